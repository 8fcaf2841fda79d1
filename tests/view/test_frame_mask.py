"""The live viewer draws its full-screen passes only over the mesh's column spans (scissor boxes per band of rows)
and clears a target only where an earlier frame wrote outside them (headless Chromium through ssskit.view.browser;
skipped without it). After orbit and zoom steps that move the mesh, every background pixel must still hold the
background value: the G-buffer's (no SSS: depth -1), each pass's (its input there), the composite's grey."""
import base64
import json

import numpy as np
import pytest

from ssskit.view.browser import browser_available, headless_page
from tests.view.pages import read_target, static_bust

ok, why = browser_available()
pytestmark = pytest.mark.skipif(not ok, reason=why)

W, H = 192, 144


def _read(pg, name):
    return read_target(pg, name, W, H)


def _display(pg):
    raw = base64.b64decode(pg.evaluate("() => window.ssskit.readDisplay()"))
    return np.frombuffer(raw, np.uint8).reshape(H, W, 4)[::-1]


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    out = static_bust(tmp_path_factory)
    with headless_page(width=W + 320, height=max(H, 500)) as (pg, log):
        pg.goto((out / "index.html").as_uri() + f"?w={W}&h={H}")
        pg.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=30_000)
        yield pg, log


@pytest.mark.parametrize("pass_", ["separable", "burley", "adaptive"])
def test_background_holds_its_value_after_the_mesh_moves(page, pass_):
    pg, log = page
    pg.evaluate(f"() => window.ssskit.set({json.dumps({'pass': pass_, 'auto': False, 'transmission': True})})")
    pg.evaluate("() => window.ssskit.render()")
    first = _read(pg, "src")[..., 3] > 0
    # a close view (the mesh fills the frame), then an orbit away and the first distance again: the spans shrink and move
    pg.evaluate("() => { const e = new WheelEvent('wheel', {deltaY: -900}); document.getElementById('view').dispatchEvent(e); }")
    pg.evaluate("() => window.ssskit.render()")
    close = _read(pg, "src")[..., 3] > 0
    pg.evaluate("() => window.ssskit.orbit(0.9, 0.3)")
    pg.evaluate("() => { const e = new WheelEvent('wheel', {deltaY: 900}); document.getElementById('view').dispatchEvent(e); }")
    timing = pg.evaluate("() => window.ssskit.render()")
    src = _read(pg, "src")
    mesh = src[..., 3] > 0
    assert close.mean() > max(first.mean(), mesh.mean()) and mesh.mean() > 0.01   # the mesh grew, then moved and shrank
    assert timing["coverage"] < 0.9
    bg = ~mesh
    assert np.all(src[bg] == np.array([0, 0, 0, -1], np.float32))
    assert np.all(_read(pg, "result")[bg][:, :3] == 0)
    for layer in ("spec", "albedo", "light"):
        assert np.all(_read(pg, layer)[bg] == 0), layer
    assert np.all(_read(pg, "transmission")[bg][:, :3] == 0)   # its own pass (drawn on the whole frame): alpha 1
    assert np.all(_read(pg, "id")[bg][:, 0] == 0)    # R32F, read as RGBA: alpha 1
    if pass_ == "adaptive":
        assert np.all(_read(pg, "taa")[bg] == 0)
    shown = _display(pg)[..., :3]
    assert np.all(shown[bg] == 33)           # the composite's background, 0.13 in 8 bits
    log.check()


def test_the_gbuffer_is_drawn_again_only_when_what_it_shows_changes(page):
    pg, log = page
    pg.evaluate("() => window.ssskit.set({pass: 'separable', auto: false, transmission: false})")
    pg.evaluate("() => window.ssskit.render()")
    before = _read(pg, "src")
    again = pg.evaluate("() => window.ssskit.render()")
    assert again["gbuffer_reused"]
    assert np.array_equal(_read(pg, "src"), before)
    pg.evaluate("() => window.ssskit.set({light: {az: 0.5, el: 0, scale: 1}})")
    lit = pg.evaluate("() => window.ssskit.render()")
    assert not lit["gbuffer_reused"] and not np.array_equal(_read(pg, "src"), before)
    pg.evaluate("() => window.ssskit.set({light: {az: 0, el: 0, scale: 1}, reuse_gbuffer: false})")
    pg.evaluate("() => window.ssskit.render()")
    assert not pg.evaluate("() => window.ssskit.render()")["gbuffer_reused"]     # the benchmarks' setting
    assert np.array_equal(_read(pg, "src"), before)
    pg.evaluate("() => window.ssskit.set({reuse_gbuffer: true})")
    log.check()
