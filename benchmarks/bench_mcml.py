"""Benchmark: ssskit's numba MCML engine against the original C MCML 1.2.2 (Wang, Jacques, Zheng 1995)
and a plain vectorised-numpy implementation of the same algorithm, all measured in the same run;
prints one JSON object.

    python benchmarks/bench_mcml.py [--photons N] [--marble-photons N] [--repeats 5] [--numpy-photons N]
                                    [--mcml-src DIR] [--fetch] [--full]

NUMBA_THREADING_LAYER is set to 'workqueue' (always available) unless given.

Cases: the red channel of Skin1 and of Marble (``ssskit.materials``), semi-infinite (ssskit: an
infinite layer; MCML: one layer 10^7 cm thick, as the supplement's section F), g = 0, refractive
index 1.3 (Skin1) / 1.5 (Marble) under an ambient of 1.0, on the supplement's radial grid
(``supplement_grid``: dr = min MFP / 20, nr = ceil(32 max MFP / dr)). Both engines trace the same
number of photons. MCML's input is written in cm and cm^-1 (ssskit works in mm and mm^-1).

Whole processes, start-up counted: per case and round, in turn, the C program on its .mci file, then
``ssskit simulate --channel R --threads 1 --no-cache --json`` (one core, like C MCML), then the same
with every core, each a fresh process (Python, imports, numba's on-disk cache of the compiled engine,
the simulation, the JSON output). Wall seconds by a monotonic clock around the child, CPU seconds from
the operating system's accounting of the finished child (getrusage); min, median and max over
``--repeats`` rounds, and the per-core ratio (ssskit photons per second on one thread / C's) taken round
by round. One untimed ssskit process first fills numba's cache, so the rounds measure a warm start (the
first run after installation compiles the engine once, about 10-20 s). Also, inside this process: the
engine's own rate (``simulate(threads=1)``, no start-up) and the numpy twin's.

C MCML. Its source is not part of this repository. ``--fetch`` clones the public repository
lhvwang/MCML (git, https://github.com/lhvwang/MCML) into a temporary folder and copies its folder
``V1/mcR5unix/mcmlcode`` (mcml.h, mcmlmain.c, mcmlgo.c, mcmlio.c, mcmlnr.c) into
``benchmarks/.mcml-src/`` (git-ignored); or put those files there yourself, e.g. from a bare mirror of
that repository,

    git --git-dir=<mirror> archive HEAD V1/mcR5unix/mcmlcode | tar -x --strip-components=3 -C benchmarks/.mcml-src

or point ``--mcml-src`` at any folder holding them. Also, where an OpenGL 4.3 context exists, the GLSL
engine (``simulate(backend="gl")``, llvmpipe on a machine without a GPU) in this process. The script then compiles them once with
``gcc -O2`` into ``benchmarks/.mcml-build/`` (git-ignored; rebuilt only when a source is newer),
writes an MCML input file (.mci) per case there and runs the program. Its total diffuse reflectance
(RAT section of the .mco output) and Rd(r) are compared with ssskit's. Without the source the JSON
says so (``"c_mcml": "not run: source not found in <dir>"``) and no C figure is given.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numba  # noqa: E402
import numpy as np  # noqa: E402

from ssskit.materials import get_material  # noqa: E402
from ssskit.profiles.montecarlo import MCConfig, config_for_material, simulate, simulate_numpy  # noqa: E402

HERE = Path(__file__).resolve().parent
DEFAULT_SRC = HERE / ".mcml-src"
BUILD_DIR = HERE / ".mcml-build"
MCML_SOURCES = ("mcmlmain.c", "mcmlgo.c", "mcmlio.c", "mcmlnr.c")
CFLAGS = ["-O2"]
SEMI_INFINITE_CM = 1.0e7  # supplement F: semi-infinite medium = 10^7 cm


# ---- C MCML ---------------------------------------------------------------------------------


def find_sources(src: Path) -> Path | None:
    """The folder under ``src`` holding MCML's C files (``src`` itself, or a nested mcmlcode folder)."""
    if all((src / f).is_file() for f in MCML_SOURCES + ("mcml.h",)):
        return src
    if src.is_dir():
        for main in sorted(src.rglob("mcmlmain.c")):
            if all((main.parent / f).is_file() for f in MCML_SOURCES + ("mcml.h",)):
                return main.parent
    return None


def build_mcml(code: Path) -> tuple[Path, dict]:
    """Compile MCML with gcc -O2 into BUILD_DIR unless an up-to-date binary is there."""
    BUILD_DIR.mkdir(parents=True, exist_ok=True)
    exe = BUILD_DIR / "mcml"
    cc = shutil.which("gcc")
    if cc is None:
        raise RuntimeError("gcc not found")
    srcs = [code / f for f in MCML_SOURCES + ("mcml.h",)]
    newest = max(p.stat().st_mtime for p in srcs)
    built = False
    if not exe.exists() or exe.stat().st_mtime < newest:
        cmd = [cc, *CFLAGS, "-o", str(exe), *(str(code / f) for f in MCML_SOURCES), "-lm"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0:
            raise RuntimeError(f"gcc failed: {p.stderr.strip()[-500:]}")
        built = True
    version = re.search(r'ShowVersion\("([^"]*)"\)', (code / "mcmlmain.c").read_text(errors="replace"))
    gcc_version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    return exe, {"source": str(code), "version": version.group(1) if version else "unknown",
                 "compiler": gcc_version, "flags": " ".join(CFLAGS), "built_now": built}


def write_mci(cfg: MCConfig, name: str) -> Path:
    """An MCML input file for ``cfg`` (one semi-infinite layer; mm -> cm, mm^-1 -> cm^-1)."""
    (layer,) = cfg.layers
    thickness_cm = SEMI_INFINITE_CM if layer.thickness_mm == float("inf") else layer.thickness_mm / 10.0
    dr_cm = cfg.dr_mm / 10.0
    text = "\n".join([
        "1.0\t# file version",
        "1\t# number of runs",
        f"{name}.mco\tA\t# output filename, ASCII",
        f"{cfg.photons}\t# No. of photons",
        # one depth bin (absorption is not compared); the radial grid is the supplement's
        f"1.0\t{dr_cm!r}\t# dz, dr [cm]",
        f"1\t{cfg.nr}\t1\t# No. of dz, dr, da",
        "1\t# No. of layers",
        f"{cfg.eta_above!r}\t# n above",
        f"{layer.eta!r}\t{layer.sigma_a * 10.0!r}\t{layer.sigma_s * 10.0!r}\t{layer.g!r}\t{thickness_cm!r}"
        "\t# n mua mus g d [cm^-1, cm]",
        f"{cfg.eta_below!r}\t# n below",
        "",
    ])
    path = BUILD_DIR / f"{name}.mci"
    path.write_text(text)
    return path


def run_mcml(exe: Path, mci: Path) -> tuple[float, dict, np.ndarray]:
    """Run MCML on ``mci``; (wall seconds, its RAT values, its Rd(r) in cm^-2)."""
    out = mci.with_suffix(".mco")
    if out.exists():
        out.unlink()
    t0 = time.perf_counter()
    p = subprocess.run([str(exe), mci.name], cwd=mci.parent, stdin=subprocess.DEVNULL,
                       capture_output=True, text=True, timeout=3600)
    seconds = time.perf_counter() - t0
    if p.returncode != 0 or not out.exists():
        raise RuntimeError(f"mcml failed (rc {p.returncode}): {(p.stdout + p.stderr).strip()[-300:]}")
    text = out.read_text()
    rat = {}
    for key, label in (("Rsp", "Specular reflectance"), ("Rd", "Diffuse reflectance"),
                       ("A", "Absorbed fraction"), ("Tt", "Transmittance")):
        m = re.search(r"^\s*(\S+)\s+#" + label, text, re.MULTILINE)
        rat[key] = float(m.group(1)) if m else None
    m = re.search(r"^Rd_r #.*\n((?:\s*\S+\n)+)", text, re.MULTILINE)
    rd_r = np.array([float(v) for v in m.group(1).split()]) if m else np.zeros(0)
    return seconds, rat, rd_r


def profile_agreement(rd_r_cm2: np.ndarray, res) -> dict:
    """C MCML's Rd(r) against ssskit's, bin by bin, over the well-sampled bins (ssskit's relative
    standard error < 10%; the sparse tail, where one photon makes a bin, and the last bin, MCML's
    overflow, are left out): each difference in units of sqrt(2) x ssskit's standard error (C
    MCML's error is about the same); reduced chi2 near 1 means agreement."""
    n = res.rd.shape[0]  # ssskit's nr - 1 regular annuli; MCML's last bin also collects every radius beyond
    if rd_r_cm2.shape[0] != n + 1:
        return {"error": f"MCML wrote {rd_r_cm2.shape[0]} radial bins, ssskit has {n} annuli + the overflow"}
    c = rd_r_cm2[:n] / 100.0  # cm^-2 -> mm^-2
    s, se = res.rd[:n], res.rd_se[:n]
    ok = (s > 0) & (se < 0.1 * s)
    z = (c[ok] - s[ok]) / (np.sqrt(2.0) * se[ok])
    return {"bins_compared": int(ok.sum()), "r_max_mm": round(float(res.r_mm[np.flatnonzero(ok).max()]), 3)
            if ok.any() else None, "reduced_chi2": round(float(np.mean(z**2)), 3),
            "bins_beyond_3_sigma": int(np.sum(np.abs(z) > 3)),
            "rd_first_bin_mm2": {"c_mcml": round(float(c[0]), 4), "ssskit": round(float(s[0]), 4),
                                 "ssskit_se": round(float(se[0]), 4)}}


# ---- ssskit ---------------------------------------------------------------------------------


MCML_REPO = "https://github.com/lhvwang/MCML"


def fetch_sources(dest: Path) -> str:
    """Clone lhvwang/MCML (git) into a temporary folder and copy V1/mcR5unix/mcmlcode's files into ``dest``."""
    import tempfile

    git = shutil.which("git")
    if git is None:
        raise RuntimeError("git not found")
    with tempfile.TemporaryDirectory() as tmp:
        p = subprocess.run([git, "clone", "--depth", "1", MCML_REPO, tmp], capture_output=True, text=True, timeout=600)
        if p.returncode != 0:
            raise RuntimeError(f"git clone {MCML_REPO} failed: {p.stderr.strip()[-300:]}")
        code = Path(tmp) / "V1" / "mcR5unix" / "mcmlcode"
        dest.mkdir(parents=True, exist_ok=True)
        for f in MCML_SOURCES + ("mcml.h",):
            shutil.copy2(code / f, dest / f)
    return MCML_REPO


def timed_process(cmd: list[str], cwd: Path | None = None) -> tuple[float, float, str]:
    """(wall seconds, CPU seconds of the finished child, its stdout); raises RuntimeError if it fails."""
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=3600)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(f"{cmd[0]} failed (rc {p.returncode}): {(p.stdout + p.stderr).strip()[-300:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, p.stdout


def spread(values: list[float], digits: int = 3) -> dict:
    return {"min": round(min(values), digits), "median": round(statistics.median(values), digits),
            "max": round(max(values), digits)}


def ssskit_cmd(material: str, photons: int, threads: int | None) -> list[str]:
    """``ssskit simulate`` for the red channel, as a fresh Python process (the console script's entry point)."""
    cmd = [sys.executable, "-c", "import sys; from ssskit.cli import main; sys.exit(main())", "simulate",
           "--material", material, "--channel", "R", "--photons", str(photons), "--no-cache", "--json"]
    return cmd + (["--threads", str(threads)] if threads else [])


def json_agreement(rd_r_cm2: np.ndarray, sim: dict):
    """:func:`profile_agreement` on the JSON of ``ssskit simulate`` (channel R)."""
    from types import SimpleNamespace

    ch = sim["channels"]["R"]
    res = SimpleNamespace(rd=np.asarray(ch["Rd"]), rd_se=np.asarray(ch["Rd_se"]), r_mm=np.asarray(sim["r_mm"]))
    return profile_agreement(rd_r_cm2, res)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--photons", type=int, default=1_000_000, help="photons of the Skin1 case (both engines)")
    ap.add_argument("--marble-photons", type=int, default=200_000, help="photons of the Marble case (both engines)")
    ap.add_argument("--repeats", type=int, default=5, help="rounds of whole-process runs per case")
    ap.add_argument("--numpy-photons", type=int, default=20_000, help="photons of the numpy twin, per case")
    ap.add_argument("--mcml-src", type=Path, default=DEFAULT_SRC, help="folder holding MCML 1.2.2's C files")
    ap.add_argument("--fetch", action="store_true", help=f"clone {MCML_REPO} into --mcml-src if the files are absent")
    ap.add_argument("--full", action="store_true", help="also time the supplement's full Skin1 RGB simulation")
    ap.add_argument("--gl-photons", type=int, default=200_000,
                    help="photons of the GLSL engine's Skin1 case (Marble: a tenth), in this process")
    ap.add_argument("--no-gl", action="store_true", help="leave the GLSL engine out")
    args = ap.parse_args()
    gl_ok, gl_why = False, "left out (--no-gl)"
    if not args.no_gl:
        from ssskit.profiles.montecarlo import engine_gl

        gl_ok, gl_why = engine_gl.available()
    cores = numba.config.NUMBA_NUM_THREADS
    out: dict = {"machine": {"cpu_count": os.cpu_count(), "numba_threads": cores, "python": platform.python_version(),
                             "numba": numba.__version__, "threading_layer": os.environ["NUMBA_THREADING_LAYER"],
                             "cpu": _cpu_name()},
                 "date": time.strftime("%Y-%m-%d"), "load_average_before": os.getloadavg(), "repeats": args.repeats,
                 "c_mcml": None, "cases": {}}
    code = find_sources(args.mcml_src)
    if code is None and args.fetch:
        try:
            out["c_mcml_fetched_from"] = fetch_sources(args.mcml_src)
            code = find_sources(args.mcml_src)
        except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
            out["c_mcml_fetch"] = f"failed: {exc}"
    exe = None
    if code is None:
        c_status = f"not run: source not found in {args.mcml_src}"
        out["c_mcml"] = c_status
    else:
        try:
            exe, out["c_mcml"] = build_mcml(code)
        except (RuntimeError, OSError) as exc:
            c_status = f"not run: build failed: {exc}"
            out["c_mcml"] = c_status

    # compile once (and fill numba's on-disk cache for the processes below), outside the timings
    simulate(config_for_material(get_material("skin1"), 0, photons=1_000), use_cache=False)
    simulate_numpy(config_for_material(get_material("skin1"), 0, photons=100))
    timed_process(ssskit_cmd("skin1", 1_000, 1))

    for name, photons in (("Skin1", args.photons), ("Marble", args.marble_photons)):
        m = get_material(name)
        cfg = config_for_material(m, 0, photons=photons)
        case: dict = {"photons": photons, "grid": {"dr_mm": cfg.dr_mm, "nr": cfg.nr}}
        mci = write_mci(cfg, f"{name.lower()}_R") if exe is not None else None
        runs: dict = {"c": [], "ssskit_1_thread": [], f"ssskit_{cores}_threads": []}
        last: dict = {}
        for _ in range(args.repeats):  # interleaved: every engine sees the same machine state
            if mci is not None:
                try:
                    wall, cpu, _ = timed_process([str(exe), mci.name], cwd=mci.parent)
                    runs["c"].append((wall, cpu))
                except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
                    case["c_mcml"] = f"failed: {exc}"
                    mci = None
            for key, threads in (("ssskit_1_thread", 1), (f"ssskit_{cores}_threads", cores)):
                wall, cpu, text = timed_process(ssskit_cmd(name, photons, threads))
                runs[key].append((wall, cpu))
                last[key] = json.loads(text)
        for key, rs in runs.items():
            if rs:
                case[key] = {"wall_s": spread([w for w, _ in rs]), "cpu_s": spread([c for _, c in rs]),
                             "photons_per_s": spread([photons / w for w, _ in rs], 0)}
        if runs["c"]:
            pairs = list(zip(runs["c"], runs["ssskit_1_thread"]))
            case["per_core_ratio_ssskit_over_c"] = spread([c[0] / s[0] for c, s in pairs])  # wall: rate ratio
            case["cpu_ratio_ssskit_over_c"] = spread([c[1] / s[1] for c, s in pairs])
            case["all_cores_ratio_ssskit_over_c"] = spread([c[0] / s[0] for c, s in
                                                             zip(runs["c"], runs[f"ssskit_{cores}_threads"])])
            text = (mci.with_suffix(".mco")).read_text() if mci is not None else ""
            rat = {}
            for k, label in (("Rsp", "Specular reflectance"), ("Rd", "Diffuse reflectance")):
                mm = re.search(r"^\s*(\S+)\s+#" + label, text, re.MULTILINE)
                rat[k] = float(mm.group(1)) if mm else None
            mm = re.search(r"^Rd_r #.*\n((?:\s*\S+\n)+)", text, re.MULTILINE)
            rd_r = np.array([float(v) for v in mm.group(1).split()]) if mm else np.zeros(0)
            sim = last["ssskit_1_thread"]["channels"]["R"]
            case["total_rd"] = {
                "c_mcml": rat["Rd"], "ssskit": round(sim["total_Rd"], 6), "ssskit_se": round(sim["total_Rd_se"], 6),
                # C MCML's own error is about the same as ssskit's (same photon count), so the
                # difference's standard error is about sqrt(2) * ssskit_se
                "difference_over_ssskit_se": None if rat["Rd"] is None else
                round((rat["Rd"] - sim["total_Rd"]) / sim["total_Rd_se"], 2),
                "rsp_c_mcml": rat["Rsp"], "rsp_ssskit": round(sim["Rsp"], 6)}
            case["rd_r_profile"] = json_agreement(rd_r, last["ssskit_1_thread"])
        elif exe is None:
            case["c_mcml"] = c_status
        # the engine alone, inside this process (no start-up), and the numpy twin
        one = simulate(cfg, threads=1, use_cache=False)
        case["engine_1_thread_photons_per_s_in_process"] = round(photons / one.seconds)
        t0 = time.perf_counter()
        simulate_numpy(config_for_material(m, 0, photons=args.numpy_photons))
        npy = args.numpy_photons / (time.perf_counter() - t0)
        case["numpy_twin_photons_per_s"] = round(npy)
        case["engine_over_numpy"] = round(photons / one.seconds / npy, 1)
        if gl_ok:  # the GLSL engine on this machine's GL device (llvmpipe here: the CPU)
            n_gl = max(args.gl_photons if name == "Skin1" else args.gl_photons // 10, 10_000)
            simulate(config_for_material(m, 0, photons=10_000, seed=2), backend="gl", use_cache=False)  # compile
            t0 = time.perf_counter()
            g = simulate(config_for_material(m, 0, photons=n_gl), backend="gl", use_cache=False)
            case["gl_engine"] = {"photons": n_gl, "photons_per_s": round(n_gl / (time.perf_counter() - t0)),
                                 "total_rd": round(g.total_rd, 6), "total_rd_se": round(g.total_rd_se, 6),
                                 "renderer": gl_why}
        else:
            case["gl_engine"] = f"not run: {gl_why}"
        out["cases"][f"{name} R"] = case
        print(json.dumps({name: case}), file=sys.stderr, flush=True)

    if args.full:
        m = get_material("skin1")
        t0 = time.perf_counter()
        for ch in range(3):
            simulate(config_for_material(m, ch, photons=10_000_000), use_cache=False)
        out["skin1_full_rgb_1e7_photons_per_channel_seconds"] = round(time.perf_counter() - t0, 1)
    out["load_average_after"] = os.getloadavg()
    print(json.dumps(out, indent=1))


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


if __name__ == "__main__":
    main()
