"""The cheap units check of the path-traced reference: with an index-matched boundary (Mitsuba
``null``) the slab's uniformly lit plateau shows the radiance MCML predicts at eta = 1.

MCML (:mod:`ssskit.profiles.montecarlo`) gives the total diffuse reflectance Rd for the plateau's
incidence angle and the radiance factor near the normal (the exit is not Lambertian: for Skin1 the
radiance along the normal is 4-15% below Rd E / pi, :meth:`MCResult.radiance_factor_at`); the
G-buffer gives E / pi per pixel. A wrong unit (mm vs cm in sigma), a wrong medium scale or albedo,
or a lost factor of pi shows up here as a percent-level or larger error. Measured (128 spp, 2e6
photons per channel): ratios 1.00-1.01 with combined standard errors of ~0.5%."""

import dataclasses

import numpy as np
import pytest

from ssskit.materials import get_material
from ssskit.profiles.montecarlo import config_for_material, simulate
from ssskit.scenes import render_gbuffer
from ssskit.scenes.reference import ReferenceRenderer, batch_mean_se

LIGHT = np.array([400.0, 0.0, 1000.0])


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


def test_index_matched_slab_plateau_matches_mcml_at_eta_1():
    mat = dataclasses.replace(get_material("skin1"), eta=1.0)
    w, h = 64, 48
    gb = render_gbuffer("slab", (1.0, 1.0, 1.0), eta=1.0, width=w, height=h, spp=16)
    world = gb.camera.unproject(gb.depth)
    # the plateau: > 15 mm from the shadow edge (x = 0) and the slab's side (x = -60 mm), where the
    # half-plane beyond holds < 0.06% of Skin1's red profile
    region = (world[..., 0] >= -36.0) & (world[..., 0] <= -15.0) & (np.abs(world[..., 1]) < 25.0)
    ys, xs = np.nonzero(region)
    crop = (int(xs.min()), int(ys.min()), int(np.ptp(xs) + 1), int(np.ptp(ys) + 1))
    sub = region[crop[1]:crop[1] + crop[3], crop[0]:crop[0] + crop[2]]
    r = ReferenceRenderer("slab", mat, w, h, max_depth=1024, seed=5, boundary="index-matched", crop=crop)
    means = np.array([r.chunk(i, 8)[sub].mean(axis=0) for i in range(16)])  # 128 spp in 16 batches
    ref, ref_se = batch_mean_se(means)
    p = world[region]
    inc = float(np.degrees(np.mean(np.arccos(LIGHT[2] / np.linalg.norm(LIGHT - p, axis=1)))))
    mu = float(np.mean(600.0 / np.linalg.norm(np.array([0, 0, 600.0]) - p, axis=1)))
    assert 22.5 < inc < 24.0 and mu > 0.998
    pred, pred_se = np.zeros(3), np.zeros(3)
    for c in range(3):
        res = simulate(dataclasses.replace(config_for_material(mat, c, photons=2_000_000, seed=9), incidence_deg=inc))
        f, f_se = res.radiance_factor_at(mu, bins=8)
        pred[c] = gb.diffuse[region][:, c].mean() * res.total_rd * f
        pred_se[c] = pred[c] * np.hypot(f_se / f, res.total_rd_se / res.total_rd)
    ratio = ref / pred
    se = ratio * np.hypot(ref_se / ref, pred_se / pred)
    # 128 spp give ~0.2-0.4% on the plateau, 2e6 photons ~0.3-0.4% on the factor near the normal:
    # a 1% bound is ~2 combined standard errors, and a 2% error fails at > 3
    assert np.all(se < 0.006), se
    np.testing.assert_allclose(ratio, 1.0, atol=0.01, err_msg=f"ratio {ratio}, standard error {se}")
