"""The finite slab (profiles.montecarlo.slab): its configuration reproduces van de Hulst's slab through a
Material, Rd(t) rises with t to the semi-infinite Rd, energy is conserved, and the table interpolates."""

import math

import numpy as np
import pytest

from ssskit.errors import ProfileError
from ssskit.materials import Material, get_material
from ssskit.profiles.montecarlo import simulate
from ssskit.profiles.montecarlo.slab import interpolate_ratio, slab_config, thickness_table

SKIN = get_material("skin1")


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


def test_slab_config_reproduces_van_de_hulst_through_a_material():
    """mu_a = 10, mu_s = 90 cm^-1, g = 0.75, n = 1, d = 0.02 cm (the MCML paper's check, van de Hulst
    1980): Rd = 0.09739, Tt = 0.66096; here given as a Material in mm^-1 and a thickness in mm."""
    mat = Material("vdh", (1.0, 1.0, 1.0), (9.0, 9.0, 9.0), (0.75, 0.75, 0.75), eta=1.0)
    cfg = slab_config(mat, 0, 0.2, photons=200_000, seed=3)
    assert cfg.layers[0].thickness_mm == 0.2 and cfg.eta_above == cfg.eta_below == 1.0
    r = simulate(cfg)
    assert abs(r.total_rd - 0.09739) <= 3 * r.total_rd_se
    assert abs(r.tt - 0.66096) <= 3 * r.tt_se


def test_thickness_table_rises_to_the_semi_infinite_limit_and_conserves_energy():
    tab = thickness_table(SKIN, (0.5, 1.0, 2.0, 4.0, 20.0), photons=40_000)
    rd, rd_se = np.array(tab["rd"]), np.array(tab["rd_se"])
    ratio, ratio_se = np.array(tab["ratio"]), np.array(tab["ratio_se"])
    # Rd(t) increasing in t: each step more than 3 combined standard errors (red, the longest diffusion)
    assert np.all(np.diff(rd[:4, 0]) > 3 * np.hypot(rd_se[:-2, 0], rd_se[1:-1, 0]))
    # 20 mm is 5 red diffusion lengths: Rd(t) = Rd(inf) within 3 SE in every channel
    assert np.all(np.abs(ratio[-1] - 1) <= 3 * ratio_se[-1]), (ratio[-1], ratio_se[-1])
    # red loses most through a thin slab (the longest diffusion length), blue least
    assert ratio[2, 0] < ratio[2, 1] < ratio[2, 2]
    # energy: Rsp + Rd + A + Tt = 1 (roulette is unbiased: within 4 SE of the sum)
    total = np.array(tab["rsp"]) + rd + np.array(tab["absorbed"]) + np.array(tab["tt"])
    se = np.sqrt(rd_se**2 + np.array(tab["absorbed_se"]) ** 2 + np.array(tab["tt_se"]) ** 2)
    assert np.all(np.abs(total - 1) <= 4 * se + 1e-12), total
    # a thin slab transmits: Tt(0.5 mm) > Tt(4 mm) > Tt(20 mm), under 1% (0.36% in red)
    tt = np.array(tab["tt"])
    assert np.all(tt[0] > tt[3]) and np.all(tt[3] > tt[4]) and np.all(tt[4] < 0.01)


def test_interpolate_ratio():
    tab = {"thickness_mm": [1.0, 2.0], "ratio": [[0.5, 0.6, 0.7], [0.9, 1.0, 1.0]],
           "ratio_se": [[0.01, 0.01, 0.01], [0.02, 0.02, 0.02]]}
    f, se = interpolate_ratio(tab, np.array([0.0, 0.5, 1.0, 1.5, 3.0, np.nan]))
    np.testing.assert_allclose(f[:5, 0], [0.0, 0.25, 0.5, 0.7, 0.9])
    np.testing.assert_allclose(se[3], [0.015] * 3)
    assert np.all(np.isnan(f[5])) and np.all(np.isnan(se[5]))


@pytest.mark.parametrize("t", [0, -1.0, "2", True])
def test_slab_config_rejects_bad_thickness(t):
    with pytest.raises(ProfileError, match="thickness"):
        slab_config(SKIN, 0, t)


def test_thickness_table_rejects_unordered_thicknesses():
    with pytest.raises(ProfileError, match="ascending"):
        thickness_table(SKIN, (2.0, 1.0))
    with pytest.raises(ProfileError, match="thicknesses must be finite, got NaN or inf in 1 of 2 values"):
        thickness_table(SKIN, (1.0, math.inf))
