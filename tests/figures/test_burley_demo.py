"""The demo's Burley section (issue 13 item 7): :func:`ssskit.figures.burley.burley_comparison` on a small
scene, and its place in the report (``report.SECTIONS``, the backend from ``ctx``)."""

import numpy as np
import pytest


def test_burley_comparison_converges_and_states_the_reference_error(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    from ssskit.figures.burley import burley_comparison

    png, rows, refs = burley_comparison(tmp_path, scenes=["slab"], width=48, height=36, spp=2, spps=(4, 64),
                                        reference_spp=512, backend="numba")
    assert png.is_file() and png.stat().st_size > 10_000
    burley = {r["spp"]: r for r in rows if r["spp"]}
    sep = [r for r in rows if r["method"] == "separable burley_fit"]
    assert set(burley) == {4, 64} and len(sep) == 1
    # more samples: closer to the converged pass, by every measure
    assert burley[64]["rmse"] < 0.5 * burley[4]["rmse"]
    assert burley[64]["psnr_gray"] > burley[4]["psnr_gray"] + 3
    assert burley[64]["flip"] < burley[4]["flip"]
    # the reference's own error is measured (two seeds) and far below a 4-spp frame's
    se = refs["slab"]["ref_se"]
    assert 0 < se < 0.2 * burley[4]["rmse"] and refs["slab"]["spp"] == 512


def test_the_report_has_the_burley_section_on_the_ctx_backend(monkeypatch, tmp_path):
    import ssskit.figures.burley as fb
    from ssskit import report

    assert "burley" in dict(report.SECTIONS)
    seen = {}

    def fake(out, progress=None, backend=None, reference_spp=None, **kw):
        seen.update(backend=backend, reference_spp=reference_spp)
        return tmp_path / "burley.png", [{"scene": "s", "method": "m", "spp": 8, "psnr_gray": 30.0, "rmse": 0.01,
                                          "flip": 0.1}], {"s": {"spp": 2048, "ref_se": 1e-5, "peak": 1.0}}

    monkeypatch.setattr(fb, "burley_comparison", fake)
    html = dict(report.SECTIONS)["burley"](tmp_path, lambda m: None, {"backend": "numpy"})
    assert seen == {"backend": "numpy", "reference_spp": fb.DEMO_REFERENCE_SPP}
    assert "numpy backend" in html and "s 1.0e-05" in html and "<td>30.0</td>" in html
    dict(report.SECTIONS)["burley"](tmp_path, lambda m: None, {})
    assert seen["backend"] == "numba"  # the default when the demo names no backend


@pytest.mark.parametrize("name", ["xie-fig5"])
def test_xie_fig5_is_a_registered_figure(name, tmp_path):
    from ssskit.figures import FIGURES, make_figures

    assert name in FIGURES.names()
    paths = make_figures([name], tmp_path, None)[name]
    assert len(paths) == 1 and paths[0].is_file() and paths[0].stat().st_size > 5_000
