"""1D taps of the separable pass (separable-SSS paper section 6): placement, normalisation, exact pairs."""

import numpy as np
import pytest

from ssskit.backends import term_rows
from ssskit.errors import SamplingError
from ssskit.kernels import build_kernel, default_grid
from ssskit.sampling.taps import SeparableTaps, make_taps


def test_importance_taps_equal_mass_of_dominant_channel(taps7):
    t = taps7
    assert t.taps == 7 and t.rank == 1
    np.testing.assert_allclose(t.total(), 1.0, rtol=1e-12)
    o = t.offsets_mm[0]
    assert o[0] == 0.0 and np.allclose(np.sort(o), -np.sort(o)[::-1])
    # red is the widest channel of skin: every cell holds 1/7 of its (normalised) 1D mass
    np.testing.assert_allclose(t.weights[0][:, 0], 1.0 / 7.0, rtol=1e-6)
    # narrower channels put more weight on the centre tap
    assert t.weights[0][0, 2] > t.weights[0][0, 1] > t.weights[0][0, 0]


def test_uniform_and_quadratic_spacing(skin):
    cell, n = default_grid(skin)
    k = build_kernel("preintegrated", skin, cell, n)
    u = np.sort(make_taps(k, 7, "uniform").offsets_mm[0])
    np.testing.assert_allclose(np.diff(u), np.diff(u)[0], rtol=1e-9)
    q = np.sort(make_taps(k, 7, "quadratic").offsets_mm[0])
    # o_i proportional to sign(t) t^2 at t = -3..3 (engine spacing): 9 : 4 : 1
    np.testing.assert_allclose(q[4:] / q[6], [1 / 9, 4 / 9, 1.0], rtol=1e-9)
    with pytest.raises(SamplingError, match="odd"):
        make_taps(k, 6)


@pytest.mark.parametrize("method", ["importance", "uniform", "quadratic"])
@pytest.mark.parametrize("spec", ["preintegrated", "svd:3", "artist"])
def test_taps_are_exact_mirror_pairs_and_the_plan_pairs_them(skin, method, spec):
    """An even kernel's taps come in exact pairs (o, -o, equal weights), so the pass plan makes one
    symmetric row per pair and no single rows: nothing is re-guessed by a tolerance."""
    from ssskit.kernels import parse_method_spec

    m, params, _ = parse_method_spec(spec)
    cell, n = default_grid(skin)
    t = make_taps(build_kernel(m.name, skin, cell, n, **params), 7, method)
    for r in range(t.rank):
        o, w = t.offsets_mm[r], t.weights[r]
        for i in range(1, 7):
            j = int(np.flatnonzero(o == -o[i])[0])
            np.testing.assert_array_equal(w[i], w[j])
        offs, wp, wm, nj = term_rows(o, w, t.jitter_count(0.1))
        assert offs.size == 3 and np.array_equal(wp, wm)  # 3 symmetric pairs, no single rows
        assert nj == (t.jitter_count(0.1) - 1) // 2  # the pairs inside the jitter radius


def test_engine_kernel_taps_are_pairs_and_the_tap_count_is_the_kernels():
    """jimenez2012 ships its own taps: asking for another count is an error, not silently ignored."""
    k = build_kernel("jimenez2012", None, taps=11)
    t = make_taps(k)
    assert t.taps == 11
    offs, wp, wm, _ = term_rows(t.offsets_mm[0], t.weights[0], 0)
    assert offs.size == 5 and np.array_equal(wp, wm)
    assert make_taps(k, 11).taps == 11
    with pytest.raises(SamplingError, match="ships 11 taps"):
        make_taps(k, 7)


def test_asymmetric_taps_become_single_rows():
    t = SeparableTaps([[0.0, 0.7, -1.3, 2.2]], [[[0.4] * 3, [0.3, 0.2, 0.1], [0.2] * 3, [0.1, 0.3, 0.2]]],
                      [[1.0, 1.0, 1.0]], "custom", 2.2)
    offs, wp, wm, nj = term_rows(t.offsets_mm[0], t.weights[0], 0)
    np.testing.assert_allclose(offs, [0.7, 1.3, 2.2])
    np.testing.assert_array_equal(wm[0], 0.0)  # +0.7: a tap on the + side only
    np.testing.assert_array_equal(wp[1], 0.0)  # -1.3: on the - side only
    assert nj == 0
