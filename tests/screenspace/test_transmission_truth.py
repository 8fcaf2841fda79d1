"""The back-lit slab against the path trace (docs/transmission.md, "Against the path trace"): Skin1 slabs of 2 and
4 mm lit from behind at normal incidence, seen at 45 degrees through a narrow camera (the slab's middle), the
pass's transmitted level pi L / E (``ssskit render --transmission on``, the MCML model and its spread) against
the converged Mitsuba reference and against MCML's scattered transmittance T_s (independent runs), per channel:
within 5 % or 3 standard errors. (benchmarks/transmission_truth.py runs the five
thicknesses; the thinnest differ through the references' rough faces, measured in experiments/.)"""

import math

import numpy as np
import pytest

from ssskit.materials import get_material
from ssskit.pipeline import RenderSettings, render
from ssskit.profiles.montecarlo import simulate
from ssskit.profiles.montecarlo.slab import slab_config
from ssskit.profiles.montecarlo.transmission import absorber_transmittance
from ssskit.scenes import render_reference
from ssskit.scenes.backlit import backlit_slab

SKIN = get_material("skin1")


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


def _within(a, b, se):
    return abs(a - b) <= max(0.05 * abs(b), 3.0 * se)


@pytest.mark.slow
@pytest.mark.parametrize("t", [2.0, 4.0])
def test_backlit_slab_matches_the_path_trace(t):
    spec = backlit_slab(t, fov_deg=5.0)  # 26 mm of the slab's middle, 1.1 mm pixels at 24 x 18
    res = render(spec, RenderSettings(material="skin1", width=24, height=18, spp=4, transmission="on",
                                      exact=False, perceptual=False))
    gb = res.gbuffer
    _, _, ndl, light = gb.transmission_inputs()
    e = (light * np.clip(-ndl, 0.0, 1.0)[..., None]).reshape(-1, 3).mean(axis=0)
    assert gb.mask.all() and np.all(e > 3.1)
    ref = render_reference(spec, SKIN, 24, 18, spp=512, max_spp=16384, target_rel_se=0.015, progress=False)
    mean, se = ref.region_stats(gb.mask)
    level_ref, se_ref = math.pi * mean / e, math.pi * se / e
    level_pass = math.pi * res.transmitted.reshape(-1, 3).mean(axis=0) / e
    for c in range(3):
        assert _within(level_pass[c], level_ref[c], se_ref[c]), (c, level_pass, level_ref, se_ref)
        r = simulate(slab_config(SKIN, c, t, 200_000, 61 + c))  # MCML's scattered part, other seeds than the fit's
        ts = r.tt - float(absorber_transmittance(SKIN.sigma_t[c], t, SKIN.eta))
        assert _within(level_pass[c], ts, r.tt_se), (c, level_pass, ts, r.tt_se)
