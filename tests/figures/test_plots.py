"""The profile plots: every label inside its panel, so the saved figure has no blank band."""
import pytest

from ssskit.figures import plots
from ssskit.materials import MATERIALS
from ssskit.profiles import profile_for_material


@pytest.mark.parametrize("name", sorted(n for n, _ in MATERIALS.items()))
def test_profile_plot_labels_inside_their_panels(name, monkeypatch, tmp_path):
    m = MATERIALS.get(name)
    profs = [profile_for_material(m, model) for model in ("dipole", "burley", "gaussians", "montecarlo")]
    figs = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: figs.append(fig))
    plots.plot_profiles(profs, name, tmp_path / "p.png")
    (fig,) = figs
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    labels = [t for ax in fig.axes for t in ax.texts]
    assert any("grid ends" in t.get_text() for t in labels), "the Monte Carlo grid's end is marked"
    for ax in fig.axes:
        box = ax.get_window_extent(renderer)
        for t in ax.texts:
            ext = t.get_window_extent(renderer)
            assert box.y0 - 1 <= ext.y0 and ext.y1 <= box.y1 + 1, (t.get_text(), ext, box)
    plots.pyplot().close(fig)
