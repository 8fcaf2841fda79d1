"""Xie 2020 Figs. 2 and 3 (the circle scenario): registered with ``ssskit figures`` and written as PNGs."""

import numpy as np

from ssskit.figures import FIGURES, make_figures
from ssskit.figures.adaptive import circle_runs


def test_registered_and_written(tmp_path):
    assert {"xie-fig2", "xie-fig3"} <= set(FIGURES.names())
    written = make_figures(["xie-fig2", "XIE_FIG3"], tmp_path / "figs", profile=None)
    paths = [p for ps in written.values() for p in ps]
    assert sorted(p.name for p in paths) == ["xie_fig2_circle_cold_start.png", "xie_fig3_circle_disocclusion.png"]
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 20_000


def test_runs_use_the_papers_setting():
    runs = circle_runs(disocclusion=True)
    assert [r.settings.kappa for r in runs] == [0.0, 1.0]
    for r in runs:
        s = r.settings
        assert (s.b_min, s.b_max, s.alpha, s.sigma0_sq) == (8, 64, 0.2, 0.08**2)
        assert r.n.shape == (150, 1) and r.disocclusion
        assert np.all((r.n >= 8) & (r.n <= 64))
