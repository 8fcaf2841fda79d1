import math

import numpy as np
import pytest
from scipy.integrate import quad

from tests.conftest import MATERIAL_CHANNELS
from ssskit.errors import ProfileError
from ssskit.materials import MATERIALS
from ssskit.profiles import (
    BurleyProfile,
    DipoleProfile,
    GaussianSumProfile,
    RGBProfile,
    burley_d,
    burley_d_diffuse_transmission,
    burley_d_dmfp,
    burley_d_searchlight,
    deon2007_profile,
    dipole_profile,
    fit_gaussian_sum,
    fresnel_diffuse_reflectance,
    profile_for_material,
)


def radial_integral(prof, r_lo=0.0, r_hi=np.inf):
    """Independent numerical 2 pi Int R(r) r dr with scipy's adaptive quadrature of eval()."""
    f = lambda r: 2 * np.pi * r * float(prof.eval(r))
    scale = prof.length_scale_mm()
    pts = [p for p in (scale * 0.1, scale, 10 * scale, 100 * scale) if r_lo < p < r_hi]
    edges = [r_lo, *pts, r_hi]
    return sum(quad(f, a, b, limit=400, epsabs=0, epsrel=1e-12)[0] for a, b in zip(edges[:-1], edges[1:]))


@pytest.mark.parametrize("name, c", MATERIAL_CHANNELS)
def test_dipole_closed_form_total_equals_radial_integral(name, c):
    """All 33 material-channels: closed-form total Rd [JMLH01] = 2 pi Int R(r) r dr to 1e-6."""
    chan = dipole_profile(MATERIALS.get(name)).channels[c]
    assert radial_integral(chan) == pytest.approx(chan.total_rd(), rel=1e-6)
    # and the energy-outside closed form agrees with the same integral from any radius
    rho = chan.radius_at_fraction(0.5)
    assert radial_integral(chan, float(rho)) == pytest.approx(float(chan.energy_outside(rho)), rel=1e-6)


def _fresnel(cos_i, n1, n2):
    """Unpolarised Fresnel reflectance from medium n1 into n2 (1 beyond the critical angle)."""
    sin_t = n1 / n2 * math.sqrt(max(0.0, 1.0 - cos_i * cos_i))
    if sin_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(1.0 - sin_t * sin_t)
    rs = ((n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)) ** 2
    rp = ((n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i)) ** 2
    return 0.5 * (rs + rp)


@pytest.mark.parametrize("eta", [1.0, 1.1, 1.3, 1.5, 2.0])
def test_fresnel_diffuse_reflectance_fit(eta):
    """The rational fit of [JMLH01] against the diffuse Fresnel reflectance it approximates, found
    by integrating the Fresnel equations over a cosine-weighted hemisphere inside the medium:
    F_dr = Int_0^1 R(mu) 2 mu dmu (critical angle as a breakpoint)."""
    crit = [math.sqrt(1.0 - 1.0 / eta**2)] if eta > 1 else None
    exact = quad(lambda mu: 2 * mu * _fresnel(mu, eta, 1.0), 0, 1, points=crit, limit=200, epsabs=1e-12)[0]
    assert fresnel_diffuse_reflectance(eta) == pytest.approx(exact, abs=2e-3)


def test_dipole_limits():
    # no absorption: all light comes back (alpha' = 1 -> total Rd = 1)
    assert DipoleProfile(0.0, 1.0).total_rd() == pytest.approx(1.0)
    # increasing absorption lowers total reflectance
    totals = [DipoleProfile(a, 1.0).total_rd() for a in (0.001, 0.01, 0.1, 1.0)]
    assert all(b < a for a, b in zip(totals, totals[1:]))


@pytest.mark.parametrize("model", ["dipole", "burley", "gaussians"])
@pytest.mark.parametrize("name", ["Skin1", "Marble", "Ketchup"])
def test_profiles_nonnegative_and_decreasing(model, name):
    prof = profile_for_material(name, model, **({"albedo_source": "dipole"} if model == "burley" else {}))
    r = np.linspace(1e-3, float(prof.radius_at_fraction(0.9999).max()), 2000)
    v = prof.eval(r)
    assert np.all(v >= 0)
    assert np.all(np.diff(v, axis=0) <= 1e-15 * v[:-1])


@pytest.mark.parametrize("A, d", [(0.9, 1.0), (0.2, 0.05), (1.0, 7.0), (0.55, 0.37)])
def test_burley_total_is_albedo(A, d):
    prof = BurleyProfile(A, d)
    assert radial_integral(prof) == pytest.approx(A, rel=1e-6)


@pytest.mark.parametrize("d", [0.1, 1.0, 3.3])
def test_burley_radius_at_0997_matches_numerical_integration(d):
    """The radius holding 99.7% of the energy (about 16.56 d) against a root of the numerically
    integrated energy 2 pi Int_0^rho R(r) r dr, not of the closed-form CDF."""
    from scipy.optimize import brentq

    prof = BurleyProfile(0.8, d)
    f = lambda rho: radial_integral(prof, 0.0, rho) / 0.8 - 0.997
    expected = brentq(f, 10 * d, 25 * d, xtol=1e-12 * d)
    assert float(prof.radius_at_fraction(0.997)) == pytest.approx(expected, rel=1e-6)
    assert expected / d == pytest.approx(16.56, abs=0.01)


def test_burley_eq5_configurations():
    A, ell = 0.6, 2.0
    assert burley_d_searchlight(A, ell) == pytest.approx(ell / (1.85 - 0.6 + 7 * 0.2**3))
    assert burley_d_diffuse_transmission(A, ell) == pytest.approx(ell / (1.9 - 0.6 + 3.5 * 0.04))
    assert burley_d_dmfp(A, ell) == pytest.approx(ell / (3.5 + 100 * 0.27**4))
    assert burley_d(A, ell, "DMFP") == burley_d_dmfp(A, ell)
    with pytest.raises(ProfileError, match="Burley configuration must be one of"):
        burley_d(A, ell, "sideways")
    with pytest.raises(ProfileError, match="albedo"):
        burley_d(1.2, ell)
    with pytest.raises(ProfileError, match="mean free path"):
        burley_d(0.5, -1.0)


def test_burley_for_material_uses_dipole_albedo_and_searchlight_d():
    m = MATERIALS.get("skin1")
    bur = profile_for_material(m, "burley", albedo_source="dipole")
    dip = dipole_profile(m)
    for c in range(3):
        assert bur.channels[c].albedo == pytest.approx(dip.channels[c].total_rd())
        assert bur.channels[c].d == pytest.approx(float(burley_d_searchlight(dip.channels[c].total_rd(), 1 / m.sigma_t[c])))
    assert bur.provenance["albedo_source"] == "dipole"


def test_burley_takes_its_albedo_from_monte_carlo_by_default(tmp_path, monkeypatch):
    """A = MCML's total diffuse reflectance (all reflected light): the dipole's albedo error against
    MCML (Skin1 green 0.2273 vs 0.2093, blue 0.1310 vs 0.1131) is not inherited."""
    from ssskit.profiles.montecarlo import montecarlo_rgb

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    m = MATERIALS.get("skin1")
    bur = profile_for_material(m, "burley", photons=20_000)
    mc = montecarlo_rgb(m, photons=20_000)
    for c in range(3):
        assert bur.channels[c].albedo == mc.channels[c].total_rd_with_overflow()
        assert bur.channels[c].total_rd() == pytest.approx(mc.channels[c].total_rd_with_overflow(), rel=1e-9)
    assert bur.provenance["albedo_source"] == "montecarlo"
    dip = dipole_profile(m).total_rd()
    assert dip[1] == pytest.approx(0.2273, abs=5e-4) and dip[2] == pytest.approx(0.1310, abs=5e-4)
    assert bur.total_rd()[1] == pytest.approx(0.2093, abs=0.004) and bur.total_rd()[2] == pytest.approx(0.1131, abs=0.004)
    with pytest.raises(ProfileError, match="albedo source"):
        profile_for_material(m, "burley", albedo_source="guess")


def test_radius_at_fraction_inverts_energy():
    for prof in (DipoleProfile(0.03, 0.7), deon2007_profile().channels[1]):
        for f in (0.01, 0.5, 0.99, 0.999999):
            r = prof.radius_at_fraction(f)
            assert float(prof.energy_within(r)) / prof.total_rd() == pytest.approx(f, rel=1e-10)
    with pytest.raises(ProfileError):
        DipoleProfile(0.03, 0.7).radius_at_fraction(1.0)


def test_deon2007_skin_weights_sum_to_one():
    prof = deon2007_profile()
    np.testing.assert_allclose(prof.total_rd(), [1.0, 1.0, 1.0], atol=1e-12)
    assert profile_for_material(None, "deon2007").total_rd()[0] == pytest.approx(1.0)
    with pytest.raises(ProfileError, match="needs a material"):
        profile_for_material(None, "dipole")


@pytest.mark.parametrize("material", ["skin1", MATERIALS.get("marble"), "no-such-material"])
def test_deon2007_refuses_a_material(material):
    with pytest.raises(ProfileError, match="^the deon2007 model is a fixed preset and takes no material \\(got '"):
        profile_for_material(material, "deon2007")
    if not isinstance(material, str):
        with pytest.raises(ProfileError, match="takes no material"):
            deon2007_profile(material)


@pytest.mark.parametrize("name", ["Skin1", "Marble"])
def test_gaussian_fit_keeps_l1_and_fits_energy(name):
    dip = dipole_profile(MATERIALS.get(name))
    for chan in dip.channels:
        fit = fit_gaussian_sum(chan, 6)
        assert fit.total_rd() == pytest.approx(chan.total_rd(), rel=1e-12)  # L1 constraint of Eq. S.1
        assert np.all(fit.weights >= 0)
        # the fitted 2 pi r R(r) tracks the dipole's: energy-weighted relative L1 error below 10%
        r = np.linspace(1e-4, float(chan.radius_at_fraction(0.999)), 4000)
        err = np.trapezoid(2 * np.pi * r * np.abs(fit.eval(r) - chan.eval(r)), r) / chan.total_rd()
        assert err < 0.10


def test_unknown_model():
    with pytest.raises(ProfileError, match="unknown profile model 'multipole'"):
        profile_for_material("skin1", "multipole")


def test_unknown_keywords_are_profile_errors():
    """A keyword a model does not take is a ProfileError naming the model's keywords (for montecarlo those it
    passes on to simulate_material too), not Python's TypeError; checked before any simulation."""
    with pytest.raises(ProfileError, match=r"profile model 'montecarlo': unknown keyword argument\(s\) photonz "
                                           r"\(known: photons, seed, grid_fraction, roughness, threads"):
        profile_for_material("skin1", "montecarlo", photonz=1)
    with pytest.raises(ProfileError, match=r"profile model 'dipole': unknown keyword argument\(s\) photons "
                                           r"\(known: none\)"):
        profile_for_material("skin1", "dipole", photons=10**5)
    with pytest.raises(ProfileError, match=r"unknown keyword argument\(s\) albedo_src \(known: configuration"):
        profile_for_material("skin1", "burley", albedo_src="dipole")


def test_eval_refuses_radii_that_are_no_distance():
    """R(r) is defined for distances 0 <= r < inf: a NaN, infinite or negative radius is a ProfileError on every
    profile type (no silent 0, no cast warning), on the RGB profile too; r = 0 and an empty array pass."""
    import warnings

    profiles = [profile_for_material("skin1", "dipole"), profile_for_material("skin1", "burley", albedo_source="dipole"),
                GaussianSumProfile((0.5, 0.5), (1.0, 4.0))]
    for prof in profiles:
        channel = prof.channels[0] if isinstance(prof, RGBProfile) else prof
        for bad in ([np.nan], [1.0, -0.5], [np.inf], -np.inf):
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                with pytest.raises(ProfileError, match=r"a profile's radii must (lie in \[0, inf\) mm|be finite), got"):
                    channel.eval(np.array(bad))
        assert channel.eval(np.array([])).shape == (0,)
        assert np.all(np.isfinite(channel.eval([0.0, 1.0]))) or channel.model == "burley"  # Burley: 1/r at 0
    with pytest.raises(ProfileError, match="radii"):
        profiles[0].eval([np.nan])


def test_bad_profile_parameters():
    with pytest.raises(ProfileError):
        BurleyProfile(0.5, 0.0)
    with pytest.raises(ProfileError):
        DipoleProfile(-1.0, 1.0)
    with pytest.raises(ProfileError):
        DipoleProfile(0.1, 1.0, eta=0.8)


def test_rgb_to_dict_shape():
    prof = profile_for_material("ketchup", "burley", albedo_source="dipole")
    data = prof.to_dict(np.array([0.0, 0.5, 1.0]))
    assert set(data["channels"]) == {"R", "G", "B"}
    assert data["channels"]["G"]["total_Rd"] == pytest.approx(prof.total_rd()[1])
    assert data["channels"]["R"]["Rd"][0] is None  # R(0) = inf for Burley: JSON null
    assert math.isfinite(data["channels"]["R"]["Rd"][1])


def test_a_given_burley_albedo_lies_in_0_1():
    """profile_for_material's burley albedo override took A = 0 (R(r) = 0 in that channel) where BurleyParams,
    render and export refuse it: one domain, (0, 1]; A = 1 is taken and is the channel's total reflectance."""
    from ssskit.errors import ProfileError

    for albedo in ((0.0, 0.5, 0.5), (0.5, 1.01, 0.5), (0.5, float("nan"), 0.5), 0.0):
        with pytest.raises(ProfileError, match=r"albedo A must lie in \(0, 1\], got .* \(a reflectance; A = 0 reflects "):
            profile_for_material("skin1", "burley", albedo=albedo)
    with pytest.raises(ProfileError, match=r"albedo A must be a number or three \[R, G, B\], got \(0.5, 0.5\)"):
        profile_for_material("skin1", "burley", albedo=(0.5, 0.5))
    # one number is every channel's, as BurleyParams, the settings' albedo and --albedo take it
    assert profile_for_material("skin1", "burley", albedo=0.5).total_rd() == pytest.approx([0.5, 0.5, 0.5])
    assert profile_for_material("skin1", "burley", albedo=(1.0, 0.5, 0.25)).total_rd() == pytest.approx([1.0, 0.5, 0.25])
