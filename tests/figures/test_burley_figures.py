"""Xie 2020 Fig. 6 (src/ssskit/figures/burley.py): the beam-light disk and the figure file."""

import numpy as np

from ssskit.figures import FIGURES
from ssskit.figures.burley import _params, beam_disk, fig6_xie_inverse


def test_beam_disk_is_a_1cm_disk():
    gb = beam_disk()
    px_per_mm = gb.camera.pixels_per_mm(gb.depth_mm[0, 0])[0]
    assert px_per_mm == 8.0
    area_mm2 = gb.diffuse[..., 0].sum() / px_per_mm**2
    assert abs(area_mm2 - np.pi * 10.0**2) < 0.01 * np.pi * 100  # 1 cm radius, to the pixel grid


def test_fig6_is_registered_and_written(tmp_path):
    from ssskit.profiles import profile_for_material

    assert FIGURES.get("xie-fig6") is fig6_xie_inverse
    burley = profile_for_material("skin1", "burley")
    assert _params(burley).d_mm == tuple(c.d for c in burley.channels)
    assert max(_params(profile_for_material("skin1", "dipole")).d_mm) > 1.0  # Xie's A = 0.9, dmfp 20 mm
    (path,) = fig6_xie_inverse(tmp_path, burley, spp=4)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_figures_run_their_pass_on_the_backend_asked_for(tmp_path, monkeypatch):
    """``ssskit figures --backend``: make_figures hands the backend to every figure that runs a pass."""
    import ssskit.screenspace as ss
    from ssskit.figures import make_figures, runs_a_pass
    from ssskit.profiles import profile_for_material

    assert runs_a_pass(fig6_xie_inverse) and not runs_a_pass(FIGURES.get("fig7"))
    real, asked = ss.burley_sss, []

    def spy(gb, params, settings=None, **kw):
        asked.append(kw["backend"])
        return real(gb, params, settings, **{**kw, "backend": "numba", "spp": 2})  # the figure, cheaply

    monkeypatch.setattr(ss, "burley_sss", spy)
    written = make_figures(["xie-fig6"], tmp_path, profile_for_material("skin1", "burley"), backend="numpy")
    assert asked == ["numpy", "numpy"] and written["xie-fig6"][0].is_file()


def test_burley_comparison_rows_and_figure(tmp_path, monkeypatch):
    """The demo's Burley comparison at a tiny size: more samples, closer to the converged reference."""
    from ssskit.figures.burley import burley_comparison

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    png, rows, refs = burley_comparison(tmp_path, scenes=["slab"], width=32, height=24, spp=1, spps=(4, 64),
                                        reference_spp=256)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    burley = [r for r in rows if r["method"].startswith("Burley")]
    assert [r["spp"] for r in burley] == [4, 64] and any(r["method"] == "separable burley_fit" for r in rows)
    assert burley[1]["rmse"] < burley[0]["rmse"] and burley[1]["psnr_gray"] > burley[0]["psnr_gray"]
    assert burley[1]["flip"] < burley[0]["flip"]
    # the reference's own error: measured with a second seed, far below a 4-spp frame's
    assert refs["slab"]["spp"] == 256 and 0 < refs["slab"]["ref_se"] < 0.2 * burley[0]["rmse"]
