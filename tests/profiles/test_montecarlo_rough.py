"""The MCML engine's rough top surface: Mitsuba 3's single-scattering ``roughdielectric`` (Beckmann,
Walter et al. 2007), the boundary of the path-traced references, inside the Monte Carlo profile."""

import dataclasses
import math

import numpy as np
import pytest

from ssskit.errors import ProfileError
from ssskit.materials import get_material
from ssskit.profiles.montecarlo import MCConfig, MCLayer, config_for_material, rough_boundary_albedo, simulate
from ssskit.scenes.boundary import rough_dielectric_weights

ETA = 1.3
ALPHA = 0.15  # ssskit.scenes.scenes.COAT_ROUGHNESS


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


@pytest.mark.parametrize("mu, inside", [(0.9, True), (0.5, True), (0.3, True), (0.1, True), (0.5, False)])
def test_interface_albedo_matches_mitsuba_roughdielectric(mu, inside):
    """The engine's surface reflects, transmits and loses what Mitsuba's BSDF does: from inside past
    the critical angle (cos 0.64 at eta 1.3) the single-scattering model loses 2.7% at cos 0.5, 5% at
    0.3, 8.5% at 0.1 (measured here on both sides)."""
    n1, n2 = (ETA, 1.0) if inside else (1.0, ETA)
    ours = rough_boundary_albedo(mu, n1, n2, ALPHA, samples=400_000, seed=3)
    # Mitsuba's own BSDF, sampled with its visible-normal routine (not the engine's Walter sampling)
    ref, ref_se = rough_dielectric_weights(mu, ETA, ALPHA, samples=40_000, seed=4, inside=inside)
    for k, name in enumerate(("reflected", "transmitted")):
        m, se = ours[name]
        assert abs(m - ref[k]) <= 4 * math.hypot(se, ref_se[k]) + 1e-6, (name, m, ref[k])
    lost, lost_se = ours["lost"]
    assert abs(lost - (1 - ref.sum())) <= 4 * math.hypot(lost_se, math.hypot(*ref_se)) + 1e-6
    if inside and mu <= 0.5:
        assert lost > 0.02  # the loss the path-traced slab shows: not a smooth surface


def test_nearly_smooth_surface_is_mcml(mc_backend):
    """alpha -> 0: the rough surface becomes MCML's smooth Fresnel boundary (independent streams,
    so the totals agree within their standard errors)."""
    cfg = config_for_material(get_material("skin1"), 1, photons=200_000, seed=2)
    smooth = simulate(cfg, use_cache=False, backend=mc_backend)
    rough = simulate(dataclasses.replace(cfg, roughness=1e-4, seed=3), use_cache=False, backend=mc_backend)
    for a, b, sa, sb in ((smooth.total_rd, rough.total_rd, smooth.total_rd_se, rough.total_rd_se),
                         (smooth.absorbed, rough.absorbed, smooth.absorbed_se, rough.absorbed_se)):
        assert abs(a - b) <= 4 * math.hypot(sa, sb)
    from ssskit.profiles.montecarlo.run import RSP_SAMPLES

    p = smooth.rsp  # the rough Rsp is a Monte Carlo estimate: a Bernoulli mean of RSP_SAMPLES draws here
    assert rough.rsp == pytest.approx(p, abs=4 * math.sqrt(p * (1 - p) / RSP_SAMPLES))
    f_s, se_s = smooth.radiance_factor_at(1.0)
    f_r, se_r = rough.radiance_factor_at(1.0)
    assert abs(f_s - f_r) <= 4 * math.hypot(se_s, se_r)


def test_rough_surface_loses_energy(mc_backend):
    """alpha = 0.15 (the references' boundary): Rd + Tt + A + Rsp < 1 by what the surface loses
    at internal reflections (~1% of the incident light for Skin1's red), the total Rd drops (by less,
    0.4%)."""
    cfg = config_for_material(get_material("skin1"), 0, photons=400_000, seed=5)
    smooth = simulate(cfg, use_cache=False, backend=mc_backend)
    rough = simulate(dataclasses.replace(cfg, roughness=ALPHA), use_cache=False, backend=mc_backend)
    deficit = 1.0 - (rough.total_rd + rough.tt + rough.absorbed + rough.rsp)
    assert 0.004 < deficit < 0.03
    assert smooth.total_rd + smooth.tt + smooth.absorbed + smooth.rsp == pytest.approx(1.0, abs=5 * smooth.total_rd_se)
    assert rough.total_rd < smooth.total_rd - 3 * math.hypot(rough.total_rd_se, smooth.total_rd_se)
    # by less than the loss: microfacets tilted towards the exit let out light past the critical angle
    assert smooth.total_rd - rough.total_rd < deficit


def test_rough_run_is_bit_identical_for_any_thread_count():
    import numba

    cfg = dataclasses.replace(config_for_material(get_material("ketchup"), 0, photons=20_000, seed=5,
                                                  batch_size=1_000), roughness=ALPHA, incidence_deg=40.0)
    one = simulate(cfg, threads=1, use_cache=False)
    many = simulate(cfg, threads=min(2, numba.config.NUMBA_NUM_THREADS), use_cache=False)
    assert np.array_equal(one.rd, many.rd) and one.total_rd == many.total_rd and one.rsp == many.rsp


def test_roughness_checks_and_cache_key():
    base = MCConfig((MCLayer(0.1, 1.0),), 0.1, 10)
    for bad in (-0.1, 1.5, float("nan"), "0.1"):
        with pytest.raises(ProfileError, match="roughness"):
            dataclasses.replace(base, roughness=bad)
    assert dataclasses.replace(base, roughness=ALPHA).key() != base.key()
    with pytest.raises(ProfileError, match=rf"^roughness {ALPHA:g} applies to engine numba or gl \(simulate\), not engine numpy$"):
        from ssskit.profiles.montecarlo import simulate_numpy

        simulate_numpy(dataclasses.replace(base, roughness=ALPHA, photons=10))
    with pytest.raises(ProfileError, match="alpha"):
        rough_boundary_albedo(0.5, ETA, 1.0, 0.0)
