"""MCML slab transmittance tables (profiles.montecarlo.transmission): the pure absorber against the exact
thick-plate sum, skin's T(t) between the two bounds every slab obeys, decreasing, with T + R <= 1, reaching
the floor; and the compact fit within its reported error."""

import math

import numpy as np
import pytest

from ssskit.errors import ProfileError
from ssskit.materials import get_material
from ssskit.profiles.montecarlo import MCConfig, MCLayer, simulate
from ssskit.profiles.montecarlo.transmission import (
    T_FLOOR,
    TransmissionTable,
    absorber_transmittance,
    fit_transmission,
    normal_fresnel,
    transmission_table,
)

SKIN = get_material("skin1")


@pytest.fixture(scope="module")
def skin_table(tmp_path_factory):
    import os

    old = os.environ.get("SSSKIT_CACHE_DIR")
    os.environ["SSSKIT_CACHE_DIR"] = str(tmp_path_factory.mktemp("cache"))
    try:
        yield transmission_table(SKIN, photons=40_000, seed=7)
    finally:
        if old is None:
            del os.environ["SSSKIT_CACHE_DIR"]
        else:
            os.environ["SSSKIT_CACHE_DIR"] = old


def test_normal_fresnel_of_glass():
    # ((1.5 - 1) / (1.5 + 1))^2 = 0.04 (Born and Wolf: 4 % at normal incidence on glass)
    assert normal_fresnel(1.5) == pytest.approx(0.04, abs=1e-15)


@pytest.mark.parametrize("sigma_a,t", [(0.5, 1.0), (2.0, 0.5), (0.2, 4.0)])
def test_a_pure_absorber_transmits_the_thick_plate_sum(sigma_a, t, tmp_path, monkeypatch):
    """sigma_s = 0: MCML's photons travel straight, so T is exactly (1 - R)^2 e^-tau / (1 - R^2 e^-2tau)
    (the incoherent sum over the round trips between two faces of reflectance R)."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    cfg = MCConfig((MCLayer(sigma_a, 0.0, 0.0, 1.3, t),), 0.01, 50, 100_000, 5, 1.0, 1.0)
    r = simulate(cfg)
    expect = float(absorber_transmittance(sigma_a, t, 1.3))
    assert abs(r.tt - expect) <= 3 * r.tt_se, (r.tt, r.tt_se, expect)
    assert r.total_rd < 0.02  # what comes back is the beam reflected at the bottom face, attenuated twice


def test_skin_table_decreases_and_reaches_the_floor(skin_table):
    tt, se = skin_table.tt, skin_table.tt_se
    step = np.diff(tt, axis=0)
    assert np.all(step <= 3 * np.hypot(se[1:], se[:-1])), "T(t) must not rise with t"
    resolved = (tt[1:] > 3 * se[1:]) & (tt[:-1] > 3 * se[:-1])
    assert np.all(step[resolved] < 0)
    assert np.all(tt[-1] < T_FLOOR) and np.any(tt[-2] >= T_FLOOR)
    # red reaches the floor last: its diffusion length 1 / sigma_tr = 3.7 mm is the longest
    assert skin_table.thickness_mm[-1] > 8 / math.sqrt(3 * SKIN.sigma_a[0] * SKIN.sigma_t[0])


def test_skin_table_obeys_the_bounds_of_every_slab(skin_table):
    """Rsp + Rd + T <= 1; T <= (1 - Rsp) exp(-sigma_a t) (every transmitted photon crossed at least t);
    T >= the ballistic part (1 - R)^2 e^(-sigma_t t) / (1 - R^2 e^(-2 sigma_t t)); each within 3 SE."""
    t = skin_table.thickness_mm[:, None]
    tt, se = skin_table.tt, skin_table.tt_se
    total = skin_table.rsp + skin_table.rd + tt
    assert np.all(total <= 1 + 3 * np.hypot(se, skin_table.rd_se))
    upper = (1 - skin_table.rsp) * np.exp(-np.asarray(SKIN.sigma_a) * t)
    lower = absorber_transmittance(np.asarray(SKIN.sigma_t), t, SKIN.eta)
    assert np.all(tt <= upper + 3 * se)
    seen = lower * skin_table.photons > 10  # the ballistic part is more than 10 photons' worth
    assert seen.sum() > 20
    assert np.all(tt[seen] >= lower[seen] - 3 * se[seen])
    # the thinnest slab (0.05 mm, under a tenth of a mean free path) transmits mostly unscattered light
    assert np.all(tt[0] - lower[0] < 0.1 * tt[0])


def test_the_fit_is_within_its_reported_error_and_monotone(skin_table):
    fit = fit_transmission(skin_table, terms=4)
    ok = skin_table.tt > 3 * skin_table.tt_se
    f = fit(skin_table.thickness_mm)
    z = np.abs(f - skin_table.tt) / np.maximum(skin_table.tt_se, 1e-300)
    assert np.all(z[ok] <= fit.max_se.max() * (1 + 1e-9))
    # at 40,000 photons per entry a 4-term fit lies within 6 SE of every resolved entry, its rms within 6 % (the precise entries have SE up to 10 %)
    assert np.all(fit.max_se < 6.0), fit.max_se
    assert np.all(fit.rms_rel_error < 0.06), fit.rms_rel_error
    dense = fit(np.linspace(0.0, skin_table.thickness_mm[-1], 400))
    assert np.all(np.diff(dense, axis=0) < 0) and np.all(dense > 0)
    assert np.all(fit.amplitudes >= 0) and np.all(fit.rates_per_mm >= 0) and np.all(fit.gauss_per_mm2 >= 0)


def test_the_table_round_trips_through_a_dict(skin_table):
    back = TransmissionTable.from_dict(skin_table.to_dict())
    np.testing.assert_array_equal(back.tt, skin_table.tt)
    assert back.sigma_t == skin_table.sigma_t and back.material == "Skin1"


def test_bad_inputs_are_refused():
    with pytest.raises(ProfileError, match="ascending"):
        transmission_table(SKIN, grid=(1.0, 0.5))
    with pytest.raises(ProfileError, match="floor"):
        transmission_table(SKIN, floor=0.0)
    with pytest.raises(ProfileError, match="extend the grid"):
        transmission_table(SKIN, photons=2_000, grid=(0.5, 1.0))
