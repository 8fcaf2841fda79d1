"""Each profile model's valid domain (ssskit.profiles.domain): the bounds are justified by an
independent computation (the Fresnel equations integrated numerically), every preset lies inside, and
what lies outside is refused naming the model, the quantity and its range."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from ssskit.errors import ProfileError
from ssskit.materials import MATERIALS, Material
from ssskit.profiles import DipoleProfile, fresnel_diffuse_reflectance, profile_for_material
from ssskit.profiles.domain import (DIPOLE_ETA_MAX, MAX_GRID_BINS, MFP_RANGE_MM, MIN_ABSORBED_FRACTION, OPTICAL_ETA_MAX,
                                   check_montecarlo)
from ssskit.profiles.montecarlo import supplement_grid


def _fresnel_inside(cos_i: float, eta: float) -> float:
    """Unpolarised Fresnel reflectance (Born & Wolf Eqs. 1.5.21/22) for light inside a medium of
    relative index eta meeting its boundary at cos_i."""
    sin_t = eta * math.sqrt(max(0.0, 1.0 - cos_i * cos_i))
    if sin_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(1.0 - sin_t * sin_t)
    rs = ((eta * cos_i - cos_t) / (eta * cos_i + cos_t)) ** 2
    rp = ((eta * cos_t - cos_i) / (eta * cos_t + cos_i)) ** 2
    return 0.5 * (rs + rp)


def _fdr_exact(eta: float) -> float:
    """The diffuse (cosine-weighted hemispherical) internal Fresnel reflectance, integrated numerically."""
    crit = [math.sqrt(1.0 - 1.0 / eta**2)] if eta > 1 else None
    return quad(lambda c: 2.0 * c * _fresnel_inside(c, eta), 0.0, 1.0, points=crit, limit=200)[0]


def _a(f: float) -> float:
    return (1.0 + f) / (1.0 - f)


def test_the_dipole_eta_bound_is_where_the_fdr_fit_holds():
    """[JMLH01]'s F_dr fit against the exact Fresnel average: A within 0.33% up to eta 2, within 5% up to
    DIPOLE_ETA_MAX = 2.5, off by more than 20% at 3, and past 1 (A < 0) before 3.9."""
    err = lambda e: abs(_a(fresnel_diffuse_reflectance(e)) / _a(_fdr_exact(e)) - 1.0)  # noqa: E731
    assert max(err(e) for e in np.linspace(1.0, 2.0, 41)) < 0.0035
    assert max(err(e) for e in np.linspace(1.0, DIPOLE_ETA_MAX, 61)) < 0.05
    assert err(3.0) > 0.2
    assert fresnel_diffuse_reflectance(3.84) < 1.0 < fresnel_diffuse_reflectance(3.86)


@pytest.mark.parametrize("name", MATERIALS.names())
def test_every_preset_lies_in_every_domain(name):
    m = MATERIALS.get(name)
    lo, hi = MFP_RANGE_MM
    assert all(lo <= v <= hi for v in m.mfp_reduced_mm)
    assert m.eta <= DIPOLE_ETA_MAX
    check_montecarlo(m)
    assert supplement_grid(m)[1] <= MAX_GRID_BINS
    assert np.all(np.isfinite(profile_for_material(m, "dipole").total_rd()))


def _mat(**kw) -> Material:
    return Material("x", kw.pop("sigma_a", 0.1), kw.pop("sigma_s", 1.0), **kw)


@pytest.mark.parametrize("model", ["dipole", "gaussians"])
def test_the_dipole_refuses_an_index_past_its_fit(model):
    """eta = 4 gave a total Rd of 6.7e60 and eta = 1e6 a negative R(r)."""
    for eta in (4.0, 1e6):
        with pytest.raises(ProfileError, match=rf"the {model}.* relative index eta must lie in \[1, 2.5\]"):
            profile_for_material(_mat(eta=eta), model)
    with pytest.raises(ProfileError, match="eta must lie in"):
        DipoleProfile(0.1, 1.0, eta=4.0)
    assert np.isfinite(DipoleProfile(0.1, 1.0, eta=2.5).total_rd())


@pytest.mark.parametrize("model", ["dipole", "gaussians", "burley", "montecarlo"])
@pytest.mark.parametrize("sigma", [1e300, 1e-300])
def test_every_model_refuses_lengths_it_cannot_compute(model, sigma):
    """sigma_a = sigma_s = 1e300 or 1e-300 gave profiles of NaN."""
    with pytest.raises(ProfileError, match=rf"the {model}.*transport mean free path 1/sigma_t'.* must lie in \[1e-06, 1e\+06\] mm"):
        profile_for_material(_mat(sigma_a=sigma, sigma_s=sigma), model)


def test_montecarlo_refuses_an_index_no_optical_medium_has():
    with pytest.raises(ProfileError, match=r"the montecarlo model's relative index eta must lie in \[1, 4\]"):
        check_montecarlo(_mat(eta=1e6))
    check_montecarlo(_mat(eta=OPTICAL_ETA_MAX))


def test_montecarlo_refuses_a_grid_it_cannot_hold():
    """dr = shortest MFP / 20 out to 32 longest: a 100:1 spread needs 64,000 bins per batch row."""
    with pytest.raises(ProfileError, match=r"grid \(its longest transport mean free path 100 times the shortest\) must lie in \[2, 20000\] bins, got 64000"):
        check_montecarlo(Material("x", (0.0, 0.0, 0.0), (1.0, 1.0, 100.0)))


def test_montecarlo_refuses_a_half_space_that_absorbs_nothing():
    """sigma_a = 0 in a semi-infinite medium: the trial's run of 10^4 photons never ended (a walk in a half-space
    has no finite mean length). Refused in one line, in the API and before any photon; a finite slab without
    absorption (its photons leave through the far side) and the smallest absorbed fraction are taken."""
    clear = Material("clear", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    with pytest.raises(ProfileError, match=r"the montecarlo model's sigma_a / sigma_t in channel R of 'clear' must lie "
                                           r"in \[1e-07, 1\], got 0 \(a semi-infinite medium must absorb"):
        profile_for_material(clear, "montecarlo", photons=10**4)
    with pytest.raises(ProfileError, match="channel B"):
        check_montecarlo(Material("x", (0.01, 0.01, 1e-9), (1.0, 1.0, 1.0)))
    check_montecarlo(Material("x", (MIN_ABSORBED_FRACTION,) * 3, (1.0 - MIN_ABSORBED_FRACTION,) * 3))
    slab = Material("slab", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), thickness_mm=2.0)
    check_montecarlo(slab)
    rd = profile_for_material(slab, "montecarlo", photons=2000).total_rd()
    assert np.all((rd > 0.3) & (rd < 1.0))  # a 2 mm slab of 1 mm mean free paths reflects part, transmits the rest


def test_the_simulation_entry_points_refuse_a_material_that_does_not_scatter():
    """sigma_s = 0 gave total Rd 0 +- NaN from simulate_material (a layered material: in every layer);
    simulate_many refuses before starting any job."""
    from ssskit.materials import LayeredMaterial
    from ssskit.profiles.montecarlo import config_for_material, simulate_many, simulate_material

    absorber = _mat(sigma_s=0.0)
    layered = LayeredMaterial("two", (_mat(sigma_s=(0.0, 1.0, 1.0), thickness_mm=0.5), _mat(sigma_s=(0.0, 0.0, 1.0))))
    for call in (lambda: check_montecarlo(absorber), lambda: config_for_material(absorber, 0, 1000),
                 lambda: simulate_material(absorber, photons=1000, use_cache=False),
                 lambda: simulate_material(layered, photons=1000, use_cache=False, backend="gl"),
                 lambda: simulate_many([MATERIALS.get("skin1"), absorber], photons=1000, jobs=2)):
        with pytest.raises(ProfileError, match=r"the montecarlo model's sigma_s in channel R of .* must lie in \(0, inf\) mm\^-1, got 0 \(a scattering material"):
            call()
    check_montecarlo(LayeredMaterial("one", (_mat(sigma_s=(0.0, 1.0, 1.0), thickness_mm=0.5), _mat(sigma_s=(1.0, 0.0, 0.0)))))
