"""Ground truth of the Burley pass (issue 13, Must show: consistency).

On a fronto-parallel surface the pass with the exact sampler and no mips converges to the exact 2D
convolution of the diffuse layer with Burley's R(r) (Xie 2020 Eq. 4) under Eq. 24's boundary rule:
samples off the region are dropped from both sums, so the limit is the normalised convolution

    M_c = ((m E_c) * K_c) / (m * K_c)                 inside the region m

with K_c the exact cell integrals of R_c on the pixel grid (the nearest-texel fetch makes the
estimator's expectation exactly this sum). It is built here from the same ingredients as
:func:`ssskit.truth.exact_screen_space` (``discretize_2d`` and an FFT convolution), and checked
against it where the region covers the whole kernel, where the two boundary rules coincide.

With independent samples (``sequence="random"``) the RMS error must fall as 1/sqrt(n) over
n = 4..4096 (fitted log-log slope within 10% of -0.5) and the mean over the mask must agree with the
truth within 3 standard errors; the default R2 sequence (randomised quasi-Monte Carlo) must converge
at least as fast.
"""

import numpy as np
import pytest
from scipy.signal import fftconvolve

from ssskit.backends import get_backend
from ssskit.screenspace import BurleyParams, Camera, GBuffer, burley_sss
from ssskit.truth import exact_screen_space

NS = [4, 16, 64, 256, 1024, 4096]


def normalised_truth(gb: GBuffer, params: BurleyParams) -> np.ndarray:
    """((m E) * K) / (m * K) inside the region (one id, constant depth, square pixels); float64."""
    h, w = gb.shape
    z = float(np.median(gb.depth_mm[gb.mask]))
    cell = z / gb.camera.fx  # mm per pixel
    k = params.profile().discretize_2d(cell, 2 * max(h, w) + 1)  # every offset inside the image
    m = gb.mask.astype(float)[..., None]
    e = gb.diffuse.astype(float)
    num = fftconvolve(m * e, k, mode="same", axes=(0, 1))
    den = fftconvolve(np.broadcast_to(m, e.shape), k, mode="same", axes=(0, 1))
    return np.where(m > 0, num / np.where(m > 0, den, 1.0), e), den / k.sum(axis=(0, 1))


def _disk_gbuffer(h=48, w=64):
    """A textured disk of one profile id at 400 mm, 3 pixels per mm, square pixels."""
    rng = np.random.default_rng(1)
    yy, xx = np.mgrid[0:h, 0:w]
    e = 0.5 + 0.5 * np.sin(xx / 3.0)[..., None] * np.array([1.0, 0.5, 0.2]) + 0.3 * rng.random((h, w, 3))
    pid = ((xx - 32) ** 2 + (yy - 24) ** 2 < 20**2).astype(np.uint32)
    depth = np.where(pid > 0, 400.0, np.inf)
    return GBuffer(diffuse=e.astype(np.float32), albedo=np.ones((h, w, 3), np.float32),
                   depth=depth.astype(np.float32), profile_id=pid, camera=Camera(w, h, 1200.0, 1200.0, w / 2, h / 2))


PARAMS = BurleyParams.from_dmfp(0.6, (8.0, 4.0, 2.0))  # d = 2.0, 1.0, 0.5 mm: 6, 3, 1.5 px


def _convergence(gb, params, truth, backend, sequence):
    inside = gb.mask
    rmse, bias = [], []
    for n in NS:
        out = burley_sss(gb, params, spp=n, sampler="exact", sequence=sequence, seed=11, mips=False, backend=backend)
        err = (out.astype(float) - truth)[inside]
        rmse.append(np.sqrt(np.mean(err**2)))
        bias.append(np.abs(err.mean(axis=0)) / (err.std(axis=0, ddof=1) / np.sqrt(err.shape[0])))
    slope = np.polyfit(np.log(NS), np.log(rmse), 1)[0]
    return slope, np.array(rmse), np.array(bias)


def test_reference_is_the_exact_screen_space_convolution():
    """exact_screen_space keeps the centre value for the share s of the kernel off the region; with the
    same (whole-image) kernel it equals spread * M + (1 - spread) * E, spread = (m * K) / sum K."""
    gb = _disk_gbuffer()
    truth, spread = normalised_truth(gb, PARAMS)
    exact = exact_screen_space(gb, PARAMS.profile(), fraction=0.9999)  # radius clipped to the image
    inside = gb.mask
    want = spread * truth + (1.0 - spread) * gb.diffuse
    np.testing.assert_allclose(exact[inside], want[inside], rtol=1e-5, atol=1e-6)
    assert np.abs(exact - truth)[inside].max() > 1e-3  # the boundary rules do differ near the edge


def test_one_over_sqrt_n_and_unbiased_on_a_synthetic_gbuffer(backend):
    if "burley" not in get_backend(backend).passes:
        pytest.skip(f"backend {backend} has no Burley pass")
    gb = _disk_gbuffer()
    truth, _ = normalised_truth(gb, PARAMS)
    slope, rmse, bias = _convergence(gb, PARAMS, truth, backend, "random")
    assert -0.55 <= slope <= -0.45, (slope, rmse)
    assert np.all(bias < 3.0), bias  # mean over the mask within 3 standard errors, every n and channel
    slope_r2, rmse_r2, _ = _convergence(gb, PARAMS, truth, backend, "r2")
    assert slope_r2 < -0.5 and np.all(rmse_r2[2:] < rmse[2:]), (slope_r2, rmse_r2)


@pytest.mark.slow
def test_one_over_sqrt_n_on_the_slab_scene():
    """The slab scene (Mitsuba G-buffer, head-on at 600 mm, a hard shadow edge), one material."""
    from ssskit.scenes import render_gbuffer

    params = BurleyParams.from_dmfp(0.6, (12.0, 6.0, 3.0))
    gb = render_gbuffer("slab", params.albedo, width=96, height=72, spp=4)
    z = gb.depth_mm[gb.mask]
    assert gb.mask.all() and np.ptp(z) < 1e-3 * z.mean()  # fronto-parallel, one region
    truth, _ = normalised_truth(gb, params)
    slope, rmse, bias = _convergence(gb, params, truth, "numba", "random")
    assert -0.55 <= slope <= -0.45, (slope, rmse)
    assert np.all(bias < 3.0), bias
