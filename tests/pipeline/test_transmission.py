"""The transmittance pass in the render pipeline (ssskit.pipeline.transmission): when it runs (auto, on, off),
the light it adds to the separable and the Burley frame and to every frame of the adaptive run (before the
albedo multiply, so the composite holds T(t) E / pi), its exact limit carrying the same light, and the checks
made before any work."""

import math

import numpy as np
import pytest

from ssskit.errors import SettingsError
from ssskit.pipeline import AdaptivePass, BurleyPass, RenderSettings, SeparablePass, plan, render
from ssskit.pipeline.transmission import transmission_passes

#: the numpy backend (the float64 oracle); the dipole profile keeps the kernel cheap
BASE = dict(backend="numpy", model="dipole", perceptual=False, pass_=SeparablePass(jitter=0.0))


@pytest.fixture(scope="module")
def ear():
    """The back-lit ear's G-buffer (its key light behind it) with the light layers, and without."""
    from ssskit.scenes import render_gbuffer

    gb = render_gbuffer("ear", (0.5, 0.4, 0.3), eta=1.4, width=32, height=24, spp=1, material="skin1",
                        light_layers=True)
    return gb, gb.with_layers(light_depth=None, light=None)


def test_auto_runs_where_the_gbuffer_has_the_layers(ear):
    lit, plain = ear
    s = RenderSettings(**BASE)  # the lateral spread is off by default (its cost: docs/transmission.md)
    on, off = render(lit, s), render(lit, s.replace(transmission="off"))
    assert on.transmission.ran and on.transmission.model == "mcml" and not off.transmission.ran
    assert not render(plain, s).transmission.ran
    np.testing.assert_array_equal(render(plain, s).image, off.image)
    mask = lit.mask
    t = on.transmitted
    assert t is not None and off.transmitted is None
    # the composite holds T E / pi on top of the reflectance; the pass's sss holds it demodulated by the albedo
    np.testing.assert_allclose(on.image - off.image, t, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose((on.sss - off.sss)[mask], t[mask] / lit.albedo[mask], rtol=1e-5, atol=1e-9)
    assert not np.any(t[~mask])
    # the radiance of the pass's exitance T E taken as a Lambertian exit: T E / pi (the diffuse layer's convention)
    from ssskit.backends import get_backend
    from ssskit.materials import get_material
    from ssskit.screenspace.transmission import mcml_model, transmission_plan

    exitance = get_backend("numpy").transmission(transmission_plan({1: mcml_model(get_material("skin1"))}),
                                                 (lit.profile_id > 0).astype(np.int32), *lit.transmission_inputs())
    assert set(np.unique(lit.profile_id)) == {0, 1}
    np.testing.assert_allclose(t, exitance / math.pi, rtol=1e-6, atol=1e-12)
    # energy: the transmitted exitance pi L never exceeds the light's irradiance (T <= 1, E <= light)
    light = np.asarray(lit.light["irradiance"])
    assert np.all(math.pi * t <= light * (1 + 1e-6))
    assert np.any(t > 0)
    # the exact limit carries the same light: its metric measures the reflectance pass as before
    np.testing.assert_allclose(on.exact - off.exact, on.sss - off.sss, rtol=1e-5, atol=1e-9)
    assert on.to_dict()["transmission"] == {"setting": "auto", "ran": True, "model": "mcml",
                                            "lit_pixels": int(np.count_nonzero(np.any(t > 0, axis=-1))),
                                            "spread": "off"}
    assert any(line.startswith("# transmission: mcml model") for line in on.lines())
    # the lateral spread (transmission_spread mcml) is the spread step on the pass's exitance, the same light
    # convention
    from ssskit.backends.spread_plan import build_spread_plan
    from ssskit.screenspace.transmission import mcml_spread

    spread = render(lit, s.replace(transmission_spread="mcml"))
    assert spread.transmission.spread == "mcml"
    uvz, shadow, _, _ = lit.transmission_inputs()
    splan = build_spread_plan({1: mcml_spread(get_material("skin1"))}, lit.camera.fx, lit.camera.fy)
    want = get_backend("numpy").transmission_spread(splan, exitance, lit.depth_mm, (lit.profile_id > 0).astype(np.int32),
                                                    uvz, shadow) / math.pi
    np.testing.assert_allclose(spread.transmitted, want, rtol=1e-6, atol=1e-12)
    assert not np.allclose(spread.transmitted, t, rtol=1e-3)  # the ear's thin parts are wider than a pixel


def test_the_burley_pass_adds_the_same_light(ear):
    lit, _ = ear
    s = RenderSettings(backend="numpy", perceptual=False, exact=False, pass_=BurleyPass(spp=4))
    on, off = render(lit, s), render(lit, s.replace(transmission="off"))
    sep = render(lit, RenderSettings(**BASE, exact=False))
    assert on.transmission.ran and on.to_dict()["transmission"]["model"] == "mcml"
    np.testing.assert_allclose(on.image - off.image, on.transmitted, rtol=1e-5, atol=1e-9)
    # the transmitted light depends on the light layers and the material, not on the reflectance pass
    np.testing.assert_array_equal(on.transmitted, sep.transmitted)


def test_every_adaptive_frame_adds_the_same_light(ear, backend):
    """burley-adaptive (static, on the G-buffer with the layers) on each backend: the frames add the one-frame
    Burley pass's transmitted light (the same pass on the same G-buffer), the guiding phase does not see it
    (the same sample counts with it on or off), and the exact limit the frames are compared with carries it."""
    lit, _ = ear
    s = RenderSettings(backend=backend, perceptual=False,
                       pass_=AdaptivePass(frames=3, static=True, b_min=2, b_max=8, taa=False))
    on, off = render(lit, s), render(lit, s.replace(transmission="off"))
    assert on.transmission.ran and not off.transmission.ran and on.transmission.model == "mcml"
    assert on.to_dict()["transmission"]["ran"] and not off.to_dict()["transmission"]["ran"]
    assert any(line.startswith("# transmission: mcml model") for line in on.lines())
    assert [r["mean_spp"] for r in on.rows] == [r["mean_spp"] for r in off.rows]
    np.testing.assert_array_equal(on.run.counts if on.run.counts is not None else 0,
                                  off.run.counts if off.run.counts is not None else 0)
    t = on.layers["transmission"]
    one = render(lit, RenderSettings(backend=backend, perceptual=False, exact=False, pass_=BurleyPass(spp=8)))
    np.testing.assert_array_equal(t, one.transmitted)
    assert "transmission" not in off.layers and np.any(t > 0)
    scale = float(np.abs(on.image).max())
    np.testing.assert_allclose(on.image - off.image, t, rtol=1e-5, atol=1e-6 * scale)
    # the exact limit got the same light: the frames' error against it is the reflectance pass's
    np.testing.assert_allclose(on.fixed.exact - off.fixed.exact, on.fixed.sss - off.fixed.sss, rtol=1e-5,
                               atol=1e-6 * scale)
    for key in ("exact_2d", "average_exact_2d"):  # the same error (the PSNR's peak is the brighter image's)
        assert on.metrics[key]["rmse"] == pytest.approx(off.metrics[key]["rmse"], rel=1e-3)


def test_the_frame_loop_refuses_a_transmitted_light_of_the_wrong_shape(ear):
    from ssskit.errors import PassError
    from ssskit.screenspace import BurleyParams, BurleySettings, run_frames

    lit, _ = ear
    params = BurleyParams.from_dmfp((0.5, 0.4, 0.3), (1.0, 0.5, 0.25))
    with pytest.raises(PassError, match=r"the transmitted light must be a real array of shape \(\d+, \d+, 3\), got shape \(2, 2, 3\)"):
        run_frames([lit], params, BurleySettings(backend="numpy"), spp=1, transmission=lambda g: np.zeros((2, 2, 3)))
    with pytest.raises(PassError, match=r"the transmitted light must lie in \[0, inf\), got -1 in"):
        run_frames([lit], params, BurleySettings(backend="numpy"), spp=1,
                   transmission=lambda g: np.full(g.shape + (3,), -1.0))


def test_jimenez2010_is_darker_than_mcml_for_skin(ear):
    """Jimenez 2010's Gaussians at scale 1 are far darker than Skin1's MCML T(t) (docs/transmission.md's table:
    0.6 to 0.01 of it at 0.5 mm), even with their wrapped back irradiance."""
    lit, _ = ear
    s = RenderSettings(**BASE, exact=False, material="skin1")
    mc = render(lit, s).transmitted
    jm = render(lit, s.replace(transmission_model="jimenez2010")).transmitted
    assert mc[lit.mask].sum() > 0 and mc[lit.mask].sum(axis=0)[0] > jm[lit.mask].sum(axis=0)[0]


def test_unreal_model_is_ues_light_in_the_frame(ear):
    """transmission_model unreal on the back-lit ear: the pass with UE's table for the material's Burley d, the
    light times UE's phase factor per pixel, and UE's exit (the base colour times the pass's out, not T E / pi):
    the frame's transmitted layer equals that, computed from the G-buffer's inputs here (the lateral spread, a
    step of its own for any model, off)."""
    lit, _ = ear
    s = RenderSettings(**BASE, exact=False, material="skin1")
    r = render(lit, s.replace(transmission_model="unreal", transmission_spread="off"))
    assert r.transmission.ran and r.transmission.model == "unreal" and r.transmission.lit_pixels > 0
    from ssskit.backends import get_backend
    from ssskit.materials import get_material
    from ssskit.pipeline.transmission import slot_model
    from ssskit.screenspace.transmission import LightView, transmission_plan, unreal_phase

    plan_ = transmission_plan({1: slot_model("unreal", get_material("skin1"))})
    uvz, shadow, ndl, light = lit.transmission_inputs()
    pos = lit.positions()
    v = np.linalg.inv(lit.camera.world_to_camera)[:3, 3] - pos
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    n = lit.normal.astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)
    to_light = -np.asarray(LightView.from_dict(lit.light).direction)
    phase = unreal_phase(n, v, np.broadcast_to(to_light, n.shape), 0.93, 1.55)
    out = get_backend("numpy").transmission(plan_, (lit.profile_id > 0).astype(np.int32), uvz, shadow, ndl,
                                            light * phase[..., None])
    np.testing.assert_allclose(r.transmitted, lit.albedo * out, rtol=1e-6, atol=1e-12)
    assert np.any(r.transmitted > 0)


def test_exported_unreal_fields_take_ues_light_with_their_phase(ear):
    """An engine's exported UE profile given as ``models`` (kind unreal) takes UE's light and recombine like the
    ``unreal`` setting: with UE's defaults it is that setting's frame, to the last bit; with the export's
    ScatteringDistribution (``ue_phase``) the light is the irradiance times ApproximateHG of that g ([UE58]),
    computed here from the G-buffer as in the test above. Mixing unreal with other kinds is refused."""
    from ssskit.backends import get_backend
    from ssskit.errors import PassError
    from ssskit.materials import get_material
    from ssskit.pipeline.transmission import slot_model, transmission_light
    from ssskit.screenspace.burley import burley_params_for_material
    from ssskit.screenspace.transmission import LightView, mcml_model, transmission_plan, unreal_model, unreal_phase

    lit, _ = ear
    mat = get_material("skin1")
    s = RenderSettings(**BASE, material="skin1", transmission="on", transmission_spread="off")
    by_setting = transmission_light(lit, s.replace(transmission_model="unreal"), {1: mat}, lambda m: None)
    given = transmission_light(lit, s, {1: mat}, lambda m: None, {1: slot_model("unreal", mat)})
    for x, y in zip(by_setting[:2], given[:2]):
        np.testing.assert_array_equal(x, y)

    model = unreal_model(burley_params_for_material(mat).d_mm, tint=(0.5, 0.25, 1.0), extinction_scale=2.0)
    got = transmission_light(lit, s, {1: mat}, lambda m: None, {1: model}, ue_phase=(0.01, 1.3))[1]
    uvz, shadow, ndl, light = lit.transmission_inputs()
    v = np.linalg.inv(lit.camera.world_to_camera)[:3, 3] - lit.positions()
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    n = lit.normal.astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)
    to_light = -np.asarray(LightView.from_dict(lit.light).direction)
    phase = unreal_phase(n, v, np.broadcast_to(to_light, n.shape), 0.01, 1.3)
    assert np.all((phase > 0.49) & (phase < 0.51))  # g = 0.01: 0.5 (1 - g^2) / (1 - g cos)^2 within 2 %
    out = get_backend("numpy").transmission(transmission_plan({1: model}), (lit.profile_id > 0).astype(np.int32), uvz,
                                            shadow, ndl, light * phase[..., None])
    np.testing.assert_allclose(got, lit.albedo * out, rtol=1e-6, atol=1e-12)
    assert np.any(got > 0)

    two = lit.profile_id.copy()
    two[:, : two.shape[1] // 2] *= 2  # ids 1 and 2
    with pytest.raises(PassError, match="mix unreal and other kinds"):
        transmission_light(lit.with_layers(profile_id=two, materials=("skin1", "skin1")), s, {1: mat, 2: mat},
                           lambda m: None,
                           {1: model, 2: mcml_model(mat)})


def test_checks_before_any_work(ear, monkeypatch):
    lit, plain = ear
    import ssskit.pipeline.transmission as tr

    def no_work(*a, **k):
        raise AssertionError("the transmittance pass ran")

    monkeypatch.setattr(tr, "add_transmission", no_work)
    with pytest.raises(SettingsError, match="needs the G-buffer's light layers"):
        plan(plain, RenderSettings(**BASE, transmission="on"))
    with pytest.raises(SettingsError, match="needs the G-buffer's light layers"):
        plan(plain, RenderSettings(backend="numpy", transmission="on", pass_=BurleyPass()))
    assert plan(lit, RenderSettings(**BASE)).transmission
    assert not plan(lit, RenderSettings(**BASE, transmission="off")).transmission
    with pytest.raises(SettingsError, match="transmission_spread applies to transmission auto or on, not transmission off"):
        RenderSettings(**BASE, transmission="off", transmission_spread="mcml")
    # a scene renders its own G-buffer: without the layers under auto, with them under on
    assert not plan("ear", RenderSettings(**BASE)).transmission
    assert plan("ear", RenderSettings(**BASE, transmission="on")).transmission


@pytest.mark.parametrize("spread", ["off", "mcml"])
def test_a_first_frame_compiles_the_transmission_passes_it_runs(ear, monkeypatch, spread):
    """The warm-up thread of a render (separable and Burley frames) is asked for the transmittance pass and, only
    where the frame spreads the light (transmission_spread mcml; off by default), for the spread's kernels (~6.5 s
    of one core on a fresh machine): the passes the frame then runs, no more; the demo's transmission section
    (default settings) the same."""
    import importlib

    from ssskit import report

    render_module, burley_frame = (importlib.import_module(f"ssskit.pipeline.{m}") for m in ("render", "burley_frame"))

    lit, _ = ear
    asked = []
    for module in (render_module, burley_frame):
        monkeypatch.setattr(module, "warm_up_in_background", lambda backend, names: asked.append(list(names)))
    burley = RenderSettings(backend="numpy", perceptual=False, pass_=BurleyPass(spp=4))
    for settings in (RenderSettings(**BASE), burley):
        res = render(lit, settings.replace(exact=False, transmission_spread=spread))
        assert res.transmission.ran and res.transmission.spread == spread
        assert ("spread" in asked[-1]) == (spread == "mcml") and "transmission" in asked[-1]
    assert len(asked) == 2
    default = RenderSettings(transmission="on")
    assert set(transmission_passes(default, True)) <= set(report.SECTION_PASSES["transmission"])
    assert "spread" not in report.SECTION_PASSES["transmission"] and transmission_passes(default, False) == []
