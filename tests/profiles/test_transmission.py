"""MCML slab transmittance tables (profiles.montecarlo.transmission): the pure absorber against the exact
thick-plate sum, skin's T(t) between the two bounds every slab obeys, decreasing, with T + R <= 1, reaching
the floor; the compact fit within its reported error; the scattered part (T less the unscattered beam) and
its fit, 0 at t = 0; the lateral spread's width from Tt(r)."""

import math
from dataclasses import replace as dataclasses_replace

import numpy as np
import pytest

from ssskit.errors import ProfileError
from ssskit.materials import Material, get_material
from ssskit.profiles.montecarlo import MCConfig, MCLayer, simulate
from ssskit.profiles.montecarlo.transmission import (
    GAUSS_MEDIAN,
    T_FLOOR,
    TransmissionTable,
    absorber_transmittance,
    diffuse_spread,
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


def test_the_scattered_part_rises_from_zero_and_its_fit_follows(skin_table):
    """T_s = T - the unscattered beam: >= 0 (within 3 SE), 0 in the limit of no medium (at 0.05 mm, under a
    tenth of a mean free path, less than 3 %), rising to a maximum and falling like T beyond it. Its fit is 0 at
    t = 0 by construction, >= 0 everywhere, within its reported error of every resolved entry."""
    ts, se = skin_table.diffuse, skin_table.tt_se
    assert np.all(ts >= -3 * se - 1.0 / skin_table.photons) and np.all(ts[0] < 0.03)  # (a beam below a photon)
    top = np.argmax(ts, axis=0)
    assert np.all((top > 0) & (top < len(ts) - 1))
    fit = fit_transmission(skin_table, part="diffuse")
    assert fit.part == "diffuse" and fit.amplitudes.shape == (3, 4)
    np.testing.assert_allclose(fit(0.0), 0.0, atol=1e-12)
    np.testing.assert_allclose(fit.amplitudes[:, -1], -fit.amplitudes[:, :-1].sum(axis=1), rtol=1e-12)
    assert np.all(fit.amplitudes[:, :-1] >= 0)
    assert np.all(fit(np.linspace(0.0, 2 * skin_table.thickness_mm[-1], 2000)) >= -1e-9)
    ok = (ts > 3 * se) & (ts > 0)
    z = np.abs(fit(skin_table.thickness_mm) - ts) / np.maximum(se, 1e-300)
    assert np.all(z[ok] <= fit.max_se.max() * (1 + 1e-9)) and np.all(fit.max_se < 6.0), fit.max_se


def test_a_nearly_pure_absorbers_scattered_part_takes_fewer_terms():
    """Ketchup's green scatters little (sigma_s 0.07 against sigma_a 0.97 per mm): its scattered part T_s is above 3
    SE at three thicknesses only, fewer than the default fit's seven parameters, and its blue at one, fewer than
    any fit's three. The fit takes the terms the entries allow (green: one and the beam's, 0 at t = 0, >= 0
    everywhere, within 3 SE of each resolved entry; blue: 0), so the pass can run for Ketchup (it raised before)."""
    table = transmission_table(get_material("ketchup"))  # the shipped table
    ts, se = table.diffuse, table.tt_se
    ok = (ts > 3 * se) & (ts > 0)
    assert ok[:, 1].sum() == 3 and ok[:, 2].sum() == 1 and ok[:, 0].sum() >= 7
    fit = fit_transmission(table, part="diffuse")
    used = np.count_nonzero(fit.amplitudes, axis=1)
    assert used[0] == 4 and used[1] == 2 and used[2] == 0
    np.testing.assert_allclose(fit(0.0), 0.0, atol=1e-12)
    assert np.all(fit(np.linspace(0.0, 2 * table.thickness_mm[-1], 4000)) >= -1e-9)
    z = np.abs(fit(table.thickness_mm)[:, 1] - ts[:, 1])[ok[:, 1]] / se[ok[:, 1], 1]
    assert np.all(z <= 3.0), z
    assert np.all(fit(table.thickness_mm)[:, 2] == 0.0)


def test_the_spread_is_the_gaussian_of_the_scattered_lights_median_radius():
    """A run whose Tt(r) is a 2D Gaussian of sigma 1.3 mm plus the unscattered beam on the axis gives sigma back
    (to a tenth of a bin); without the Tt(r) tally (a result stored before it), NaN."""
    from ssskit.profiles.montecarlo.result import MCResult

    cfg = MCConfig((MCLayer(0.1, 1.0, 0.0, 1.3, 2.0),), 0.01, 1500, photons=10_000)
    r = (np.arange(cfg.nr - 1) + 0.5) * cfg.dr_mm
    area = 2 * np.pi * r * cfg.dr_mm
    dens = 0.3 * np.exp(-r ** 2 / (2 * 1.3 ** 2)) / (2 * np.pi * 1.3 ** 2)
    tt_r = dens.copy()
    tt_r[0] += 0.2 / area[0]
    res = MCResult(cfg, r, np.zeros_like(r), np.zeros_like(r), 0.0, 0.0, float(np.sum(tt_r * area)), 1e-4, 0.0, 0.0,
                   0.0, 0.0, 10_000, tt_r=tt_r, tt_r_se=np.zeros_like(r), exit_tt=np.zeros(20), exit_tt_se=np.zeros(20))
    assert diffuse_spread(res, 0.2) == pytest.approx(1.3, abs=0.1 * cfg.dr_mm)
    assert math.isnan(diffuse_spread(dataclasses_replace(res, tt_r=np.zeros(0)), 0.2))
    assert GAUSS_MEDIAN == pytest.approx(math.sqrt(2 * math.log(2)))


def test_the_skin_tables_spread_widens_with_thickness(skin_table):
    """Beyond a mean free path (1.3 mm in red) the scattered light's lateral spread grows with the slab's
    thickness, and stays below it (the light diffuses forward as much as sideways)."""
    w = skin_table.spread_mm
    t = skin_table.thickness_mm
    for c in range(3):
        sel = (t >= 1.5) & np.isfinite(w[:, c]) & (skin_table.diffuse[:, c] > 0.01)  # a few hundred photons or more
        assert sel.sum() >= 3
        assert np.all(np.diff(w[sel, c]) > 0), w[sel, c]
        assert np.all(w[sel, c] * GAUSS_MEDIAN < t[sel])


def test_the_table_round_trips_through_a_dict(skin_table):
    back = TransmissionTable.from_dict(skin_table.to_dict())
    np.testing.assert_array_equal(back.tt, skin_table.tt)
    np.testing.assert_array_equal(back.spread_mm, skin_table.spread_mm)
    assert back.sigma_t == skin_table.sigma_t and back.material == "Skin1"


def test_bad_inputs_are_refused():
    with pytest.raises(ProfileError, match="ascending"):
        transmission_table(SKIN, grid=(1.0, 0.5))
    with pytest.raises(ProfileError, match="floor"):
        transmission_table(SKIN, floor=0.0)
    with pytest.raises(ProfileError, match="unscattered alone is 0.447.*extend the grid"):  # the ballistic bound
        transmission_table(SKIN, photons=2_000, grid=(0.5, 1.0))
    with pytest.raises(ProfileError, match="still .* at the grid's last thickness 5 mm.*extend the grid"):
        transmission_table(get_material("marble"), photons=2_000, grid=(4.0, 5.0))  # scattered light: simulated
    clear = Material("clear", (0.01,) * 3, (0.01,) * 3, eta=1.4)  # even 200 mm leaves 0.945 e^-4 unscattered
    with pytest.raises(ProfileError, match=r"unscattered alone is 0.0173.*domain is sigma_t above about 0.0461 /mm"):
        transmission_table(clear)
