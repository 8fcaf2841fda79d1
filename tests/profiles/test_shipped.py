"""The Monte Carlo profiles the package ships (ssskit.profiles.montecarlo.shipped): present, covering the
simulations the demo and the defaults use, small, read back as the result of their configuration, and
in agreement with a fresh, independent simulation within the standard errors."""

import numpy as np
import pytest

from ssskit.profiles.montecarlo import config_for_material, simulate
from ssskit.profiles.montecarlo import shipped as sh

#: re-simulated here with fewer photons and another seed (independent photons): (label, channel)
SUBSET = [("Skin1", "R"), ("Skin1", "B"), ("Ketchup", "G"), ("Skin1 (eta = 1)", "G")]
FRESH_PHOTONS = 1_000_000


def test_the_shipped_file_covers_every_shipped_simulation_and_is_small():
    assert sh.SHIPPED_FILE.is_file(), "the package data is missing: python docs/supplement_profiles.py writes it"
    info = sh.manifest()
    expected = [(label, ch, sh.config_id(cfg)) for label, ch, cfg in sh.shipped_configs()]
    assert [(d["label"], d["channel"], d["id"]) for d in info] == expected, \
        "the shipped configurations changed: regenerate with python docs/supplement_profiles.py"
    assert all(d["photons"] == 10_000_000 for d in info)  # supplement F
    assert sh.SHIPPED_FILE.stat().st_size < 600 * 1024


def _fresh(label: str, ch: str):
    cfg = next(c for lab, chan, c in sh.shipped_configs() if (lab, chan) == (label, ch))
    stored = sh.shipped_result(cfg)
    assert stored is not None and stored.extra == {"shipped": True}
    mat = dict(sh.shipped_materials())[label]
    # 200 batches of 5,000: the batch method's standard error is then estimated well enough that the reduced
    # chi-square of two independent runs is ~1 (with 20 batches of 10,000, rare long paths in one batch give
    # it heavy tails: 1.1-2.8 over seeds; with 200: 0.90-1.40 over seeds 1000, 2000, 3000 on this subset)
    fresh_cfg = config_for_material(mat, "RGB".index(ch), FRESH_PHOTONS, seed=1000 + "RGB".index(ch),
                                    batch_size=FRESH_PHOTONS // 200)
    return stored, simulate(fresh_cfg, use_cache=False)


@pytest.mark.parametrize("label, ch", SUBSET, ids=[f"{a} {b}" for a, b in SUBSET])
def test_shipped_profiles_agree_with_a_fresh_simulation(label, ch):
    """Totals within 4 combined standard errors; R(r), over the bins the fresh run resolves (relative
    SE < 20%), a reduced chi-square in [0.6, 1.5] and no bias: the mean of the n normalised differences
    within 4/sqrt(n) of 0 (the two runs are independent: other seeds; a photon leaves through one bin, so
    the bins are independent too)."""
    stored, fresh = _fresh(label, ch)
    for a, b, sa, sb in ((stored.total_rd, fresh.total_rd, stored.total_rd_se, fresh.total_rd_se),
                         (stored.overflow, fresh.overflow, stored.overflow_se, fresh.overflow_se)):
        assert abs(a - b) <= 4 * np.hypot(sa, sb) + 1e-12, (a, b, sa, sb)
    ok = (fresh.rd > 0) & (fresh.rd_se < 0.2 * fresh.rd)
    z = (stored.rd[ok] - fresh.rd[ok]) / np.hypot(stored.rd_se[ok], fresh.rd_se[ok])
    assert ok.sum() >= 30 and 0.6 <= float(np.mean(z**2)) <= 1.5, (int(ok.sum()), float(np.mean(z**2)))
    assert abs(float(np.mean(z))) <= 4 / np.sqrt(ok.sum()), (int(ok.sum()), float(np.mean(z)))


def test_simulate_reads_a_shipped_result_and_recompute_ignores_it(tmp_path, monkeypatch):
    """A configuration in the file is answered from it (exactly what was written, float32 R(r)); inside
    shipped.recompute() (ssskit demo --full) and with use_cache=False it is simulated."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    mat = dict(sh.shipped_materials())["Ketchup"]
    cfg = config_for_material(mat, 1, 2_000, seed=4, batch_size=500)
    res = simulate(cfg, use_cache=False)
    monkeypatch.setattr(sh, "SHIPPED_FILE", tmp_path / "p.npz")
    sh._index.cache_clear()
    try:
        sh.write_shipped([("Ketchup", "G", res)], tmp_path / "p.npz")
        back = simulate(cfg)
        assert back.extra == {"shipped": True} and back.total_rd == res.total_rd
        np.testing.assert_array_equal(back.rd, res.rd.astype(np.float32).astype(float))
        with sh.recompute():
            again = simulate(cfg)
        assert "shipped" not in again.extra and np.array_equal(again.rd, res.rd)
        assert "shipped" not in simulate(cfg, use_cache=False).extra
    finally:
        sh._index.cache_clear()
