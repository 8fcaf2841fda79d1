"""MCML engine: published validation values, an independent adding-doubling solver, physical
properties, reproducibility across threads, caching, interruption and resume."""

import dataclasses
import math

import numpy as np
import pytest

from ssskit.errors import ProfileError
from ssskit.materials import MATERIALS, get_material
from ssskit.profiles.montecarlo import (
    MCConfig,
    MCLayer,
    SimulationInterrupted,
    config_for_material,
    simulate,
    supplement_grid,
)


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))


def within_3_se(value, se, ref, ref_err=0.0):
    return abs(value - ref) <= 3.0 * math.hypot(se, ref_err)


def test_van_de_hulst_slab(mc_backend):
    """mu_a = 10, mu_s = 90 cm^-1, g = 0.75, n = 1, d = 0.02 cm: Rd = 0.09739, Tt = 0.66096."""
    cfg = MCConfig((MCLayer(1.0, 9.0, 0.75, 1.0, 0.2),), dr_mm=0.01, nr=50, photons=400_000, seed=11)
    r = simulate(cfg, backend=mc_backend)
    assert within_3_se(r.total_rd, r.total_rd_se, 0.09739)
    assert within_3_se(r.tt, r.tt_se, 0.66096)
    # energy balance: what enters is reflected, transmitted or absorbed (roulette is unbiased)
    assert r.total_rd + r.tt + r.absorbed == pytest.approx(1.0 - r.rsp, abs=5 * r.total_rd_se)


def _chandrasekhar_h(albedo: float, n: int = 200):
    """H(mu) of isotropic scattering with single-scattering albedo ``albedo`` (Chandrasekhar, Radiative
    Transfer, 1950, Eq. V.33 in the form 1/H = sqrt(1 - a) + a/2 Int_0^1 mu' H(mu') / (mu + mu') dmu'),
    by fixed-point iteration on Gauss-Legendre nodes; returns (H as a function, nodes, weights)."""
    x, wt = np.polynomial.legendre.leggauss(n)
    mu, wt = (x + 1) / 2, wt / 2
    h = np.ones_like(mu)
    for _ in range(500):
        h = 1 / (np.sqrt(1 - albedo) + albedo / 2 * (wt * mu * h / (mu[:, None] + mu)).sum(1))

    def hf(m):
        return 1 / (np.sqrt(1 - albedo) + albedo / 2 * (wt * mu * h / (np.asarray(m, float)[..., None] + mu)).sum(-1))

    return hf


def test_semi_infinite_albedo_09_h_function(mc_backend):
    """n = 1, g = 0, albedo 0.9, semi-infinite: Rd = 0.414947 (exact, H-function), and the light per
    exit direction: for normal incidence the reflected intensity is (F a / 4) H(mu) H(1) / (mu + 1)
    (Chandrasekhar 1950, Eq. IV.70 with mu0 = 1), so the fraction leaving with mu in [mu1, mu2] is
    (a / 2) H(1) Int H(mu) mu / (mu + 1) dmu; each exit bin within 4 standard errors."""
    cfg = MCConfig((MCLayer(0.1, 0.9, 0.0, 1.0),), dr_mm=0.05, nr=100, photons=400_000, seed=12)
    r = simulate(cfg, backend=mc_backend)
    assert r.rsp == 0.0 and r.tt == 0.0
    assert within_3_se(r.total_rd, r.total_rd_se, 0.414947)
    assert r.exit_rd.sum() == pytest.approx(r.total_rd, rel=1e-12)
    hf = _chandrasekhar_h(0.9)
    from scipy.integrate import quad

    n = r.exit_rd.shape[0]
    edges = np.sqrt(np.arange(n + 1) / n)  # bins uniform in mu^2
    expected = np.array([0.45 * hf(1.0) * quad(lambda m: hf(m) * m / (m + 1), a, b)[0]
                         for a, b in zip(edges[:-1], edges[1:])])
    assert expected.sum() == pytest.approx(0.414947, rel=1e-5)
    assert np.all(np.abs(r.exit_rd - expected) <= 4 * r.exit_rd_se), (r.exit_rd - expected) / r.exit_rd_se
    # the exit is not Lambertian: near the normal the radiance is ~8% below a Lambertian one of the same total
    assert r.radiance_factor()[-1] == pytest.approx(n * expected[-1] / 0.414947, abs=4 * n * r.exit_rd_se[-1] / r.total_rd)


def test_oblique_incidence_h_function(mc_backend):
    """An oblique beam (60 degrees, n = 1, albedo 0.9, semi-infinite): Rd = 1 - H(mu0) sqrt(1 - a) with
    mu0 = 0.5 (Chandrasekhar 1950, conservation of the reflection function's flux), and the light per
    exit bin (a / 2) H(mu0) Int H(mu) mu / (mu + mu0) dmu (isotropic scattering: no azimuth
    dependence); and the specular part of a beam on n = 1.5 at 60 degrees is Fresnel's 0.0892."""
    cfg = MCConfig((MCLayer(0.1, 0.9, 0.0, 1.0),), dr_mm=0.05, nr=100, photons=200_000, seed=14, incidence_deg=60.0)
    r = simulate(cfg, backend=mc_backend)
    hf = _chandrasekhar_h(0.9)
    assert within_3_se(r.total_rd, r.total_rd_se, 1 - hf(0.5) * math.sqrt(0.1))
    from scipy.integrate import quad

    n = r.exit_rd.shape[0]
    edges = np.sqrt(np.arange(n + 1) / n)
    expected = np.array([0.45 * hf(0.5) * quad(lambda m: hf(m) * m / (m + 0.5), a, b)[0]
                         for a, b in zip(edges[:-1], edges[1:])])
    assert np.all(np.abs(r.exit_rd - expected) <= 4 * r.exit_rd_se), (r.exit_rd - expected) / r.exit_rd_se
    glass = MCConfig((MCLayer(0.1, 0.9, 0.0, 1.5),), dr_mm=0.05, nr=10, incidence_deg=60.0)
    ct = math.sqrt(1 - (math.sin(math.radians(60)) / 1.5) ** 2)
    rs = ((0.5 - 1.5 * ct) / (0.5 + 1.5 * ct)) ** 2
    rp = ((1.5 * 0.5 - ct) / (1.5 * 0.5 + ct)) ** 2
    assert glass.specular_reflectance() == pytest.approx((rs + rp) / 2) == pytest.approx(0.0892, abs=5e-4)
    assert glass.launch_direction() == pytest.approx((math.sin(math.radians(60)) / 1.5, ct))


def test_giovanelli_matched_index_1_5(mc_backend):
    """mu_a = 10, mu_s = 90 cm^-1, g = 0, n = 1.5, semi-infinite: Rd + Rsp = 0.2600."""
    cfg = MCConfig((MCLayer(1.0, 9.0, 0.0, 1.5),), dr_mm=0.01, nr=100, photons=400_000, seed=13)
    r = simulate(cfg, backend=mc_backend)
    assert r.rsp == pytest.approx(0.04)
    assert within_3_se(r.total_rd + r.rsp, r.total_rd_se, 0.2600, 0.00005)


@pytest.mark.slow
@pytest.mark.parametrize("name", MATERIALS.names())
def test_all_materials_against_adding_doubling(name, mc_backend):
    """Total Rd of 11 materials x RGB vs Prahl's adding-doubling (iadpython), within 3 SE.

    The adding-doubling value's own discretisation error is taken as the change from 16 to 32
    quadrature points and combined with the Monte Carlo standard error.
    """
    iad = pytest.importorskip("iadpython")
    m = MATERIALS.get(name)
    rsp = ((m.eta - 1) / (m.eta + 1)) ** 2
    for c in range(3):
        ref = [iad.Sample(a=m.albedo[c], b=1e4, g=0.0, n=m.eta, n_above=1.0, n_below=1.0, quad_pts=q).rt()[0] - rsp
               for q in (16, 32)]
        r = simulate(config_for_material(m, c, photons=100_000, seed=21, batch_size=2_500), backend=mc_backend)
        assert within_3_se(r.total_rd, r.total_rd_se, ref[1], abs(ref[1] - ref[0])), (c, r.total_rd, r.total_rd_se, ref)


def test_profile_properties_skin1(mc_backend):
    from ssskit.profiles.montecarlo import MonteCarloProfile

    m = get_material("skin1")
    r = simulate(config_for_material(m, "R", photons=100_000, seed=3), backend=mc_backend)
    prof = MonteCarloProfile(r)
    # the regular radial bins integrate to the total inside the grid; the overflow bin is no density
    assert r.rd.shape == r.r_mm.shape == (r.config.nr - 1,)
    assert np.sum(r.rd * 2 * np.pi * r.r_mm * r.config.dr_mm) == pytest.approx(r.total_rd_in_grid, rel=1e-12)
    assert r.total_rd_in_grid + r.overflow == pytest.approx(r.total_rd, rel=1e-12)
    assert prof.total_rd() == pytest.approx(r.total_rd_in_grid, rel=1e-12)
    assert prof.total_rd() + prof.overflow == pytest.approx(r.total_rd, rel=1e-12)
    assert prof.total_rd_with_overflow() == r.total_rd
    assert 0 <= prof.overflow < 1e-3 * r.total_rd  # skin red: little light beyond 32 mean free paths
    assert prof.eval(r.grid_mm + 0.5 * r.config.dr_mm) == 0.0
    assert np.all(r.rd >= 0) and np.all(r.rd_se >= 0)
    # decreasing where the bins are well resolved (first 4 mean free paths)
    k = int(4 * m.mfp_mm[0] / r.config.dr_mm)
    assert np.all(np.diff(r.rd[:k]) < 3 * (r.rd_se[:k - 1] + r.rd_se[1:k]))
    # 2D discretisation of the simulated profile conserves its energy in the square
    from scipy.integrate import quad

    n = 2 * (r.config.nr // 4) - 1
    cells = prof.discretize_2d(4 * r.config.dr_mm, n)
    half = n * 2 * r.config.dr_mm
    square = 8 * quad(lambda t: float(prof.energy_within(half / np.cos(t))), 0, np.pi / 4, limit=500)[0] / (2 * np.pi)
    assert cells.sum() == pytest.approx(square, rel=1e-6)
    assert cells.sum() <= prof.total_rd() * (1 + 1e-12)


def test_grid_fraction_extends_a_truncating_grid():
    """A nearly absorption-free medium sends ~3% of its light beyond 32 mean free paths; with
    grid_fraction=0.999 the grid is lengthened (same photons, same total) until it holds 99.9%."""
    from ssskit.materials import Material
    from ssskit.profiles.montecarlo import montecarlo_rgb, simulate_material

    m = Material("clear", (0.0005, 0.0005, 0.0005), (1.0, 1.0, 1.0), eta=1.3)
    short = simulate_material(m, "R", photons=20_000, batch_size=1_000)["R"]
    long = simulate_material(m, "R", photons=20_000, batch_size=1_000, grid_fraction=0.999)["R"]
    assert short.overflow > 1e-3 * short.total_rd
    assert long.overflow <= 1e-3 * long.total_rd and long.grid_mm > short.grid_mm
    assert long.total_rd == short.total_rd  # the same photons, tallied on a longer grid
    prof = montecarlo_rgb(m, photons=20_000, batch_size=1_000, grid_fraction=0.999).channels[0]
    assert prof.total_rd() == pytest.approx(long.total_rd_in_grid, rel=1e-12)
    with pytest.raises(ProfileError, match="grid fraction"):
        simulate_material(m, "R", photons=20_000, grid_fraction=1.0)


def test_supplement_grid_rules():
    m = get_material("skin1")
    dr, nr = supplement_grid(m)
    mfp = [1 / (a + s) for a, s in zip(m.sigma_a, m.sigma_s)]
    assert dr == pytest.approx(min(mfp) / 20)
    assert nr == math.ceil(32 * max(mfp) / dr)


def test_same_seed_bit_identical_for_any_thread_count():
    import numba

    cfg = config_for_material(get_material("ketchup"), 0, photons=40_000, seed=5, batch_size=1_000)
    one = simulate(cfg, threads=1, use_cache=False)
    many = simulate(cfg, threads=min(2, numba.config.NUMBA_NUM_THREADS), use_cache=False)
    assert np.array_equal(one.rd, many.rd) and one.total_rd == many.total_rd and one.absorbed == many.absorbed
    other = simulate(MCConfig(cfg.layers, cfg.dr_mm, cfg.nr, cfg.photons, seed=6, batch_size=1_000), use_cache=False)
    assert other.total_rd != one.total_rd


def _gl_or_skip():
    from ssskit.profiles.montecarlo import engine_gl

    ok, why = engine_gl.available()
    if not ok:
        pytest.skip(f"gl engine not available: {why}")
    return engine_gl


def test_gl_same_seed_same_tallies_for_any_dispatch(monkeypatch):
    """The GLSL engine's tallies are integers added by atomics and each photon draws from its own
    counter-based stream: the same seed gives bit-identical tallies on every run, for any number of
    invocations, steps per dispatch and batches per call; another seed gives others."""
    engine_gl = _gl_or_skip()
    cfg = config_for_material(get_material("ketchup"), 0, photons=12_000, seed=5, batch_size=1_000)
    a = simulate(cfg, backend="gl", use_cache=False)
    b = simulate(cfg, backend="gl", use_cache=False)
    assert np.array_equal(a.rd, b.rd) and a.total_rd == b.total_rd and a.absorbed == b.absorbed
    monkeypatch.setattr(engine_gl, "INVOCATIONS_CPU", 96)
    monkeypatch.setattr(engine_gl, "INVOCATIONS_GPU", 96)
    monkeypatch.setattr(engine_gl, "STEPS_CPU", 700)
    monkeypatch.setattr(engine_gl, "STEPS_GPU", 700)
    monkeypatch.setattr(engine_gl, "CHUNK_CPU", 5)
    monkeypatch.setattr(engine_gl, "CHUNK_GPU", 5)
    c = simulate(cfg, backend="gl", use_cache=False)
    assert np.array_equal(a.rd, c.rd) and np.array_equal(a.exit_rd, c.exit_rd) and a.total_rd == c.total_rd
    assert a.absorbed == c.absorbed and a.total_rd_se == c.total_rd_se
    other = simulate(dataclasses.replace(cfg, seed=6), backend="gl", use_cache=False)
    assert other.total_rd != a.total_rd
    # the two engines: independent streams, the same physics (energy balance within 5 SE)
    n = simulate(cfg, use_cache=False)
    assert abs(n.total_rd - a.total_rd) <= 4 * math.hypot(n.total_rd_se, a.total_rd_se)
    assert a.total_rd + a.tt + a.absorbed + a.rsp == pytest.approx(1.0, abs=5 * a.total_rd_se)


def test_gl_results_are_cached_apart(tmp_path):
    _gl_or_skip()
    cfg = config_for_material(get_material("skin1"), 0, photons=2_000, seed=2, batch_size=1_000)
    g = simulate(cfg, backend="gl")
    n = simulate(cfg)
    assert g.total_rd != n.total_rd  # not the gl result read back for numba, nor the reverse
    assert simulate(cfg, backend="gl").total_rd == g.total_rd and simulate(cfg).total_rd == n.total_rd
    with pytest.raises(ProfileError, match="the Monte Carlo backend must be one of numba, gl, got 'cuda'"):
        simulate(cfg, backend="cuda")


def _interrupt_on_call(monkeypatch, n):
    """Make the numba engine raise KeyboardInterrupt (as Ctrl-C) on its n-th call; returns a
    function that restores the engine."""
    from ssskit.profiles.montecarlo import engine_numba

    calls = {"n": 0}
    real = engine_numba.run_batches

    def flaky(*args):
        calls["n"] += 1
        if calls["n"] == n:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(engine_numba, "run_batches", flaky)
    return lambda: monkeypatch.setattr(engine_numba, "run_batches", real)


def _partial_files():
    from ssskit.cache import cache_dir

    return sorted(cache_dir("mcml").glob("*.partial.npz"))


def test_cache_and_resume_after_interrupt(monkeypatch):
    cfg = config_for_material(get_material("skin1"), 2, photons=20_000, seed=9, batch_size=1_000)
    reference = simulate(cfg, use_cache=False)
    restore = _interrupt_on_call(monkeypatch, 3)  # one thread: 2 batches per call, so 4 batches done
    with pytest.raises(SimulationInterrupted, match="interrupted after 4000 of 20000 photons.*resume=True.*restart=True") as exc:
        simulate(cfg, threads=1)
    # the command line's message names the command and its options, not the API's keywords
    assert "ssskit simulate" in exc.value.cli_message and "--resume" in exc.value.cli_message
    assert "=True" not in exc.value.cli_message
    restore()
    assert len(_partial_files()) == 1
    # the partial result is never dropped silently: running again without resume or restart is an error
    with pytest.raises(ProfileError, match=r"^a partial result of an interrupted run exists \(4000 of 20000 "
                       r"photons\); pass resume=True to continue it or restart=True to discard it") as exc:
        simulate(cfg, threads=1)
    assert exc.value.cli_message.endswith("run ssskit simulate with the same material, photons and seed and --resume "
                                          "to continue it, or --restart to discard it")
    with pytest.raises(ProfileError, match="resume and restart exclude each other"):
        simulate(cfg, resume=True, restart=True)
    with pytest.raises(ProfileError, match="^resume applies to use_cache True, not use_cache False$"):
        simulate(cfg, resume=True, use_cache=False)
    assert np.array_equal(simulate(cfg, use_cache=False).rd, reference.rd)  # no cache: the partial is untouched
    assert len(_partial_files()) == 1
    resumed = simulate(cfg, threads=1, resume=True)
    assert np.array_equal(resumed.rd, reference.rd) and resumed.total_rd == reference.total_rd
    assert _partial_files() == []
    cached = simulate(cfg)
    assert cached.extra.get("cached") and np.array_equal(cached.rd, reference.rd)


def test_restart_discards_partial_result(monkeypatch):
    from ssskit.profiles.montecarlo import simulate_material

    m = get_material("ketchup")
    run = dict(photons=8_000, seed=4, batch_size=1_000, threads=1)
    reference = simulate_material(m, "R", use_cache=False, **run)["R"]
    restore = _interrupt_on_call(monkeypatch, 2)
    with pytest.raises(SimulationInterrupted, match="^Ketchup R: simulation interrupted after 2000 of 8000"):
        simulate_material(m, "R", **run)
    restore()
    with pytest.raises(ProfileError, match=r"^Ketchup R: a partial result of an interrupted run exists \(2000 of"):
        simulate_material(m, "R", **run)
    with pytest.raises(ProfileError, match="resume and restart exclude each other"):
        simulate_material(m, "R", resume=True, restart=True, **run)
    fresh = simulate_material(m, "R", restart=True, **run)["R"]
    assert _partial_files() == [] and np.array_equal(fresh.rd, reference.rd)


def test_unreadable_partial_result_needs_restart():
    from ssskit.cache import cache_dir

    cfg = config_for_material(get_material("skin1"), 0, photons=3_000, seed=2, batch_size=1_000)
    path = cache_dir("mcml") / f"{cfg.key()}.partial.npz"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"not an npz file")
    with pytest.raises(ProfileError, match="unknown number of photons"):
        simulate(cfg)
    with pytest.raises(ProfileError, match="cannot be read; pass restart"):
        simulate(cfg, resume=True)
    assert simulate(cfg, restart=True).photons == 3_000 and not path.exists()


def test_numpy_implementation_agrees_statistically():
    """The numpy twin (PCG64 streams) and the numba engine estimate the same Rd, Tt, A and R(r);
    the twin also matches van de Hulst's slab (Rd = 0.09739, Tt = 0.66096) within 3 SE."""
    from ssskit.profiles.montecarlo import MCResult, simulate_numpy

    cfg = MCConfig((MCLayer(1.0, 9.0, 0.75, 1.0, 0.2),), dr_mm=0.01, nr=50, photons=200_000, seed=4)
    r = simulate(cfg, use_cache=False)
    t = simulate_numpy(cfg)
    assert isinstance(t, MCResult) and t.extra["engine"] == "numpy" and t.rd.shape == r.rd.shape
    assert within_3_se(t.total_rd, t.total_rd_se, 0.09739) and within_3_se(t.tt, t.tt_se, 0.66096)
    for name in ("total_rd", "tt", "absorbed"):
        diff = getattr(t, name) - getattr(r, name)
        assert abs(diff) < 4 * math.hypot(getattr(t, name + "_se"), getattr(r, name + "_se")), name
    se = np.hypot(t.rd_se, r.rd_se)
    assert np.all(se > 0)
    assert np.mean(np.abs(t.rd - r.rd) < 3 * se) > 0.95  # bin by bin, as two independent estimates should
    assert t.total_rd + t.tt + t.absorbed == pytest.approx(1.0 - t.rsp, abs=5 * t.total_rd_se)


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        (dict(photons=0), "photon count"),
        (dict(seed=-1), "seed"),
        (dict(dr_mm=0.0), "grid spacing"),
        (dict(nr=1), "radial bins"),
    ],
)
def test_config_validation(kwargs, fragment):
    base = dict(layers=(MCLayer(0.1, 1.0),), dr_mm=0.1, nr=10)
    base.update(kwargs)
    with pytest.raises(ProfileError, match=fragment):
        MCConfig(**base)
    with pytest.raises(ProfileError, match="semi-infinite"):
        MCConfig((MCLayer(0.1, 1.0), MCLayer(0.1, 1.0)), 0.1, 10)


def test_layered_file_split_slab_matches_single_slab(tmp_path, mc_backend):
    """Two index-matched identical layers of 0.1 mm transport light like one 0.2 mm layer (the
    van de Hulst slab, given in cm^-1 as MCML files are)."""
    f = tmp_path / "split.toml"
    layer = "[[layers]]\nsigma_a = 10\nsigma_s = 90\ng = 0.75\neta = 1.0\nthickness_mm = 0.01\n"
    f.write_text('name = "split"\nunit = "cm"\n' + layer + layer)
    m = get_material(str(f))
    assert len(m.layers) == 2 and m.layers[0].thickness_mm == pytest.approx(0.1)
    r = simulate(config_for_material(m, 0, photons=300_000, seed=31), backend=mc_backend)
    assert within_3_se(r.total_rd, r.total_rd_se, 0.09739)
    assert within_3_se(r.tt, r.tt_se, 0.66096)


def test_layered_material_errors(tmp_path):
    from ssskit.errors import MaterialError
    from ssskit.profiles import profile_for_material

    f = tmp_path / "bad.json"
    f.write_text('{"layers": [{"sigma_a": 1, "sigma_s": 1}, {"sigma_a": 1, "sigma_s": 1}]}')
    with pytest.raises(MaterialError, match="only the last layer may be semi-infinite"):
        get_material(str(f))
    f.write_text('{"layers": [{"sigma_a": 1, "sigma_s": -1}]}')
    with pytest.raises(MaterialError, match=r"layer 1: sigma_s must lie in \[0, inf\) mm\^-1, got"):
        get_material(str(f))
    f.write_text('{"layers": [{"sigma_a": 1, "sigma_s": 1}]}')
    with pytest.raises(ProfileError, match="only supported by the montecarlo model"):
        profile_for_material(str(f), "dipole")


def test_dask_cluster_sweep_matches_single_process(capsys):
    """A sweep on a dask.distributed cluster (a local one here) equals the single-process run, and says
    on stderr which materials are done."""
    distributed = pytest.importorskip("distributed")
    from ssskit.profiles.montecarlo import simulate_many, simulate_material

    mats = [get_material("ketchup"), get_material("skin1")]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        swept = simulate_many(mats, "G", photons=10_000, seed=3, batch_size=1_000, scheduler=cluster.scheduler_address,
                              progress=True)
    err = capsys.readouterr().err
    assert "sweep (dask at tcp://" in err and "2 of 2 materials" in err, err
    for m in mats:
        alone = simulate_material(m, "G", photons=10_000, seed=3, batch_size=1_000, use_cache=False)
        assert np.array_equal(swept[m.name]["G"].rd, alone["G"].rd)
        assert swept[m.name]["G"].total_rd == alone["G"].total_rd


def test_unreachable_scheduler_is_a_clear_error():
    pytest.importorskip("distributed")
    from ssskit.profiles.montecarlo import simulate_many

    # a refused connection: dask's rpc retries it until the connect timeout (sweep.check_scheduler), or says so
    with pytest.raises(ProfileError, match="cannot reach the dask scheduler|no dask scheduler answered at .* within 2 s"):
        simulate_many([get_material("ketchup"), get_material("skin1")], "G", photons=100,
                      scheduler="tcp://127.0.0.1:1", connect_timeout_s=2)


@pytest.fixture
def listening_socket():
    """start(reply) -> 'tcp://127.0.0.1:PORT' of a local TCP server that is no dask scheduler: it sends ``reply``
    to each connection (b"" says nothing) and keeps it open."""
    import socket
    import threading

    servers, held = [], []

    def start(reply: bytes) -> str:
        srv = socket.socket()
        srv.bind(("127.0.0.1", 0))
        srv.listen(8)
        servers.append(srv)

        def serve():
            while True:
                try:
                    conn, _ = srv.accept()
                except OSError:
                    return
                held.append(conn)
                if reply:
                    conn.sendall(reply)

        threading.Thread(target=serve, daemon=True).start()
        return f"tcp://127.0.0.1:{srv.getsockname()[1]}"

    yield start
    for s in servers + held:
        s.close()


def test_an_address_where_no_dask_scheduler_answers_is_one_clear_error(listening_socket):
    """An HTTP server's reply read as dask's frame lengths asked for 3.07 EiB (a MemoryError traceback); a server
    that says nothing hung the sweep for ever. Both are refused in one ProfileError, the silent one after the
    connect timeout."""
    pytest.importorskip("distributed")
    from ssskit.profiles.montecarlo import simulate_many

    mats = [get_material("ketchup"), get_material("skin1")]
    web = listening_socket(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
    with pytest.raises(ProfileError, match=f"what answers at '{web}' is not a dask scheduler"):
        simulate_many(mats, "G", photons=100, scheduler=web, connect_timeout_s=5)
    silent = listening_socket(b"")
    with pytest.raises(ProfileError, match=f"no dask scheduler answered at '{silent}' within 1 s"):
        simulate_many(mats, "G", photons=100, scheduler=silent, connect_timeout_s=1)
    with pytest.raises(ProfileError, match="the dask scheduler address 'nonsense' is not valid: missing port"):
        simulate_many(mats, "G", photons=100, scheduler="nonsense")


def test_a_scheduler_gone_after_it_answered_is_one_clear_error(monkeypatch):
    """A scheduler that answered dask's identity call and is gone before the sweep's client connects: the client's
    connection is refused under the same rule (a ProfileError, which API callers catch as SsskitError), never a raw
    OSError. Here the identity answer is dask's own words from a stand-in rpc; the client then really connects to a
    port where nothing listens."""
    distributed = pytest.importorskip("distributed")
    import distributed.core
    from ssskit.profiles.montecarlo import simulate_many

    class Answered:  # what distributed.core.rpc(address, timeout=...) gives a live scheduler: its identity
        def __init__(self, address, timeout):
            pass

        async def identity(self):
            return {"type": "Scheduler", "id": "gone-since"}

        async def close_rpc(self):
            pass

    monkeypatch.setattr(distributed.core, "rpc", Answered)
    with pytest.raises(ProfileError, match="cannot reach the dask scheduler at 'tcp://127.0.0.1:1'|"
                                           "no dask scheduler answered at 'tcp://127.0.0.1:1' within 2 s"):
        simulate_many([get_material("ketchup"), get_material("skin1")], "G", photons=100,
                      scheduler="tcp://127.0.0.1:1", connect_timeout_s=2)


def test_one_progress_bar_and_time_estimate_across_the_channels(capsys, tmp_path, monkeypatch):
    """``simulate`` estimated the time left of the running channel only ("about 10 s left" with 37 s to go): one bar
    now counts every channel's photons, and photons not simulated (a cached channel) leave its total."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("SSSKIT_PROGRESS", "lines")
    from ssskit.profiles.montecarlo import simulate_material

    mat = get_material("ketchup")
    simulate_material(mat, "all", photons=20_000, batch_size=1_000, progress=True)
    lines = [line for line in capsys.readouterr().err.splitlines() if "photons" in line]
    assert lines and all("Ketchup R/G/B: " in line and "/60,000 photons" in line for line in lines), lines
    assert "60,000/60,000 photons" in lines[-1]
    assert any("channel R" in line for line in lines) and any("channel B" in line for line in lines)
    simulate_material(mat, "G", photons=30_000, batch_size=1_000, progress=True)  # G cached at 30,000
    capsys.readouterr()
    simulate_material(mat, "all", photons=30_000, batch_size=1_000, progress=True)
    lines = [line for line in capsys.readouterr().err.splitlines() if "photons" in line]
    assert "60,000/60,000 photons" in lines[-1], lines  # R and B simulated, G taken from the cache
