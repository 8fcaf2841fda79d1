"""``ssskit figures region-attribution`` and the demo's use of it: the numbers are stored once and only
read by the report (which never computes them), with a table and a plot of every run."""

from ssskit import report
from ssskit.figures import FIGURES
from ssskit.figures import regions as fr
from ssskit.figures.stored import peek, stored
from ssskit.pipeline.attribution import ATTRIBUTION_REGIONS


def _pair(v, se):
    return {"value": [v] * 3, "se": [se] * 3}


def _fake_data():
    """The shape of attribution_data's result (two setups of one run), with made-up numbers."""
    cell = {"screen_space": [0.4] * 3, "exact_2d": [0.4] * 3, "path_traced": _pair(2.0, 0.05),
            "exact_over_reference": _pair(0.2, 0.005), "pass_over_reference": _pair(0.2, 0.005)}
    setups = [{"label": "as rendered", "regions": {"silhouette": cell}},
              {"label": "backed", "regions": {"silhouette": cell},
               "vs_first": {"silhouette": {"reference_ratio": _pair(0.8, 0.01), "gap_removed": _pair(0.25, 0.01)}}}]
    regions = {name: 0 for name in ATTRIBUTION_REGIONS} | {"silhouette": 100}
    return {"material": "Skin1", "spp": 64, "runs": [{"experiment": "transmission", "scene": "ear",
                                                      "regions": regions, "setups": setups}]}


def test_peek_reads_what_stored_wrote_and_computes_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    assert peek("figures", "x", {"a": 1}) is None
    assert stored("figures", "x", {"a": 1}, lambda: [1, 2]) == [1, 2]
    assert peek("figures", "x", {"a": 1}) == [1, 2] and peek("figures", "x", {"a": 2}) is None


def test_table_and_plot_of_the_runs(tmp_path):
    data = _fake_data()
    html = fr.attribution_table_html(data)
    assert html.count("<tr>") == 3  # the head and one row per setup
    assert "0.250 ± 0.010" not in html and "0.25 ± 0.01" in html  # shares with two digits
    assert "0.800 ± 0.010" in html and "2.000 ± 0.050" in html
    png = tmp_path / "a.png"
    fr.plot_attribution(data, png)
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert "region-attribution" in FIGURES.names()


def test_the_demo_shows_the_attribution_only_when_stored(tmp_path, monkeypatch):
    """Without stored numbers the report says how to make them (and computes nothing); with them it
    shows the table and writes the plot; the screen-space section's cache key follows that."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    (tmp_path / "out" / "figures").mkdir(parents=True)
    text = report._attribution_html(tmp_path / "out", 5000)
    assert "ssskit figures region-attribution --photons 5000" in text and "<table>" not in text
    assert report._SECTION_KEYS["screenspace"]({"photons": 5000}) == {"attribution": False}
    stored("figures", "region_attribution", fr._key("skin1", 5000, fr.ATTRIBUTION_SPP, 160, 120), _fake_data)
    assert fr.cached_attribution(photons=5000) is not None and fr.cached_attribution(photons=6000) is None
    text = report._attribution_html(tmp_path / "out", 5000)
    assert "<table>" in text and (tmp_path / "out" / "figures" / "region_attribution.png").is_file()
    assert report._SECTION_KEYS["screenspace"]({"photons": 5000}) == {"attribution": True}
