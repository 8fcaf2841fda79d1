"""Xie 2020 Fig. 4, Figs. 10-11, 13 and Table 1 in kind (ssskit.figures.adaptive): registered, cached, and
the properties the paper's figures show, on small frames (not pixel values)."""

import numpy as np
import pytest

from ssskit.figures import FIGURES
from ssskit.figures import adaptive as fa


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


def test_registered():
    assert {"xie-fig4", "xie-fig10", "xie-fig11", "xie-fig13", "xie-table1"} <= set(FIGURES.names())


def test_results_are_cached_by_key():
    calls = []
    first = fa._cached("t", {"a": 1}, lambda: calls.append(1) or {"x": np.arange(3)})
    again = fa._cached("t", {"a": 1}, lambda: calls.append(1) or {"x": None})
    other = fa._cached("t", {"a": 2}, lambda: calls.append(1) or {"x": None})
    assert len(calls) == 2 and np.array_equal(again["x"], first["x"]) and other["x"] is None


def test_fig4_taa_lowers_the_standard_deviation_and_the_shadow_takes_more_samples():
    d = fa.fig4_data(frames=24, replicas=6)
    p1, p2 = d["series"]["P1 (shadow)"], d["series"]["P2 (lit)"]
    assert p1["sigma_g"][8:].mean() < 0.7 * p1["sigma_l"][8:].mean()  # the global TAA averages frames
    assert p2["sigma_g"][8:].mean() <= p2["sigma_l"][8:].mean()  # (P2 is often exact: rare samples reach the shadow)
    assert p1["sigma_l"][8:].mean() > p2["sigma_l"][8:].mean()
    assert d["spp"]["P1 (shadow)"] > 2 * d["spp"]["P2 (lit)"]
    assert d["spp"]["P2 (lit)"] < 16  # near b_min = 8


def test_grid_smaller_target_takes_more_samples_and_taa_helps(tmp_path):
    d = fa.grid_data("regular", frames=16, size=(64, 36))
    f = d["fixed64"]
    assert f["mean_spp"] == 64
    for k in fa.GRID_KAPPA:
        spp = [d["grid"][(s0, k)]["mean_spp"] for s0 in fa.GRID_SIGMA0_SQ]
        assert all(a >= b - 0.25 for a, b in zip(spp, spp[1:])), spp  # sigma0^2 up: fewer samples
        assert spp[0] > spp[-1] + 2
    for c in d["grid"].values():
        assert 8 <= c["mean_spp"] < 64
        assert c["psnr_taa"] > c["psnr"] + 1  # TAA accumulates frames
        assert c["psnr"] < f["psnr"]  # fewer samples than fixed 64: a noisier frame
    for e in d["equal_time"]:
        assert 1 <= e["fixed_spp"] <= 64 and e["fixed"]["mean_spp"] == e["fixed_spp"]
        assert e["images"]["counts"].shape == (36, 64)
    (png,) = fa.plot_grid(d, tmp_path / "grid.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_fixed_and_adaptive_sequences_agree_on_numba_and_gl():
    """The figures' loop gives the same frames through numba and gl, but for rare count flips."""
    from ssskit.backends import backend_status

    if not backend_status()["gl"]["available"]:
        pytest.skip("gl not available")
    gb = fa.shadow_plane(48, 27)
    params = fa.plane_params()
    from ssskit.pipeline.burley_frame import burley_exact
    from ssskit.screenspace.adaptive import AdaptiveSettings

    ref = burley_exact(gb, params)
    s = AdaptiveSettings(sigma0_sq=1e-3, kappa=0.6)
    a = fa.run_plane_frames(gb, params, ref, s, 6, backend="numba")
    b = fa.run_plane_frames(gb, params, ref, s, 6, backend="gl")
    np.testing.assert_allclose(a["mean_spp"], b["mean_spp"], atol=0.1)
    np.testing.assert_allclose(a["psnr_taa"], b["psnr_taa"], atol=0.3)


def test_demo_section_writes_its_figures_and_links_them(tmp_path, monkeypatch):
    """The report section (``(out, progress, ctx) -> html``) on small runs: every figure it links exists."""
    import re

    small = {"fig4_data": dict(frames=10, replicas=3, size=(48, 27)), "grid_data": dict(frames=6, size=(48, 27)),
             "phase_data": dict(frames=3, size=(48, 27))}
    for name, kw in small.items():
        original = getattr(fa, name)
        monkeypatch.setattr(fa, name, lambda *a, _f=original, _kw=kw, **k: _f(*a, **{**k, **_kw}))
    messages = []
    text = fa.demo_section(tmp_path, messages.append, {})
    assert "<h2 id=adaptive>" in text and "Table 1 in kind" in text and messages
    links = re.findall(r"src='figures/([^']+)'", text)
    assert len(links) == 7
    for name in links:
        assert (tmp_path / "figures" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
