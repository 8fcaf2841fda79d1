import numpy as np
import pytest
from scipy.optimize import brentq

from . import sampler_suite as suite
from ssskit.errors import SamplingError
from ssskit.profiles import burley_cdf
from ssskit.sampling import XIE_C, BurleyRadial, BurleyRadialApprox, fit_xie_c, xie_cdf_error, xie_g

NAMES = list(suite.DISTRIBUTIONS)


@pytest.mark.parametrize("name", NAMES)
def test_pdf_integrates_to_one(name):
    suite.check_pdf_normalised(suite.DISTRIBUTIONS[name](1.0), 1.0)


@pytest.mark.parametrize("name", NAMES)
def test_cdf_is_integral_of_pdf(name):
    suite.check_cdf_is_integral_of_pdf(suite.DISTRIBUTIONS[name](1.0), 1.0)


@pytest.mark.parametrize("name", NAMES)
def test_chi_square_sample_against_pdf(name):
    suite.check_chi_square(suite.DISTRIBUTIONS[name](1.0), 1.0)


@pytest.mark.parametrize("name", NAMES)
def test_invert_sample_roundtrip(name):
    suite.check_invert_roundtrip(suite.DISTRIBUTIONS[name](1.0))


@pytest.mark.parametrize("name", NAMES)
def test_finite_at_extreme_parameters(name):
    suite.check_finite_extremes(suite.DISTRIBUTIONS[name])


def test_chi_square_detects_the_wrong_density():
    """The suite can fail: Xie's approximate samples tested against Burley's exact pdf."""

    class Mislabelled(BurleyRadialApprox):
        def pdf(self, r):
            return self.target_pdf(r)

    with pytest.raises(AssertionError):
        suite.check_chi_square(Mislabelled(0.8), 1.0, n=400_000)


@pytest.mark.parametrize("xi", [1e-12, 1e-6, 1e-3, 0.1, 0.5, 0.9, 0.999, 1 - 1e-9])
def test_exact_inverse_to_1e_10(xi):
    d = 0.37
    ref = brentq(
        lambda r: (burley_cdf(r, d) - xi) if xi < 0.5 else ((1 - xi) - (0.25 * np.exp(-r / d) + 0.75 * np.exp(-r / (3 * d)))),
        0.0, 200.0, xtol=1e-300, rtol=1e-15, maxiter=500,
    )
    assert float(BurleyRadial(d).sample(xi)) == pytest.approx(ref, rel=1e-10)


def test_xie_eq21_formula():
    xi = np.array([0.25, 0.5, 0.75])
    np.testing.assert_allclose(xie_g(xi, 2.0, 2.5715), 2.0 * ((2 - 2.5715) * xi - 2) * np.log(1 - xi))


def test_least_squares_refit_finds_xie_c():
    c, err = fit_xie_c("lsq")
    assert c == pytest.approx(2.5715, abs=1e-4)
    assert err == pytest.approx(float(np.max(np.abs(xie_cdf_error(XIE_C)))), rel=1e-3)


def test_minimax_c_has_smaller_max_error():
    c_lsq, e_lsq = fit_xie_c("lsq")
    c_mm, e_mm = fit_xie_c("minimax")
    assert e_mm < e_lsq
    # minimax balances the largest positive and negative CDF errors
    err = xie_cdf_error(c_mm)
    assert err.max() == pytest.approx(-err.min(), rel=0.02)


def test_sampling_errors():
    with pytest.raises(SamplingError):
        BurleyRadial(0.0)
    with pytest.raises(SamplingError):
        BurleyRadial(1.0).sample([0.5, 1.5])
    with pytest.raises(SamplingError):
        BurleyRadialApprox(1.0, c=1.0)
    with pytest.raises(SamplingError):
        fit_xie_c("median")
