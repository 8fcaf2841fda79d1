"""The attribution's stored numbers (lab.figure): stored once and read without computing anything, with
a table and a plot of every run; the product no longer registers the figure."""

from lab import figure as fr
from lab.attribution import ATTRIBUTION_REGIONS
from ssskit.figures import FIGURES
from ssskit.figures.stored import peek, stored


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
    assert "region-attribution" not in FIGURES.names()  # a lab figure: experiments/region_attribution.py --plot


def test_stored_numbers_are_read_without_computing(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    assert fr.cached_attribution(photons=5000) is None
    stored("figures", "region_attribution", fr._key("skin1", 5000, fr.ATTRIBUTION_SPP, 160, 120), _fake_data)
    assert fr.cached_attribution(photons=5000) is not None and fr.cached_attribution(photons=6000) is None
