"""The shared headless-browser driver: WebGL2 with float render targets, and no request leaves the machine."""
import pytest

from ssskit.view.browser import browser_available, headless_page

ok, why = browser_available()
pytestmark = pytest.mark.skipif(not ok, reason=why)


def test_webgl2_float_targets_and_offline():
    with headless_page() as (page, log):
        page.set_content("<canvas id=c></canvas>")
        caps = page.evaluate(
            """() => { const gl = document.getElementById('c').getContext('webgl2');
                       return gl && [!!gl.getExtension('EXT_color_buffer_float'), gl.getParameter(gl.MAX_DRAW_BUFFERS)]; }"""
        )
        assert caps is not None, "no WebGL2 context"
        assert caps[0] and caps[1] >= 4
        page.evaluate("() => fetch('https://example.com/never').catch(() => null)")
        page.wait_for_timeout(200)
        assert log.blocked == ["https://example.com/never"]
        with pytest.raises(AssertionError, match="blocked request"):
            log.check()
