"""The demo's Burley section (issue 13 item 7) in the report (``report.SECTIONS``, the backend from
``ctx``; the comparison itself: tests/figures/test_burley_figures.py), and Xie's Fig. 5 as a figure."""

import pytest


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
