"""ssskit view in a real browser (headless Chromium through ssskit.view.browser; skipped without it): the static
page draws a finite frame with a frame time and no console error; its G-buffer read back as float32 and fed to the
numpy oracle gives the page's separable and Burley outputs; the page runs the exported shader text; the camera and
the material change the image."""
import base64
import json
import subprocess
import sys

import numpy as np
import pytest

from ssskit.view.browser import browser_available, headless_page

ok, why = browser_available()
pytestmark = pytest.mark.skipif(not ok, reason=why)

#: the page's size in the tests (small: browser time in CI)
W, H = 192, 144


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """``ssskit view --scene bust --no-open --out DIR`` run as a user runs it (one preset beside Skin1: test time)."""
    out = tmp_path_factory.mktemp("view") / "site"
    proc = subprocess.run([sys.executable, "-m", "ssskit", "view", "--scene", "bust", "--no-open", "--out", str(out),
                           "--presets", "marble"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="module")
def page(site):
    with headless_page(width=W + 320, height=max(H, 500)) as (pg, log):
        pg.goto((site / "index.html").as_uri() + f"?w={W}&h={H}")
        pg.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=30_000)
        yield pg, log


def read(pg, name):
    """A float target of the page, (H, W, 4) float32, rows from the top (ssskit's arrays)."""
    raw = base64.b64decode(pg.evaluate(f"() => window.ssskit.read('{name}')"))
    return np.frombuffer(raw, np.float32).reshape(H, W, 4)[::-1]


def display(pg):
    raw = base64.b64decode(pg.evaluate("() => window.ssskit.readDisplay()"))
    return np.frombuffer(raw, np.uint8).reshape(H, W, 4)[::-1]


def render(pg, **state):
    pg.evaluate(f"() => window.ssskit.set({json.dumps(state)})")
    return pg.evaluate("() => window.ssskit.render()")


def test_static_page_draws_a_finite_frame_with_a_frame_time(page):
    pg, log = page
    timing = render(pg, **{"pass": "separable"})
    assert pg.evaluate("() => document.getElementById('status').textContent") == ""
    stats = pg.evaluate("() => document.getElementById('stats').textContent")
    assert "ms" in stats and "separable" in stats and timing["frame_ms"] > 0
    img = display(pg)[..., :3].astype(float)
    assert img.std() > 5.0                                  # not blank: the bust against the background
    assert np.isfinite(read(pg, "result")).all()
    assert (read(pg, "src")[..., 3] > 0).mean() > 0.05      # the bust covers part of the frame
    log.check()


def test_static_page_says_export_and_the_guides_limits_need_the_server(page):
    """From file:// there is no server: each engine format's button is there, disabled, and says it needs
    `ssskit view`; the adaptive guide's limits (baked into the precomputed shaders) likewise; the history's
    frames, a setting of the page itself, stays."""
    from ssskit.export import FORMATS

    pg, log = page
    buttons = pg.evaluate("() => [...document.querySelectorAll('#exports button')].map((b) => [b.id, b.disabled, b.title])")
    assert sorted(b[0] for b in buttons) == sorted(f"export_{f.name}" for _, f in FORMATS.items() if f.kind == "engine")
    assert all(disabled and "ssskit view" in title for _, disabled, title in buttons)
    assert "needs the served page: run ssskit view" in pg.evaluate("() => document.getElementById('export_note').textContent")
    inputs = dict(pg.evaluate("() => [...document.querySelectorAll('#adaptive_limits input')].map((i) => [i.id, i.disabled])"))
    assert inputs == {"ad_b_min": True, "ad_b_max": True, "ad_sigma0_sq": True, "ad_kappa": True, "ad_alpha": True,
                      "ad_frames": False}
    log.check()


def _gbuffer(pg):
    src = read(pg, "src").astype(np.float64)
    slots = (src[..., 3] > 0).astype(np.int64)
    depth = np.where(slots > 0, src[..., 3], 1.0)
    return src[..., :3], depth, slots


def test_separable_pass_matches_the_numpy_oracle_on_the_pages_gbuffer(page):
    """Tolerance: the gl backend's float32 bound (tests/conftest.py TOLERANCES, 1e-5) per unit of the brightest
    diffuse value, on every pixel."""
    from ssskit.backends import build_separable_plan
    from ssskit.backends.numpy_backend import NumpyBackend
    from ssskit.screenspace.separable import default_depth_mode
    from ssskit.view.site import MaterialRequest, kernel_taps
    from tests.conftest import TOLERANCES

    pg, log = page
    timing = render(pg, **{"pass": "separable", "frame": 0, "seed": 0})
    e, depth, slots = _gbuffer(pg)
    got = read(pg, "result")[..., :3]
    _, _, taps = kernel_taps(MaterialRequest("skin1"))
    plan = build_separable_plan({1: taps}, timing["fx"], timing["fy"], jitter=0.1, depth_mode=default_depth_mode(taps))
    want = NumpyBackend().separable(plan, e, depth, slots)
    scale = max(1.0, float(e.max()))
    err = np.abs(got - want).max() / scale
    assert err <= TOLERANCES[("gl", "float32")], err
    assert np.abs(want - e).max() > 100 * TOLERANCES[("gl", "float32")] * scale   # the pass did change the image
    log.check()


def test_burley_pass_matches_the_numpy_oracle_on_the_pages_gbuffer(page):
    """Tolerance as the gl backend's Burley test (tests/backends/test_gl.py): at most 0.2% of pixels off by more
    than 1e-5 per unit of the brightest value (a sample within float32 rounding of a texel edge may land on the
    neighbouring texel)."""
    from ssskit.backends.burley_plan import build_burley_plan
    from ssskit.backends.numpy_backend import NumpyBackend
    from ssskit.materials import get_material
    from ssskit.screenspace.burley import burley_params_for_material
    from tests.conftest import TOLERANCES

    pg, log = page
    timing = render(pg, **{"pass": "burley", "spp": 8, "frame": 0, "seed": 0})
    e, depth, slots = _gbuffer(pg)
    got = read(pg, "result")[..., :3]
    plan = build_burley_plan({1: burley_params_for_material(get_material("skin1"))}, timing["fx"], timing["fy"])
    want = NumpyBackend().burley(plan, e, depth, slots, 8)
    scale = max(1.0, float(e.max()))
    off = float((np.abs(got - want) > TOLERANCES[("gl", "float32")] * scale).mean())
    assert off <= 0.002, off
    log.check()


def test_the_page_runs_the_exported_shader_text(page, tmp_path):
    """`ssskit export --format glsl-shader --out X.frag` writes the text the page runs (less the comment line
    export adds after #version), and the gl backend's compute shader holds the same per-pixel body."""
    from importlib import resources

    from ssskit.backends.gl.separable import separable_source
    from ssskit.backends import build_separable_plan
    from ssskit.screenspace.separable import default_depth_mode
    from ssskit.view.site import MaterialRequest, kernel_taps

    pg, _ = page
    render(pg, **{"material": "skin1"})
    shader = pg.evaluate("() => window.ssskit.shader('separable')")
    out = tmp_path / "sss.frag"
    proc = subprocess.run([sys.executable, "-m", "ssskit", "export", "--material", "skin1", "--model", "dipole",
                           "--kernel", "preintegrated", "--taps", "7", "--format", "glsl-shader", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = out.read_text().splitlines(keepends=True)
    assert lines[1].startswith("// ssskit export")
    assert "".join(lines[:1] + lines[2:]) == shader
    body = resources.files("ssskit.backends.gl").joinpath("separable.glsl").read_text()
    _, _, taps = kernel_taps(MaterialRequest("skin1"))
    plan = build_separable_plan({1: taps}, 1.0, 1.0, jitter=0.1, depth_mode=default_depth_mode(taps))
    assert body.rstrip() in shader and body.rstrip() in separable_source(plan, 0, False)

    # the transmittance pass: `ssskit export --pass transmission --out X.frag` is the page's text
    out = tmp_path / "transmission.frag"
    proc = subprocess.run([sys.executable, "-m", "ssskit", "export", "--material", "skin1", "--pass", "transmission",
                           "--format", "glsl-shader", "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = out.read_text().splitlines(keepends=True)
    assert "".join(lines[:1] + lines[2:]) == pg.evaluate("() => window.ssskit.shader('transmission')")

    # the Burley pass: `ssskit export --pass burley --out X.frag` is the page's text, and its per-pixel body is
    # the one the gl backend's compute shader (`--out X.comp`) holds
    out = tmp_path / "burley.frag"
    proc = subprocess.run([sys.executable, "-m", "ssskit", "export", "--material", "skin1", "--pass", "burley",
                           "--format", "glsl-shader", "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = out.read_text().splitlines(keepends=True)
    assert lines[1].startswith("// ssskit export: the Burley pass")
    assert "".join(lines[:1] + lines[2:]) == pg.evaluate("() => window.ssskit.shader('burley')")
    comp = tmp_path / "burley.comp"
    proc = subprocess.run([sys.executable, "-m", "ssskit", "export", "--material", "skin1", "--pass", "burley",
                           "--format", "glsl-shader", "--out", str(comp)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    body = resources.files("ssskit.backends.gl").joinpath("burley.glsl").read_text().rstrip()
    assert body in out.read_text() and body in comp.read_text() and comp.read_text().count("#version 430") == 1


def test_every_pass_of_the_page_shares_its_body_with_the_gl_backend(page):
    """One source per pass: the page's Burley, adaptive and transmittance shaders and the gl backend's compute
    shaders for the same plans hold the same per-pixel body file."""
    from importlib import resources

    from ssskit.backends.adaptive_plan import as_plan
    from ssskit.backends.burley_plan import build_burley_plan
    from ssskit.backends.gl.adaptive import adaptive_source
    from ssskit.backends.gl.burley import burley_source
    from ssskit.backends.gl.transmission import transmission_source
    from ssskit.backends.transmission_plan import build_transmission_plan
    from ssskit.materials import get_material
    from ssskit.screenspace.adaptive import AdaptiveSettings
    from ssskit.screenspace.burley import burley_params_for_material
    from ssskit.screenspace.transmission import mcml_model

    pg, _ = page
    render(pg, **{"material": "skin1"})
    mat = pg.evaluate("() => window.SSSKIT_DATA.materials.skin1")
    skin = get_material("skin1")
    bplan = build_burley_plan({1: burley_params_for_material(skin)}, 1.0, 1.0)
    guide = as_plan(AdaptiveSettings())
    files = resources.files("ssskit.backends.gl")
    for body, page_text, compute in (
            ("burley.glsl", mat["burley"]["shader"], burley_source(bplan)),
            ("burley.glsl", mat["adaptive"]["burley"], burley_source(bplan, count_image=True)),
            ("adaptive.glsl", mat["adaptive"]["update"], adaptive_source(guide, True)),
            ("adaptive.glsl", mat["adaptive"]["estimate"], adaptive_source(guide, False)),
            ("transmission.glsl", mat["transmission"]["shader"],
             transmission_source(build_transmission_plan({1: mcml_model(skin)})))):
        text = files.joinpath(body).read_text().rstrip()
        assert text in page_text and text in compute, body
        assert page_text.startswith("#version 300 es\n") and compute.count("#version 430") == 1


def test_camera_and_material_change_the_image(page):
    pg, log = page
    render(pg, **{"pass": "separable", "material": "skin1"})
    a = display(pg).astype(int)
    pg.evaluate("() => window.ssskit.orbit(0.4, 0.0)")
    render(pg)
    b = display(pg).astype(int)
    pg.evaluate("() => window.ssskit.orbit(-0.4, 0.0)")
    render(pg, material="marble")
    c = display(pg).astype(int)
    assert np.abs(a - b).mean() > 1.0
    assert np.abs(a - c).mean() > 1.0
    render(pg, material="skin1")
    assert np.array_equal(display(pg).astype(int), a)      # and back: the same frame
    log.check()


@pytest.mark.slow  # browser time: CI's slow set runs it
def test_adaptive_pass_matches_the_numpy_oracle_over_three_frames(page):
    """Xie 2020 Sec. 4.1 on a static camera: the page's estimate, three Burley frames at its counts and three
    history updates against the numpy oracle (ssskit.backends.adaptive_plan's reference functions and the numpy
    Burley pass, frames 0-2, seed 0). Tolerances: the Burley result as in the Burley test (0.2% of pixels beyond
    1e-5 of the brightest value); counts and history may differ only where a result or a float32 count estimate
    did (the module docstring of adaptive_plan), on at most 0.5% of the pixels."""
    from ssskit.backends.adaptive_plan import as_plan
    from ssskit.backends.burley_plan import build_burley_plan
    from ssskit.backends.numpy_backend import NumpyBackend
    from ssskit.materials import get_material
    from ssskit.screenspace.adaptive import AdaptiveSettings
    from ssskit.screenspace.burley import burley_params_for_material
    from tests.conftest import TOLERANCES

    pg, log = page
    render(pg, **{"auto": False, "pass": "adaptive", "material": "skin1", "seed": 0})   # frame 0 of a new history
    timing = render(pg)
    render(pg)
    assert pg.evaluate("() => window.ssskit.adaptiveFrames()") == 3
    e, depth, slots = _gbuffer(pg)
    got = read(pg, "result")[..., :3]
    got_hist = read(pg, "history")
    raw = base64.b64decode(pg.evaluate("() => window.ssskit.readCounts('next')"))
    got_counts = np.frombuffer(raw, np.int32).reshape(H, W)[::-1]

    guide = as_plan(AdaptiveSettings())
    params = {1: burley_params_for_material(get_material("skin1"))}
    mask = slots > 0
    hist = np.zeros((H, W, 4), np.float32)
    oracle = NumpyBackend()  # the reference functions of adaptive_plan, on inputs checked by the Backend
    counts = oracle.adaptive_counts(guide, hist, mask)
    for f in range(3):
        plan = build_burley_plan(params, timing["fx"], timing["fy"], frame=f)
        rgb = oracle.burley(plan, e, depth, slots, counts)
        hist, counts = oracle.adaptive_update(guide, hist, rgb, counts, mask)
    scale = max(1.0, float(e.max()))
    assert float((np.abs(got - rgb) > TOLERANCES[("gl", "float32")] * scale).mean()) <= 0.002
    assert float((got_counts != counts).mean()) <= 0.005
    assert counts[mask].max() > guide.b_min                   # the guide did move the counts off the floor
    close = np.isclose(got_hist, hist, rtol=1e-4, atol=1e-7).all(axis=-1)
    assert float((~close).mean()) <= 0.005
    render(pg, **{"heat": True})
    heat = display(pg)
    assert heat[mask][:, :3].std() > 1.0                       # the heat map shows the counts
    render(pg, **{"heat": False, "auto": True, "pass": "separable"})
    log.check()


@pytest.mark.slow  # browser time: CI's slow set runs it
def test_transmittance_pass_matches_the_numpy_oracle(page):
    """The key light turned behind the bust: the page's transmittance output against the numpy oracle on the page's
    own inputs (its light map, the G-buffer's light-space positions and N . L, the light's irradiance), the material's
    MCML model. Tolerance: 1e-5 of the light's irradiance per pixel, except where the float32 t = z - D sits within
    rounding of the bias (at most 0.2% of the pixels)."""
    from ssskit.backends.numpy_backend import NumpyBackend
    from ssskit.backends.transmission_plan import build_transmission_plan
    from ssskit.materials import get_material
    from ssskit.screenspace.transmission import mcml_model

    pg, log = page
    render(pg, **{"pass": "off", "material": "skin1", "transmission": True, "light": {"az": 2.6, "el": 0.3, "scale": 1}})
    got = read(pg, "transmission")[..., :3].astype(np.float64)
    ls = read(pg, "light").astype(np.float64)
    slots = np.rint(read(pg, "id")[..., 0]).astype(np.int64)
    n = pg.evaluate("() => window.ssskit.lightMapSize")
    shadow = np.frombuffer(base64.b64decode(pg.evaluate("() => window.ssskit.readLightMap()")), np.float32)
    shadow = shadow.reshape(n, n).astype(np.float64)
    light = np.broadcast_to(np.asarray(pg.evaluate("() => window.ssskit.lightRgb()"), float), (H, W, 3))
    plan = build_transmission_plan({1: mcml_model(get_material("skin1"))})
    want = NumpyBackend().transmission(plan, slots, ls[..., :3], shadow, ls[..., 3], np.ascontiguousarray(light))
    assert want.max() > 1e-3 * light.max()                    # light does come through (the ears, the nose)
    off = np.abs(got - want).max(axis=-1) > 1e-5 * light.max()
    assert float(off.mean()) <= 0.002, float(off.mean())
    render(pg, **{"light": {"az": 0, "el": 0, "scale": 1}, "pass": "separable"})
    log.check()


def _linear(srgb8):
    x = srgb8.astype(np.float64) / 255.0
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


@pytest.mark.slow  # browser time: CI's slow set runs it
def test_each_pass_matches_its_golden_screenshot_by_flip(page):
    """Each pass's displayed frame against tests/view/goldens/<pass>.png (regenerate: PYTHONPATH=src python -m
    tests.view.goldens). Bound: mean FLIP (ssskit.metrics.flip, the sRGB frames linearised) below 1e-3; the passes
    differ from one another by about 3e-3 at this size, which the test checks too, so it tells them apart."""
    import imageio.v3 as iio

    from ssskit.metrics import flip
    from tests.view import goldens

    pg, log = page
    shots = goldens.frames(pg)
    golden = {name: iio.imread(goldens.HERE / f"{name}.png") for name in goldens.STATES}
    for name, img in shots.items():
        assert img.shape == golden[name].shape, name
        assert flip(_linear(golden[name]), _linear(img)) < 1e-3, name
    assert flip(_linear(golden["off"]), _linear(shots["separable"])) > 1e-3
    log.check()
