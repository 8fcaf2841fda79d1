"""The path-traced reference beside the viewer's frame: the server's levels per region over the rows the page shows
(against ssskit.metrics.region_level on a synthetic reference whose level is known), the page's own region levels
against numpy on the page's read-back frame, the reference drawn unfiltered, and what the page says when the camera
moved or no reference is cached. The head's real references (docs/head_references.json) where this machine's cache
holds them."""
import base64
import json

import numpy as np
import pytest

from ssskit.errors import SceneError
from ssskit.view.browser import browser_available, headless_page
from tests.view.serving import running

ok, why = browser_available()

#: the reference grid (docs/head_references.json's size) and the page's size in the browser test (4:3 and 16:9)
RW, RH = 96, 72
W, H = 160, 90
#: the synthetic reference's known effective albedo
LEVEL = 0.5


def synthetic_layers(view, material):
    """A reference of known level: image = LEVEL x E / pi + specular, three regions (column thirds of the head's
    middle), a per-pixel SE; the camera's own G-buffer is not needed for the levels' arithmetic."""
    if material != "skin1":
        raise SceneError(f"no path-traced reference of the head's {view} view with {material} is cached here")
    rng = np.random.default_rng(7)
    e = rng.uniform(0.2, 1.0, (RH, RW, 3))
    spec = rng.uniform(0.0, 0.1, (RH, RW, 3))
    masks = {}
    cols = np.arange(RW)[None, :].repeat(RH, 0)
    rows = np.arange(RH)[:, None].repeat(RW, 1)
    body = (rows >= 10) & (rows < 66)
    for i, name in enumerate(("left", "middle", "right")):
        masks[name] = body & (cols >= 30 + 12 * i) & (cols < 42 + 12 * i)
    masks["empty"] = np.zeros((RH, RW), bool)
    return {"image": LEVEL * e + spec, "pixel_se": np.full((RH, RW, 3), 0.01), "specular": spec, "e_over_pi": e,
            "mask": body, "masks": masks, "spp": 64, "converged": True, "driving_region": "middle"}


def test_reference_levels_over_the_rows_the_page_shows():
    """Levels of LEVEL exactly, with region_level's standard error, over the rows a 16:9 frame shows of a 4:3
    reference (rows 9 to 63 of 72: 72 / 2 -+ 90 / 2 x 96 / 160), and over all rows."""
    from ssskit.metrics import region_level
    from ssskit.view.site import reference_payload

    layers = synthetic_layers("front", "skin1")
    got = reference_payload(layers, W, H)
    assert got["rows"] == [9, 63] and got["size"] == [RW, RH] and got["regions"] == ["left", "middle", "right", "empty"]
    labels = np.frombuffer(base64.b64decode(got["labels"]), np.uint8).reshape(RH, RW)
    shown = np.zeros((RH, RW), bool)
    shown[9:63] = True
    for i, name in enumerate(got["regions"]):
        m = layers["masks"][name]
        assert np.array_equal(labels == i + 1, m)
        if not m.any():
            assert got["levels"][name]["level"] is None and got["levels"][name]["pixels"] == 0
            continue
        want = region_level(layers["image"] - layers["specular"], layers["e_over_pi"], m & shown, layers["pixel_se"])
        assert got["levels"][name]["pixels"] == int((m & shown).sum()) < int(m.sum())
        np.testing.assert_allclose(got["levels"][name]["level"], LEVEL, rtol=1e-12)
        np.testing.assert_allclose(got["levels"][name]["se"], want["se"], rtol=1e-12)
        np.testing.assert_allclose(got["levels_all"][name]["level"], LEVEL, rtol=1e-12)
    json.dumps(got, allow_nan=False)                        # JSON as the page reads it: no NaN


def test_the_heads_cached_references_give_the_documented_levels():
    """The layers the served head page reads give docs/head_references.json's levels (the same renders), where
    this machine's reference cache holds them."""
    from pathlib import Path

    from ssskit.figures.head import cached_reference_layers
    from ssskit.view.site import reference_payload

    doc = json.loads((Path(__file__).parents[2] / "docs" / "head_references.json").read_text())
    row = doc["rows"][0]
    try:
        layers = cached_reference_layers(row["view"], row["material"])
    except SceneError as exc:
        pytest.skip(f"not cached here: {exc}")
    got = reference_payload(layers, *row["size"])
    for name, want in row["regions"].items():
        if name == "all" or not want["pixels"]:
            continue
        assert got["levels"][name]["pixels"] == want["pixels"]
        np.testing.assert_allclose(got["levels"][name]["level"], want["level"], rtol=1e-12)
        np.testing.assert_allclose(got["levels"][name]["se"], want["se"], rtol=1e-12)


@pytest.fixture(scope="module")
def head_page():
    if not ok:
        pytest.skip(why)
    from ssskit.view.site import MaterialRequest, page_data

    data = page_data("head", {"skin1": MaterialRequest("skin1")}, "skin1", served=True)
    with running(data, synthetic_layers) as (srv, _), headless_page(width=W + 900, height=900) as (pg, plog):
        pg.goto(srv.url + f"?w={W}&h={H}")
        pg.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=120_000)
        pg.evaluate("() => window.ssskit.ready()")
        yield pg, plog, srv


def read(pg, name):
    raw = base64.b64decode(pg.evaluate(f"() => window.ssskit.read('{name}')"))
    return np.frombuffer(raw, np.float32).reshape(H, W, 4)[::-1].astype(np.float64)


def test_the_page_shows_the_reference_unfiltered_and_its_own_region_levels(head_page):
    pg, plog, _ = head_page
    assert pg.evaluate("() => document.getElementById('viewsel').value") == "front"
    pg.evaluate("() => window.ssskit.set({pass: 'separable', transmission: false, auto: false})")
    pg.evaluate("() => window.ssskit.showReference(true)")
    pg.evaluate("() => window.ssskit.render()")
    got = pg.evaluate("() => window.ssskit.referenceLevels()")
    assert got["moved"] == ""
    layers = synthetic_layers("front", "skin1")
    np.testing.assert_allclose(got["reference"]["middle"]["level"], LEVEL, rtol=1e-12)

    # the page's levels, again in numpy from its read-back frame: page pixel centre -> reference pixel
    src, sss, alb = read(pg, "src"), read(pg, "result"), read(pg, "albedo")
    y, x = np.mgrid[0:H, 0:W]
    col = np.floor((x + 0.5) * RW / W).astype(int)
    row = np.floor(RH / 2 + (y + 0.5 - H / 2) * RW / W).astype(int)
    inside = (row >= 0) & (row < RH) & (alb[..., 3] != 0)
    for name in ("left", "middle", "right"):
        m = inside & layers["masks"][name][np.clip(row, 0, RH - 1), col]
        want = (alb[..., :3] * sss[..., :3])[m].sum(axis=0) / src[..., :3][m].sum(axis=0)
        assert got["page"][name]["pixels"] == int(m.sum()) > 0
        np.testing.assert_allclose(got["page"][name]["level"], want, rtol=1e-5)
    assert got["page"]["empty"]["level"] is None

    # the reference drawn as it is: one canvas pixel per reference pixel, the composite's display mapping
    drawn = np.array(pg.evaluate("() => Array.from(document.getElementById('refimg').getContext('2d')"
                                 ".getImageData(0, 0, 96, 72).data)"), float).reshape(RH, RW, 4)[..., :3]
    c = layers["image"] / (1 + layers["image"])
    want = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055) * 255
    assert np.abs(drawn - want).max() <= 0.5 + 1e-6
    assert pg.evaluate("() => getComputedStyle(document.getElementById('refimg')).imageRendering") == "pixelated"
    plog.check()


def test_the_page_says_when_the_camera_moved_or_no_reference_is_cached(head_page):
    pg, plog, _ = head_page
    pg.evaluate("() => window.ssskit.showReference(true)")
    pg.evaluate("() => window.ssskit.orbit(0.3, 0)")
    pg.evaluate("() => window.ssskit.render()")
    got = pg.evaluate("() => window.ssskit.referenceLevels()")
    assert got["page"] is None and "the camera moved from the front view" in got["moved"]
    assert "the camera moved" in pg.evaluate("() => document.getElementById('refnote').textContent")
    pg.select_option("#viewsel", "front")                  # back at the view
    pg.evaluate("() => window.ssskit.render()")
    assert pg.evaluate("() => window.ssskit.referenceLevels()")["moved"] == ""
    pg.select_option("#material", "marble")
    pg.evaluate("() => window.ssskit.ready()")
    pg.wait_for_function("() => document.getElementById('refnote').textContent.includes('no path-traced reference')",
                         timeout=60_000)
    pg.select_option("#material", "skin1")
    pg.evaluate("() => window.ssskit.showReference(false)")
    log_errors = [e for e in plog.errors if "status of 404" not in e]   # the 404 of the missing reference
    assert not log_errors and not plog.blocked


def test_the_reference_route_answers_the_levels_or_says_why_not():
    """POST /api/reference: the payload of the provider's layers for the page's size; a preset without a cached
    reference and a scene without references each get a 404 naming why, and one logged line."""
    import http.client

    from ssskit.view.site import reference_payload

    def ask(srv, body):
        conn = http.client.HTTPConnection("127.0.0.1", srv.port, timeout=60)
        conn.request("POST", "/api/reference", json.dumps(body), {"Content-Type": "application/json"})
        r = conn.getresponse()
        return r.status, json.loads(r.read())

    data = {"scene": {"views": {"front": {}, "ear": {}}}}
    for references, cases in ((synthetic_layers, ((("front", "skin1"), 200), (("ear", "marble"), 404))),
                              (None, ((("front", "skin1"), 404),))):
        with running(data, references) as (srv, log):
            for (view, material), status in cases:
                got_status, got = ask(srv, {"view": view, "material": material, "w": W, "h": H})
                assert got_status == status, got
                if status == 200:
                    assert got == json.loads(json.dumps(reference_payload(synthetic_layers(view, material), W, H)))
                else:
                    assert ("no path-traced reference" in got["error"] if references else
                            "has no path-traced references" in got["error"])
            assert log.getvalue().count("\n") == sum(s != 200 for _, s in cases)
