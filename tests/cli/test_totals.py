"""``ssskit simulate`` and ``ssskit profile --model montecarlo`` report the same named totals: ``total_Rd`` with
the overflow (MCML's Rd, incl. the light escaping beyond the grid: one meaning in every JSON) and
``total_Rd_in_grid`` (what R(r) integrates to), for the same run."""

import json
import math

import pytest

from ssskit.cli import main


def test_simulate_and_profile_report_the_same_totals(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    assert main(["simulate", "--material", "marble", "--photons", "20000", "--json"]) == 0
    sim = json.loads(capsys.readouterr().out)
    assert main(["profile", "--material", "marble", "--model", "montecarlo", "--photons", "20000", "--json"]) == 0
    prof = json.loads(capsys.readouterr().out)
    for ch in "RGB":
        s, p = sim["channels"][ch], prof["channels"][ch]
        # one key, one meaning: total_Rd held the light in the grid in profile's JSON (0.7873 for Marble R) and
        # the light with the overflow in simulate's (0.8046)
        assert p["total_Rd"] == pytest.approx(s["total_Rd"], rel=1e-12)
        assert p["total_Rd_in_grid"] == pytest.approx(s["total_Rd_in_grid"], rel=1e-12)
        assert p["overflow"] == pytest.approx(s["overflow"], rel=1e-12)
        assert not {"total_Rd", "total_Rd_in_grid", "total_Rd_with_overflow"} & set(p["params"])
        assert s["total_Rd_in_grid"] + s["overflow"] == pytest.approx(s["total_Rd"], rel=1e-12)
        # the grid's total is what the profile's R(r) integrates to: 2 pi sum R(r_i) r_i dr
        dr = sim["r_mm"][1] - sim["r_mm"][0]
        assert 2 * math.pi * sum(r * v for r, v in zip(sim["r_mm"], s["Rd"])) * dr == pytest.approx(
            s["total_Rd_in_grid"], rel=1e-9)
        assert len(s["Rd"]) == len(sim["r_mm"])
        # the overflow bin is not in the density: the last annulus holds a few photons, not the overflow
        # (0.2-2% of the light here; each photon of 20000 is < 5e-5)
        r_mm = sim["r_mm"]
        assert 2 * math.pi * r_mm[-1] * (r_mm[1] - r_mm[0]) * s["Rd"][-1] < 0.25 * s["overflow"]
    # Marble's 32-MFP grid truncates: light escapes beyond it
    assert sim["channels"]["R"]["overflow"] > 1e-3 * sim["channels"]["R"]["total_Rd"]
    assert main(["profile", "--material", "marble", "--model", "montecarlo", "--photons", "20000"]) == 0
    text = capsys.readouterr().out
    assert "# total Rd in grid (R, G, B)" in text and "with overflow" in text
    assert main(["simulate", "--material", "marble", "--photons", "20000"]) == 0
    assert "total Rd with overflow" in capsys.readouterr().out


def test_rough_surface_through_simulate_and_profile(capsys, tmp_path, monkeypatch):
    """--roughness reaches the engine on both commands: the same run (same totals), the entry's
    Rsp estimated for the rough surface (within its Monte Carlo error of the smooth Fresnel value at
    normal incidence)."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    args = ["--material", "skin1", "--photons", "100000"]
    assert main(["simulate", *args, "--roughness", "0.15", "--json"]) == 0
    rough = json.loads(capsys.readouterr().out)
    assert main(["simulate", *args, "--json"]) == 0
    smooth = json.loads(capsys.readouterr().out)
    assert main(["profile", *args, "--model", "montecarlo", "--roughness", "0.15", "--json"]) == 0
    prof = json.loads(capsys.readouterr().out)
    assert rough["roughness"] == 0.15 and smooth["roughness"] == 0.0
    for ch in "RGB":
        r, s = rough["channels"][ch], smooth["channels"][ch]
        assert prof["channels"][ch]["total_Rd"] == pytest.approx(r["total_Rd"], rel=1e-12)
        assert r["Rsp"] == pytest.approx(s["Rsp"], abs=6e-4)
        assert r["Rsp"] != s["Rsp"]
    assert main(["simulate", *args, "--roughness", "0.15"]) == 0
    assert "rough surface (Beckmann alpha 0.15)" in capsys.readouterr().out
