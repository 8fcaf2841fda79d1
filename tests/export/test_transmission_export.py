"""Engine transmission parameters from MCML tables (export.transmission): HDRP's formula as its shader writes
it, the pass model equal to it, the tint the least-squares optimum of the relative error and an HDR colour;
Unreal's fields the fit of UE's own computation, their error what UE renders with them."""

import numpy as np
import pytest

from ssskit.backends.transmission_plan import build_transmission_plan
from ssskit.export.transmission import UE_EXPORT_G, hdrp_model, hdrp_shape, hdrp_transmission, unreal_shape, unreal_transmission
from ssskit.materials import get_material
from ssskit.profiles.montecarlo.transmission import transmission_table

D = np.array([1.2, 0.5, 0.23])


def _hdrp_shader(s, volume_albedo, thickness):
    """ComputeTransmittanceDisney (HDRP DiffusionProfile.hlsl) written out: exp_13 = exp2(LOG2_E (-1/3) t S);
    volumeAlbedo (premultiplied by 1/4) * (exp_13 * (exp_13 * exp_13 + 3))."""
    exp_13 = np.exp2(1.4426950408889634 * (-1.0 / 3.0) * thickness * s)
    return volume_albedo * (exp_13 * (exp_13 * exp_13 + 3))


def test_the_pass_model_is_hdrps_formula():
    tint = np.array([0.9, 0.6, 0.3])
    t = np.linspace(0, 10, 41)
    plan = build_transmission_plan({1: hdrp_model(tint, D)})
    expect = np.stack([_hdrp_shader(1 / D[c], tint[c] / 4, t) for c in range(3)], -1)
    np.testing.assert_allclose(plan.transmittance(1, t), expect, rtol=1e-12)
    np.testing.assert_allclose(hdrp_shape(D, t) * tint, expect, rtol=1e-12)


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    import os

    old = os.environ.get("SSSKIT_CACHE_DIR")
    os.environ["SSSKIT_CACHE_DIR"] = str(tmp_path_factory.mktemp("cache"))
    try:
        yield transmission_table(get_material("skin1"), photons=20_000, seed=3)
    finally:
        if old is None:
            del os.environ["SSSKIT_CACHE_DIR"]
        else:
            os.environ["SSSKIT_CACHE_DIR"] = old


def _scattered(table):
    """MCML's scattered transmittance T_s = Tt - the unscattered beam (the thick-plate sum with sigma_t), and per
    channel the thicknesses from T_s's maximum on where T_s > 1e-3: what the engines' falling shapes are fitted to."""
    from ssskit.profiles.montecarlo.transmission import absorber_transmittance

    ball = np.stack([absorber_transmittance(table.sigma_t[c], table.thickness_mm, table.eta) for c in range(3)], -1)
    ts = table.tt - ball
    t = np.asarray(table.thickness_mm)
    return ts, (ts > 1e-3) & (t[:, None] >= t[np.argmax(ts, axis=0)][None, :])


def test_the_engines_are_fitted_to_the_scattered_part_past_its_maximum(table):
    """T_s rises from 0 at t = 0 (no medium, nothing scattered) to a maximum and falls after; the fit range starts
    there, is reported, and T_s is below Tt everywhere (the beam's share is positive)."""
    ts, m = _scattered(table)
    assert np.all(ts < table.tt) and np.all(ts[0] < ts.max(axis=0))
    out = hdrp_transmission(table, D)
    t = np.asarray(table.thickness_mm)
    assert out["thinner_than_fit_mm"] == [float(t[m[:, c]].min()) for c in range(3)]


def test_the_tint_minimises_the_relative_error(table):
    d = np.array([4.0, 2.0, 1.0])  # wide enough that the unclamped tints stay below 1
    out = hdrp_transmission(table, d)
    tint = np.array(out["tint_unclamped"])
    ts, m = _scattered(table)

    def cost(a, c):
        g = hdrp_shape(d, table.thickness_mm[m[:, c]])[:, c]
        y = ts[m[:, c], c]
        return float(np.sum(((a * g - y) / y) ** 2))

    for c in range(3):
        best = cost(tint[c], c)
        assert best <= cost(tint[c] * 1.01, c) and best <= cost(tint[c] * 0.99, c)
    assert out["thicknessRemap"][0] == 0.0 and out["thicknessRemap"][1] == table.thickness_mm[m.any(axis=1)].max()
    assert all(v >= 0 for v in out["transmissionTint"])


def test_the_hdrp_tint_is_an_hdr_colour(table):
    """HDRP declares transmissionTint [ColorUsage(false, true)] (DiffusionProfileSettings.cs: an HDR colour) and
    Validate does not clamp it: a tint above 1 (skin's blue with a reflectance d narrower than its transmitted light
    falls, 0.1 mm) is written as fitted."""
    out = hdrp_transmission(table, np.array([1.2, 0.5, 0.1]))
    assert max(out["tint_unclamped"]) > 1
    assert out["transmissionTint"] == out["tint_unclamped"]


A = np.array([0.8, 0.6, 0.45])


def test_the_unreal_fields_are_what_ue_renders(table):
    """The reported error is UE's radiance with the exported fields (UE's own table at UE's optical depth,
    the pass's unreal model, times the base colour and ApproximateHG ~ 0.5 (1 - g^2)) against MCML's scattered
    T_s E / pi, recomputed here; every field lies in UE's clamps; the search beats UE's defaults."""
    out = unreal_transmission(table, A, D)
    assert 0.01 <= out["ExtinctionScale"] <= 100 and 0.1 <= out["DistanceScale"] <= 10
    assert all(0.009 <= v <= 1 for v in out["TransmissionTintColor"]) and out["ScatteringDistribution"] == UE_EXPORT_G
    t = table.thickness_mm
    phase = 0.5 * (1 - UE_EXPORT_G ** 2)

    ts, fit = _scattered(table)

    def errors(ext, ds, tint):
        ue = A * np.asarray(tint) * unreal_shape(D, t, ext, 0.08, ds) * phase
        rel = []
        for c in range(3):
            m = fit[:, c]
            rel.append(np.abs(ue[m, c] - ts[m, c] / np.pi) / (ts[m, c] / np.pi))
        return rel

    rel = errors(out["ExtinctionScale"], out["DistanceScale"], out["TransmissionTintColor"])
    np.testing.assert_allclose([r.max() for r in rel], out["max_rel_error"], rtol=1e-9)
    np.testing.assert_allclose([np.sqrt(np.mean(r ** 2)) for r in rel], out["rms_rel_error"], rtol=1e-9)
    default = errors(1.0, 1.0, (1.0, 1.0, 1.0))
    assert sum(float(np.sum(r ** 2)) for r in rel) < sum(float(np.sum(r ** 2)) for r in default)
