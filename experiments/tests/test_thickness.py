"""The thin medium's back losses (lab.thickness): the path-traced slab cut to 2 mm loses what MCML
says it loses, and the ear's prediction averages Rd(t) / Rd(inf) the way a level is averaged."""

import types

import numpy as np
import pytest

from ssskit.errors import SettingsError
from lab.attribution import ATTRIBUTION_REGIONS
from lab.thickness import predict_thin, slab_check, slab_setups, thickness_setups


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


def test_index_matched_thin_slab_loses_what_mcml_says():
    """The slab's plateau, 2 mm thick against 20 mm, index-matched boundary (Mitsuba null, MCML at eta = 1),
    64 spp in 8 paired chunks: the reference's ratio equals MCML's Rd(2) F_2(mu) / (Rd(20) F_20(mu)) at the
    plateau's 23 degrees within 3.5 combined standard errors, and that error is small enough (< 2%) to see
    the red loss (~25%) many times over: a slab that did not lose light through its back fails by > 10 SE."""
    res = slab_check("skin1", thicknesses=(2.0,), spp=64, photons=50_000, mcml_photons=200_000, width=64,
                     height=48)
    assert 22.5 < res["incidence_deg"] < 24.0 and res["view_cosine"] > 0.998 and res["eta"] == 1.0
    row = res["rows"][0]
    ref, mc = np.array(row["reference_ratio"]["value"]), np.array(row["mcml_ratio"]["value"])
    se = np.hypot(row["reference_ratio"]["se"], row["mcml_ratio"]["se"])
    assert np.all(se < 0.02), se
    assert mc[0] < 0.8 and mc[0] < mc[1] < mc[2]  # red loses most
    assert np.all(np.abs(ref - mc) <= 3.5 * se), (ref, mc, se)


def _prep(e, exact, albedo):
    gb = types.SimpleNamespace(diffuse=e, albedo=albedo)
    return types.SimpleNamespace(gbuffer=gb, exact=exact)


def test_predict_thin_weights_like_a_level():
    """Two pixels of thickness 1 and 2 mm where f = 0.5 and 0.9: the level's prediction is sum(w) /
    sum(w f), w = E / pi (entry) or the exact result (exit); NaN thickness leaves a pixel out."""
    h, w = 1, 3
    e = np.array([[[1.0] * 3, [3.0] * 3, [5.0] * 3]])
    exact = np.array([[[2.0] * 3, [1.0] * 3, [1.0] * 3]])
    albedo = np.full((h, w, 3), 0.5)
    masks = {name: np.ones((h, w), bool) for name in ATTRIBUTION_REGIONS}
    thick = np.array([[1.0, 2.0, np.nan]])
    table = {"thickness_mm": [1.0, 2.0], "ratio": [[0.5] * 3, [0.9] * 3], "ratio_se": [[0.01] * 3, [0.02] * 3]}
    out = predict_thin(_prep(e, exact, albedo), masks, thick, table)["object"]
    assert out["pixels"] == 2 and out["pixels_left_out"] == 1
    np.testing.assert_allclose(out["entry_weighted"]["value"], 4.0 / (0.5 + 2.7))
    np.testing.assert_allclose(out["exit_weighted"]["value"], 1.5 / (0.5 + 0.45))
    np.testing.assert_allclose(out["mean_thickness_mm"], (1.0 + 6.0) / 4.0)
    # the table's errors taken fully correlated: r * sum(w se) / sum(w f)
    np.testing.assert_allclose(out["entry_weighted"]["se"], 4.0 / 3.2 * (0.01 + 0.06) / 3.2)


def test_setups_and_their_checks():
    s = thickness_setups("ear", "skin1", (10.0,))
    assert [x.scene.name for x in s] == ["ear-backed", "ear-deep10-backed"]
    sl = slab_setups("skin1", (4.0, 2.0))
    assert [x.scene if isinstance(x.scene, str) else x.scene.name for x in sl] == ["slab", "slab-t4", "slab-t2"]
    assert all(x.boundary == "index-matched" and x.material.eta == 1.0 for x in sl)
    with pytest.raises(SettingsError):
        thickness_setups("ear", "skin1", (1.0,))
    with pytest.raises(SettingsError):
        slab_setups("skin1", (2.0,), boundary="glass")


def test_predict_thin_interpolates_between_incidence_angles():
    """Tables at 0 and 60 degrees (f = 0.5 and 0.8 at 1 mm): a pixel at 30 degrees gets 0.65, one at 80
    the 60 degree table's value (clamped), one with no light (NaN angle) is left out."""
    e = np.ones((1, 3, 3))
    masks = {name: np.ones((1, 3), bool) for name in ATTRIBUTION_REGIONS}
    tabs = [{"incidence_deg": a, "thickness_mm": [1.0], "ratio": [[f] * 3], "ratio_se": [[0.0] * 3]}
            for a, f in ((0.0, 0.5), (60.0, 0.8))]
    prep = _prep(e, e, np.ones((1, 3, 3)))
    thick = np.ones((1, 3))
    out = predict_thin(prep, masks, thick, tabs, np.array([[30.0, 80.0, np.nan]]))["object"]
    assert out["pixels"] == 2 and out["pixels_left_out"] == 1 and out["mean_incidence_deg"] == pytest.approx(55.0)
    np.testing.assert_allclose(out["entry_weighted"]["value"], 2.0 / (0.65 + 0.8))
    with pytest.raises(SettingsError, match="ascend"):
        predict_thin(prep, masks, thick, tabs[::-1], np.array([[30.0, 80.0, 10.0]]))
