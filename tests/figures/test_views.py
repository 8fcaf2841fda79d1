"""The three-view study (Xie 2020 Fig. 1, Sec. 6.4 in kind) on the generated bust, kept tiny: small images,
few frames, a short converged limit."""

import math

import numpy as np
import pytest

from ssskit.figures import FIGURES
from ssskit.figures.views import (FIXED_SPP, STUDY_METHODS, STUDY_VIEWS, XIE_GOLUBEV_MINUS_EQ21, golubev_counts,
                                  study_gbuffer, study_json, three_view_study, xie_fig1)


def test_registered_and_views_are_xies():
    assert FIGURES.get("xie-fig1") is xie_fig1
    assert set(STUDY_VIEWS) == set(XIE_GOLUBEV_MINUS_EQ21) == {"close", "ear", "front"}
    assert XIE_GOLUBEV_MINUS_EQ21 == {"close": 2.09, "ear": 0.29, "front": 0.26}  # Xie 2020 Sec. 6.4


def test_golubev_counts_follow_the_footprint():
    """n = max(1, min(64, floor(pi r997^2 sx sy / 4))): the close view (larger footprint per mm) takes at
    least as many samples as the front view, never more than 64, none off the mask."""
    near = study_gbuffer("close", width=64, height=48, spp=1)
    far = study_gbuffer("front", width=64, height=48, spp=1)
    cn, cf = golubev_counts(near.gbuffer, near.params), golubev_counts(far.gbuffer, far.params)
    for gb, c in ((near.gbuffer, cn), (far.gbuffer, cf)):
        assert np.all(c[~gb.mask] == 0) and np.all((c[gb.mask] >= 1) & (c[gb.mask] <= FIXED_SPP))
    assert cn[near.gbuffer.mask].mean() > cf[far.gbuffer.mask].mean()


def test_three_view_study_table():
    study = three_view_study(views=("close", "ear"), width=48, height=36, frames=3, reference_spp=128, repeats=1,
                             gbuffer_spp=2)
    js = study_json(study)
    assert "images" not in js and set(js["golubev_minus_eq21"]) == {"close", "ear"}
    rows = {(r["view"], r["method"]): r for r in js["rows"]}
    assert set(rows) == {(v, m) for v in ("close", "ear") for m in STUDY_METHODS}
    for view in ("close", "ear"):
        diff = rows[(view, "golubev-64")]["psnr_gray"] - rows[(view, "eq21-64")]["psnr_gray"]
        assert js["golubev_minus_eq21"][view] == pytest.approx(diff, abs=1e-12)
        for m in STUDY_METHODS:
            r = rows[(view, m)]
            assert math.isfinite(r["psnr_gray"]) and r["psnr_gray"] > 20 and r["ms"] > 0
            assert (r["psnr_gray_taa"] is None) == (m == "separable")
        taa = rows[(view, "golubev-64")]["psnr_gray_taa"] - rows[(view, "eq21-64")]["psnr_gray_taa"]
        assert js["golubev_minus_eq21_taa"][view] == pytest.approx(taa, abs=1e-12)
        # the converged limit is less noisy than any method at its count: its two seeds agree better
        assert js["limit"][view]["psnr_gray_second_seed"] > max(rows[(view, m)]["psnr_gray"] for m in STUDY_METHODS)
        counts = study["images"][view]["adaptive"]["counts"]
        mask = study["images"][view]["mask"]
        assert np.all((counts[mask] >= 8) & (counts[mask] <= 64))  # Xie's budget [b_min, b_max] = [8, 64]
        assert rows[(view, "eq21-64")]["mean_spp"] == FIXED_SPP


@pytest.mark.slow
def test_path_traced_regions_of_the_study():
    """The per-region comparison with the path-traced bust: every lit region's level has a standard error,
    and each method's ratio to it is finite."""
    study = three_view_study(views=("ear",), width=40, height=30, frames=2, reference_spp=64, repeats=1,
                             gbuffer_spp=2, path_traced=True, path_traced_spp=(16, 64), path_traced_rel_se=0.5)
    table = study["regions"]["ear"]
    assert table["reference"]["spp"] >= 16
    lit = [r for r in table["regions"].values() if r["pixels"] and "path_traced" in r]
    assert lit
    for row in lit:
        assert all(np.isfinite(row["path_traced"]["se"]))
        assert set(row["methods"]) == set(STUDY_METHODS)
        assert all(np.all(np.isfinite(m["ratio"])) for m in row["methods"].values())


def test_study_on_a_two_material_mesh(tmp_path):
    """Any mesh scene with its units and material map: one converged limit and four methods over both ids."""
    from ssskit.scenes.generated import icosphere
    from ssskit.scenes.meshes import Mesh, write_mesh

    a = icosphere(2, 20.0, name="skinA")
    b = Mesh("skinB", a.vertices / np.float32(1000) + np.float32([0.045, 0, 0]), a.faces, a.normals)
    a = Mesh("skinA", a.vertices / np.float32(1000), a.faces, a.normals)
    path = write_mesh(tmp_path / "two.glb", [a, b])
    sc = study_gbuffer("front", width=48, height=24, spp=1, scene=str(path), material_map="skinB=marble")
    assert [m.name for m in sc.materials] == ["Skin1", "Marble"] and set(sc.params) == {1, 2}
    study = three_view_study(views=("front",), width=48, height=24, frames=2, reference_spp=64, repeats=1,
                             gbuffer_spp=1, scene=str(path), material_map="skinB=marble")
    assert study["material"] == ["Skin1", "Marble"]
    assert all(math.isfinite(r["psnr_gray"]) for r in study["rows"])
