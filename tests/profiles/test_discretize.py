import numpy as np
import pytest
from scipy.integrate import dblquad, quad

from ssskit.errors import ProfileError
from ssskit.profiles import BurleyProfile, DipoleProfile, deon2007_profile, profile_for_material

PROFILES = {
    "burley": BurleyProfile(0.8, 0.5),
    "dipole": DipoleProfile(0.032, 0.74, 0.0, 1.3),
    "gaussians": deon2007_profile().channels[0],
}


def centre_cell_polar(prof, h):
    """Independent: 8 x Int_0^{pi/4} Int_0^{h/(2 cos t)} R(r) r dr dt, from eval() alone."""
    inner = lambda t: quad(lambda r: r * float(prof.eval(r)), 0, h / (2 * np.cos(t)), epsabs=0, epsrel=1e-12, limit=200)[0]
    return 8 * quad(inner, 0, np.pi / 4, epsabs=0, epsrel=1e-11)[0]


@pytest.mark.parametrize("kind", PROFILES)
@pytest.mark.parametrize("h", [0.02, 0.3, 2.0])
def test_cells_match_independent_integrals(kind, h):
    prof = PROFILES[kind]
    n = 9
    cells = prof.discretize_2d(h, n)
    c = n // 2
    assert np.isfinite(cells).all()
    assert cells[c, c] == pytest.approx(centre_cell_polar(prof, h), rel=1e-8)
    # an off-centre cell (x index c + 2, y index c + 1) by plain 2D quadrature of eval()
    x0, y0 = 1.5 * h, 0.5 * h
    ref = dblquad(lambda y, x: float(prof.eval(np.hypot(x, y))), x0, x0 + h, y0, y0 + h, epsabs=0, epsrel=1e-10)[0]
    assert cells[c + 1, c + 2] == pytest.approx(ref, rel=1e-8)
    # radial symmetry of the grid: the 8 symmetries of the square
    np.testing.assert_allclose(cells, cells.T, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(cells, cells[::-1, :], rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize("model", ["dipole", "burley", "gaussians"])
@pytest.mark.parametrize("name", ["Skin1", "Marble", "Ketchup"])
def test_grid_covering_999_permille_sums_to_total(model, name):
    """A grid covering 99.9% of the energy sums to the energy in its square (exact, to 1e-4
    relative of total Rd), which lies between 99.9% and 100% of the total."""
    prof = profile_for_material(name, model)
    for chan in prof.channels:
        r999 = float(chan.radius_at_fraction(0.999))
        n = 101
        h = 2 * r999 / n
        cells = chan.discretize_2d(h, n)
        total = chan.total_rd()
        half = n * h / 2
        # independent square integral: 8 Int_0^{pi/4} E(half / cos t) dt / (2 pi), E from quad of eval
        square = 8 * quad(lambda t: float(chan.energy_within(half / np.cos(t))), 0, np.pi / 4, epsrel=1e-12)[0] / (2 * np.pi)
        assert cells.sum() == pytest.approx(square, rel=1e-10)
        assert abs(cells.sum() - square) < 1e-4 * total
        assert 0.999 * total <= cells.sum() <= total * (1 + 1e-12)
        assert np.all(cells >= 0)


def test_cell_integral_of_one_over_r_centre_is_finite():
    prof = BurleyProfile(1.0, 1.0)
    cells = prof.discretize_2d(0.001, 3)
    # for h << d the centre cell of A/(8 pi d r) * 2 ~ 1/(4 pi d r) integrates to
    # (1 / (4 pi d)) * 8 * Int_0^{pi/4} h / (2 cos t) dt = h * 4 asinh(1) / (4 pi d)... to first order
    expected = 0.001 * 4 * np.arcsinh(1.0) / (4 * np.pi)
    assert cells[1, 1] == pytest.approx(expected, rel=2e-3)


def test_grid_validation():
    with pytest.raises(ProfileError, match="odd"):
        BurleyProfile(0.5, 1.0).discretize_2d(0.1, 10)
    with pytest.raises(ProfileError, match="cell size"):
        BurleyProfile(0.5, 1.0).discretize_2d(-0.1, 11)


def test_rgb_discretize_shape():
    cells = profile_for_material("apple", "dipole").discretize_2d(0.1, 21)
    assert cells.shape == (21, 21, 3)
