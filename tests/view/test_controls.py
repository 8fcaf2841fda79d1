"""The served viewer's controls in a real browser (headless Chromium through ssskit.view.browser; skipped without it):
the export buttons download the bytes `ssskit export` writes, the adaptive limits are checked with Python's ranges
before any request and reach the page's shaders, and a preset chosen in the page is computed by the server."""
import base64
import subprocess
import sys

import numpy as np
import pytest

from ssskit.view.browser import browser_available, headless_page

ok, why = browser_available()
pytestmark = pytest.mark.skipif(not ok, reason=why)

W, H = 160, 120


@pytest.fixture(scope="module")
def served():
    """``ssskit view --scene icosphere`` served on a free port (the server's code, in this process), and the page."""
    from ssskit.view.site import MaterialRequest, page_data
    from tests.view.serving import running

    data = page_data("icosphere", {"skin1": MaterialRequest("skin1")}, "skin1", served=True)
    with running(data) as (srv, log), headless_page(width=W + 420, height=900) as (pg, plog):
        pg.goto(srv.url + f"?w={W}&h={H}")
        pg.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=60_000)
        pg.evaluate("() => window.ssskit.ready()")
        yield pg, plog, srv, log


def display(pg):
    raw = base64.b64decode(pg.evaluate("() => window.ssskit.readDisplay()"))
    return np.frombuffer(raw, np.uint8).reshape(H, W, 4)[::-1, :, :3].astype(int)


def status(pg):
    """What the page said: the render loop's errors and the controls' notices."""
    return pg.evaluate("() => document.getElementById('status').textContent + document.getElementById('notice').textContent")


def test_a_preset_chosen_in_the_page_is_computed_by_the_server_and_drawn(served):
    pg, plog, _, _ = served
    assert pg.evaluate("() => Object.keys(window.SSSKIT_DATA.materials.skin1)").count("transmission") == 1
    pg.evaluate("() => window.ssskit.render()")
    before = display(pg)
    options = pg.evaluate("() => [...document.getElementById('material').options].map((o) => o.value)")
    assert {"skin1", "skin2", "marble", "ketchup", "apple"} <= set(options)
    pg.select_option("#material", "marble")
    pg.evaluate("() => window.ssskit.ready()")
    marble = pg.evaluate("() => window.SSSKIT_DATA.materials.marble")
    assert pg.evaluate("() => window.ssskit.render()") and "shader" in marble["transmission"]
    assert "burley" not in marble            # the separable pass does not need it: not computed
    assert np.abs(display(pg) - before).mean() > 1.0
    assert status(pg) == ""
    plog.check()


def test_export_buttons_download_what_ssskit_export_writes(served, tmp_path):
    pg, plog, _, _ = served
    pg.select_option("#material", "marble")
    pg.evaluate("() => window.ssskit.ready()")
    for name, suffix in (("unreal", ".json"), ("materialx", ".mtlx"), ("blender", ".py")):
        pg.select_option(f"#export_suffix_{name}", suffix)
        with pg.expect_download() as dl:
            pg.click(f"#export_{name}")
        got = dl.value
        assert got.suggested_filename == f"marble_{name}{suffix}"
        out = tmp_path / got.suggested_filename
        proc = subprocess.run([sys.executable, "-m", "ssskit", "export", "--format", name, "--material", "marble",
                               "--out", str(out)], capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        with open(got.path(), "rb") as fh:
            assert fh.read() == out.read_bytes(), name
    plog.check()


def test_adaptive_limits_are_checked_with_pythons_ranges_and_reach_the_shaders(served):
    """A value outside AdaptivePass's range, or b_min above b_max, is refused in the page in Python's terms and
    nothing is asked of the server (its log of refusals stays empty); a valid guide comes back as the shaders of
    that guide; ``frames`` bounds the history the page renders."""
    from ssskit.backends.adaptive_plan import as_plan
    from ssskit.backends.gl.adaptive import adaptive_fragment_source
    from ssskit.screenspace.adaptive import AdaptiveSettings

    pg, plog, _, log = served
    pg.select_option("#material", "skin1")
    pg.select_option("#pass", "adaptive")
    pg.evaluate("() => window.ssskit.ready()")
    refused = log.getvalue()
    for field, value, words in (("b_min", "0", "b_min must be an integer in [1, 65536]"),
                                ("alpha", "0", "alpha must be a number in (0, 1]"),
                                ("sigma0_sq", "-1e-3", "sigma0_sq must be a number in (0, inf)"),
                                ("b_min", "2.5", "b_min must be an integer"),
                                ("b_min", "100", "the sample budget needs b_min <= b_max, got b_min=100 > b_max=64")):
        pg.fill(f"#ad_{field}", value)
        pg.dispatch_event(f"#ad_{field}", "change")
        pg.evaluate("() => window.ssskit.ready()")
        assert words in status(pg), (field, value, status(pg))
        pg.fill(f"#ad_{field}", {"b_min": "8", "alpha": "0.2", "sigma0_sq": "0.001"}[field])
    assert log.getvalue() == refused
    pg.fill("#ad_frames", "3")
    pg.dispatch_event("#ad_frames", "change")
    pg.fill("#ad_b_min", "4")
    pg.fill("#ad_b_max", "24")
    pg.dispatch_event("#ad_b_max", "change")      # a new guide: a new history, of 3 frames
    pg.evaluate("() => window.ssskit.ready()")
    got = pg.evaluate("() => window.SSSKIT_DATA.materials.skin1.adaptive")
    assert got["estimate"] == adaptive_fragment_source(as_plan(AdaptiveSettings(b_min=4, b_max=24)), False)
    pg.wait_for_function("() => window.ssskit.adaptiveFrames() >= 3", timeout=30_000)
    pg.wait_for_timeout(500)
    assert pg.evaluate("() => window.ssskit.adaptiveFrames()") == 3      # the history stops at frames
    assert status(pg) == ""
    pg.select_option("#pass", "separable")
    plog.check()

