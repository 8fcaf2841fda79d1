"""The back-lit thin slab through the whole pass: Skin1 slabs of 0.5, 1, 2, 4 and 8 mm lit from behind at
normal incidence, the pass's transmitted level (the MCML model, fitted to one set of simulations) against
MCML's scattered transmittance T_s = Tt - the unscattered beam of an independent run (other seeds) of each
thickness, per channel: within 5 % or 3 standard errors. (Against the path trace:
tests/screenspace/test_transmission_truth.py.)"""

import numpy as np
import pytest

from ssskit.backends import get_backend
from ssskit.materials import get_material
from ssskit.profiles.montecarlo import simulate
from ssskit.profiles.montecarlo.slab import slab_config
from ssskit.profiles.montecarlo.transmission import absorber_transmittance
from ssskit.screenspace.transmission import LightView, mcml_model, transmission_plan

SKIN = get_material("skin1")
THICK = (0.5, 1.0, 2.0, 4.0, 8.0)


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


@pytest.mark.slow
def test_backlit_slab_matches_mcml_per_thickness_and_channel():
    plan = transmission_plan({1: mcml_model(SKIN)})  # the default model: 200,000 photons per entry
    # the slab's back face (the first surface the light meets) at depth 1000 mm of an orthographic light
    # looking along -z; one pixel per thickness, on the front face t behind it, its normal facing away
    view = LightView.looking_along(np.array([0.0, 0.0, -1.0]), np.zeros(3), 64.0, 64, distance_mm=1000.0)
    shadow = np.full((64, 64), 1000.0)
    pts = np.array([[x, 0.0, -t] for x, t in zip(np.linspace(-20, 20, len(THICK)), THICK)])
    uvz = view.project(pts)[None]
    slots = np.ones((1, len(THICK)), np.int32)
    ndl = np.full((1, len(THICK)), -1.0)  # N . L = -1: the back face faces the light squarely
    e = np.ones((1, len(THICK), 3))
    out = get_backend("numpy").transmission(plan, slots, uvz, shadow, ndl, e)[0]
    ok = np.zeros((len(THICK), 3), bool)
    for i, t in enumerate(THICK):
        for c in range(3):
            r = simulate(slab_config(SKIN, c, t, 100_000, 7000 + i))  # independent of the fit's runs
            ts = r.tt - float(absorber_transmittance(SKIN.sigma_t[c], t, SKIN.eta))
            ok[i, c] = abs(out[i, c] - ts) <= max(0.05 * ts, 3 * r.tt_se)
    assert ok.all(), f"cells within 5 % or 3 SE (rows {THICK} mm, columns RGB):\n{ok}"
