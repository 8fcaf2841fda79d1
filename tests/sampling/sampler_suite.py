"""The reusable sampler test suite (DESIGN: every distribution runs it).

Add a factory to DISTRIBUTIONS for every new distribution in ssskit.sampling; the checks are:
pdf integrates to 1; cdf equals the integral of pdf; a chi-square test of sample() against pdf();
invert(sample(u)) == u; finite output at extreme parameters and extreme u.
"""

from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.integrate import quad

from ssskit.profiles import DipoleProfile, deon2007_profile
from ssskit.sampling import BurleyRadial, BurleyRadialApprox, ProfileRadial

#: name -> (factory(scale), typical length) ; scale multiplies the distribution's length parameter
DISTRIBUTIONS = {
    "burley-exact": lambda s: BurleyRadial(0.8 * s),
    "burley-xie-eq21": lambda s: BurleyRadialApprox(0.8 * s),
    "burley-xie-minimax-c": lambda s: BurleyRadialApprox(0.8 * s, c=2.5952),
    "dipole-radius": lambda s: ProfileRadial(DipoleProfile(0.032 / s, 0.74 / s, 0.0, 1.3)),
    "gaussians-radius": lambda s: ProfileRadial(_scaled_deon(s)),
}

#: the parameter scales the "extreme parameters" check runs
EXTREME_SCALES = (1e-4, 1e4)


def _scaled_deon(s):
    from ssskit.profiles import GaussianSumProfile

    base = deon2007_profile().channels[0]
    return GaussianSumProfile(base.weights, base.variances * s * s)


def integrate_pdf(dist, a=0.0, b=np.inf, length=1.0):
    f = lambda x: float(dist.pdf(x))
    pts = [p for p in (0.1 * length, length, 10 * length, 100 * length) if a < p < b]
    edges = [a, *pts, b]
    return sum(quad(f, lo, hi, limit=400, epsabs=1e-14, epsrel=1e-11)[0] for lo, hi in zip(edges[:-1], edges[1:]))


def check_pdf_normalised(dist, length):
    total = integrate_pdf(dist, length=length)
    assert abs(total - 1.0) < 1e-7, total


def check_cdf_is_integral_of_pdf(dist, length):
    for x in (0.05 * length, 0.7 * length, 4 * length):
        ref = integrate_pdf(dist, 0.0, x, length)
        got = float(dist.cdf(x))
        assert abs(got - ref) < 1e-8, (x, got, ref)


def check_chi_square(dist, length, n=200_000, bins=60, seed=7):
    u = np.random.default_rng(seed).random(n)
    x = dist.sample(u)
    assert np.all(np.isfinite(x)) and np.all(x >= 0)
    # bin edges from a fixed geometric ladder, expected counts from quadrature of pdf (not cdf)
    edges = np.concatenate([[0.0], np.geomspace(1e-3 * length, 40 * length, bins - 1), [np.inf]])
    probs = np.array([integrate_pdf(dist, a, b, length) for a, b in zip(edges[:-1], edges[1:])])
    counts = np.histogram(x, edges)[0]
    keep = probs * n >= 5
    expected = probs[keep] * n
    observed = counts[keep]
    # fold the dropped bins into one so the totals match
    expected = np.append(expected, n - expected.sum())
    observed = np.append(observed, n - observed.sum())
    if expected[-1] < 5:
        expected[-2] += expected[-1]
        observed[-2] += observed[-1]
        expected, observed = expected[:-1], observed[:-1]
    chi2 = float(np.sum((observed - expected) ** 2 / expected))
    p = stats.chi2.sf(chi2, len(expected) - 1)
    assert p > 1e-3, (chi2, len(expected), p)


def check_invert_roundtrip(dist):
    u = np.concatenate([np.linspace(0, 0.999999, 1001), [1e-12, 1e-9, 0.5, 1 - 1e-9]])
    back = dist.invert(dist.sample(u))
    np.testing.assert_allclose(back, u, rtol=1e-9, atol=1e-12)


def check_finite_extremes(factory):
    u = np.array([0.0, 1e-15, 1e-6, 0.5, 1 - 1e-6, 1 - 1e-12])
    for s in EXTREME_SCALES:
        dist = factory(s)
        x = dist.sample(u)
        assert np.all(np.isfinite(x)) and np.all(np.diff(x) >= 0), (s, x)
        assert np.all(np.isfinite(dist.pdf(x))) and np.all(np.isfinite(dist.cdf(x)))
