"""MCML's oblique-incidence table (:mod:`lab.oblique_table`): Rd(theta_i) against
Chandrasekhar's H-function, the interpolation, the Fresnel transmittance and the incidence cosine."""

import math

import numpy as np
import pytest

from ssskit.errors import ProfileError
from ssskit.materials import Material
from ssskit.profiles.montecarlo import MCConfig, MCLayer
from ssskit.profiles.montecarlo.config import N_EXIT_BINS
from lab.oblique_table import fresnel_transmittance, incidence_cosines, oblique_table

from tests.profiles.test_montecarlo import _chandrasekhar_h


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


#: isotropic scattering, albedo 0.9, index-matched, semi-infinite, the same in every channel
ISO = Material("iso", (0.1, 0.1, 0.1), (0.9, 0.9, 0.9), (0.0, 0.0, 0.0), eta=1.0)
ANGLES = (0.0, 45.0, 75.0)


@pytest.fixture(scope="module")
def iso_table(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("SSSKIT_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    try:
        yield oblique_table(ISO, ANGLES, photons=100_000, seed=5)
    finally:
        mp.undo()


def test_rd_follows_the_h_function_at_every_angle(iso_table):
    """Rd(mu0) = 1 - H(mu0) sqrt(1 - a) (Chandrasekhar 1950, flux conservation of the reflection
    function), so Rd rises with the incidence angle: 0.4149, 0.4644, 0.5725 at 0, 45, 75 degrees."""
    hf = _chandrasekhar_h(0.9)
    expected = np.array([1 - hf(math.cos(math.radians(a))) * math.sqrt(0.1) for a in ANGLES]).ravel()
    np.testing.assert_allclose(expected, [0.414947, 0.464423, 0.572459], atol=1e-5)
    for c in range(3):
        assert np.all(np.abs(iso_table.rd[c] - expected) <= 3.5 * iso_table.rd_se[c]), (iso_table.rd[c], expected)
    ratio = iso_table.rd_ratio(np.cos(np.radians(ANGLES)))
    np.testing.assert_allclose(ratio[:, 0], 1.0)
    assert np.all(np.diff(ratio, axis=1) > 0)


def test_radiance_factor_follows_the_h_function(iso_table):
    """The exit per bin at 75 degrees' incidence: (a / 2) H(mu0) Int H(mu) mu / (mu + mu0) dmu over the
    bin (isotropic scattering: Chandrasekhar Eq. IV.70); the factor relative to a Lambertian exit is
    N x that / Rd; every bin within 4 standard errors; its mean over the bins is 1 (energy)."""
    from scipy.integrate import quad

    hf = _chandrasekhar_h(0.9)
    mu0 = math.cos(math.radians(75.0))
    edges = np.sqrt(np.arange(N_EXIT_BINS + 1) / N_EXIT_BINS)
    per_bin = np.array([0.45 * float(hf(mu0)) * quad(lambda m: float(hf(m)) * m / (m + mu0), a, b)[0]
                        for a, b in zip(edges[:-1], edges[1:])])
    expected = N_EXIT_BINS * per_bin / per_bin.sum()
    got, se = iso_table.radiance[0, 2], iso_table.radiance_se[0, 2]
    assert np.all(np.abs(got - expected) <= 4 * se + 1e-3 * expected), (got - expected) / se
    assert got.mean() == pytest.approx(1.0, rel=1e-9)
    # grazing light leaves preferentially at grazing angles: the factor falls towards the normal
    assert expected[0] > 1.2 > 0.9 > expected[-1]


def test_interpolation_is_exact_at_the_nodes_and_linear_between(iso_table):
    cos_nodes = np.cos(np.radians(ANGLES))
    np.testing.assert_allclose(iso_table.rd_at(cos_nodes), iso_table.rd)
    mid = 0.5 * (cos_nodes[1] + cos_nodes[2])
    np.testing.assert_allclose(iso_table.rd_at(mid), 0.5 * (iso_table.rd[:, 1] + iso_table.rd[:, 2]))
    assert iso_table.rd_at(0.0)[0] == iso_table.rd[0, -1]  # beyond the last angle: held
    centres = np.sqrt((np.arange(N_EXIT_BINS) + 0.5) / N_EXIT_BINS)
    f = iso_table.radiance_factor(np.full(N_EXIT_BINS, cos_nodes[1]), centres)
    np.testing.assert_allclose(f, iso_table.radiance[:, 1])
    np.testing.assert_allclose(iso_table.exit_radiance(cos_nodes[1], centres[3]),
                               iso_table.rd[:, 1] * iso_table.radiance[:, 1, 3])


def test_fresnel_transmittance_matches_the_launch():
    """1 - R of the launch's own Fresnel reflectance (MCConfig.specular_reflectance, at eta 1.3) at every
    angle; 1 for an index-matched boundary; 0.983 at normal incidence (1 - ((1.3 - 1) / 2.3)^2)."""
    for a in (0.0, 30.0, 60.0, 73.0, 85.0):
        cfg = MCConfig((MCLayer(0.1, 0.9, 0.0, 1.3),), dr_mm=0.1, nr=4, incidence_deg=a)
        t = fresnel_transmittance(math.cos(math.radians(a)), 1.3)
        assert t == pytest.approx(1 - cfg.specular_reflectance(), abs=1e-12)
    assert fresnel_transmittance(0.3, 1.0) == pytest.approx(1.0)
    assert fresnel_transmittance(1.0, 1.3) == pytest.approx(1 - (0.3 / 2.3) ** 2)


def test_incidence_cosines():
    p = np.zeros((2, 3))
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]])
    light = (math.sin(math.radians(73.0)) * 10, 0.0, math.cos(math.radians(73.0)) * 10)
    np.testing.assert_allclose(incidence_cosines(p, n, light), math.cos(math.radians(73.0)))
    assert incidence_cosines(p[0], -n[0], light) == 0.0  # below the horizon


def test_bad_angles_and_photons():
    with pytest.raises(ProfileError, match="start at 0"):
        oblique_table(ISO, (10.0, 45.0))
    with pytest.raises(ProfileError, match="below 90"):
        oblique_table(ISO, (0.0, 90.0))
    with pytest.raises(ProfileError, match="photons"):
        oblique_table(ISO, (0.0, 45.0), photons=100)


def test_rough_surface_lets_in_more_grazing_light():
    """With the references' rough surface (Beckmann alpha = 0.15, MCConfig.roughness) a beam at 85 degrees
    enters ~45% more than through a smooth Fresnel boundary (the surface's own transmittance ratio there,
    sampled from Mitsuba's roughdielectric in tests/scenes/test_flat.py), so Rd(85) rises by about that;
    at normal incidence the two surfaces' Rd agree within 2% (the rough one loses ~1% at grazing internal
    reflections)."""
    mat = Material("iso13", (0.1, 0.1, 0.1), (0.9, 0.9, 0.9), (0.0, 0.0, 0.0), eta=1.3)
    smooth = oblique_table(mat, (0.0, 85.0), photons=40_000, seed=6)
    rough = oblique_table(mat, (0.0, 85.0), photons=40_000, seed=6, roughness=0.15)
    assert rough.roughness == 0.15 and rough.to_dict()["roughness"] == 0.15
    ratio = rough.rd[0] / smooth.rd[0]
    assert 0.97 < ratio[0] < 1.01
    assert 1.3 < ratio[1] < 1.6
