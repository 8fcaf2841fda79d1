"""MCML's transmitted-light tallies (Tt_r and Tt_a, [WJZ95]) of a finite slab: against the original C MCML
1.2.2's Tt_r (reference data written by benchmarks/mcml_transmitted.py), the exact pure absorber, and the
engines against each other."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from ssskit.materials import get_material
from ssskit.profiles.montecarlo import MCConfig, MCLayer, simulate, simulate_numpy
from ssskit.profiles.montecarlo.config import N_EXIT_BINS
from ssskit.profiles.montecarlo.result import ring_sums
from ssskit.profiles.montecarlo.slab import slab_config
from ssskit.profiles.montecarlo.transmission import absorber_transmittance

DATA = Path(__file__).parent / "data" / "c_mcml_slab_tt.json"
RINGS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 14.0, 20.0)
SKIN = get_material("skin1")


def _cases():
    return json.loads(DATA.read_text())["cases"]


@pytest.mark.parametrize("case", _cases(), ids=lambda c: c["name"])
def test_tt_r_agrees_with_c_mcml(case):
    """Ring by ring (the fraction of the light transmitted within each ring), ssskit's numba Tt(r) equals the
    C program's within the two runs' errors: |z| < 4 on every well-sampled ring, mean z^2 < 2.5; totals
    within 4 SE. The C run's error is ssskit's scaled by the photon counts (the same per-photon spread)."""
    photons = 200_000
    res = simulate(slab_config(SKIN, case["channel"], case["thickness_mm"], photons, 5), use_cache=False)
    assert res.config.dr_mm == pytest.approx(case["dr_mm"], rel=1e-12) and res.config.nr == case["nr"]
    s, s_se = ring_sums(res.tt_r, res.config.dr_mm, RINGS, res.tt_r_se)
    c, _ = ring_sums(np.asarray(case["tt_r_mm2"])[:-1], case["dr_mm"], RINGS)
    se = s_se * math.sqrt(1.0 + photons / case["photons"])
    sampled = s_se < 0.1 * s
    assert sampled.sum() >= 8
    z = (s - c)[sampled] / se[sampled]
    assert np.max(np.abs(z)) < 4.0, z
    assert np.mean(z ** 2) < 2.5, z
    tt_se = res.tt_se * math.sqrt(1.0 + photons / case["photons"])
    assert abs(res.tt - case["rat"]["Tt"]) < 4 * tt_se


def test_tallies_add_up_to_the_totals():
    """2 pi sum Tt(r_i) r_i dr + the overflow = Tt, and the exit-direction bins sum to Tt (each photon is
    scored once in each); a semi-infinite medium's are zero."""
    res = simulate(slab_config(SKIN, 1, 1.0, 20_000, 3), use_cache=False)
    area = 2.0 * np.pi * res.r_mm * res.config.dr_mm
    assert res.has_transmitted_tallies
    assert np.sum(res.tt_r * area) + res.tt_overflow == pytest.approx(res.tt, rel=1e-12)
    assert np.sum(res.exit_tt) == pytest.approx(res.tt, rel=1e-12)
    assert np.sum(res.rd * area) + res.overflow == pytest.approx(res.total_rd, rel=1e-12)
    deep = simulate(slab_config(SKIN, 1, math.inf, 5_000, 3), use_cache=False)
    assert deep.tt == 0 and not np.any(deep.tt_r) and not np.any(deep.exit_tt)


def test_pure_absorber_transmits_along_the_axis():
    """No scattering: every transmitted photon leaves on the beam's axis (the first annulus) along the normal
    (the last exit bin), and the total is the exact thick-plate sum."""
    cfg = MCConfig((MCLayer(0.5, 0.0, 0.0, 1.4, 1.0),), 0.01, 50, photons=40_000, seed=2)
    res = simulate(cfg, use_cache=False)
    area = 2.0 * np.pi * res.r_mm * cfg.dr_mm
    assert res.tt_r[0] * area[0] == pytest.approx(res.tt, rel=1e-12)
    assert res.exit_tt[-1] == pytest.approx(res.tt, rel=1e-12)
    assert res.tt == pytest.approx(float(absorber_transmittance(0.5, 1.0, 1.4)), abs=4 * res.tt_se + 1e-12)


def test_numpy_twin_and_gl_engine_agree_with_numba(mc_backend):
    """The same slab through independent random streams (numpy's PCG64) and the other engine: the ring sums
    of Tt(r) and the transmitted exit-direction halves agree within 4 combined SE."""
    cfg = slab_config(SKIN, 0, 1.0, 40_000, 9)
    ref = simulate(cfg, use_cache=False)
    other = simulate_numpy(cfg) if mc_backend == "numba" else simulate(cfg, use_cache=False, backend="gl")
    for r in (ref, other):
        assert r.has_transmitted_tallies
    a, a_se = ring_sums(ref.tt_r, cfg.dr_mm, RINGS[:8], ref.tt_r_se)
    b, b_se = ring_sums(other.tt_r, cfg.dr_mm, RINGS[:8], other.tt_r_se)
    assert np.all(np.abs(a - b) < 4 * np.hypot(a_se, b_se))
    half = N_EXIT_BINS // 2
    for sl in (slice(0, half), slice(half, N_EXIT_BINS - 1)):  # the last bin holds the unscattered beam
        x, y = ref.exit_tt[sl].sum(), other.exit_tt[sl].sum()
        sx = math.sqrt(np.sum(ref.exit_tt_se[sl] ** 2))
        sy = math.sqrt(np.sum(other.exit_tt_se[sl] ** 2))
        assert abs(x - y) < 4 * math.hypot(sx, sy)


def test_a_result_stored_before_the_transmitted_tallies(tmp_path, monkeypatch):
    """A finished result stored without Tt_r / Tt_a: a semi-infinite medium's serves (it transmits nothing:
    zeros); a finite slab's is simulated again, with the same streams: Rd and Tt bit for bit, and the tallies."""
    from ssskit.cache import cache_dir

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    for thickness in (1.0, math.inf):
        cfg = slab_config(SKIN, 0, thickness, 4_000, 21)
        fresh = simulate(cfg, shipped=False)
        path = cache_dir("mcml") / f"{cfg.key()}.npz"
        with np.load(path) as z:  # rewrite it as the engine before the tallies stored it
            old = {k: z[k] for k in ("r_mm", "rd", "rd_se", "exit_rd", "exit_rd_se")}
            old["scalars"] = z["scalars"][:10]
        np.savez(path, **old)
        again = simulate(cfg, shipped=False)
        assert again.has_transmitted_tallies
        assert (again.total_rd, again.tt) == (fresh.total_rd, fresh.tt)
        np.testing.assert_array_equal(again.tt_r, fresh.tt_r)
        if math.isinf(thickness):
            assert again.extra.get("cached") and not np.any(again.tt_r)
        else:
            assert not again.extra.get("cached") and again.tt > 0
