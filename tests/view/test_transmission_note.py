"""A material without a transmittance pass in a real browser (headless Chromium; skipped without it): its own
module, since a module-scoped page elsewhere holds Playwright's sync API while its module runs."""
import pytest

from ssskit.view.browser import browser_available, headless_page
from tests.view.test_controls import H, W, display, status

ok, why = browser_available()
pytestmark = pytest.mark.skipif(not ok, reason=why)


def test_a_material_without_a_transmittance_pass_is_drawn_and_says_why(tmp_path, monkeypatch):
    """A material whose MCML slab table does not converge (`ssskit view --albedo 0.8,0.6,0.5 --mfp 3.7,1.4,0.7`
    here; a stand-in failure in the test) keeps its other passes: the static page draws it without transmission
    and says why."""
    import ssskit.view.site as site
    from ssskit.errors import ProfileError

    def fail(_mat):
        raise ProfileError("the transmittance is still 0.008 at the grid's last thickness (a stand-in)")

    monkeypatch.setattr(site, "_transmission_part", fail)
    out = site.write_site(tmp_path / "site", site.page_data("icosphere", {"skin1": site.MaterialRequest("skin1")},
                                                            "skin1", served=False))
    with headless_page(width=W + 420, height=900) as (pg, plog):
        pg.goto((out / "index.html").as_uri() + f"?w={W}&h={H}")
        pg.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=60_000)
        pg.evaluate("() => window.ssskit.ready()")
        assert status(pg) == ("no transmittance pass for this material: the transmittance is still 0.008 at the "
                              "grid's last thickness (a stand-in)")
        assert pg.evaluate("() => window.ssskit.drawn()")["transmission"] is False
        assert display(pg).std() > 5.0                       # the frame is drawn
        plog.check()
