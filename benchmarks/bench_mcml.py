"""Benchmark: ssskit's numba MCML engine against the original C MCML 1.2.2 (Wang, Jacques, Zheng)
and a plain vectorised-numpy implementation of the same algorithm, all measured in the same run;
prints one JSON object.

    python benchmarks/bench_mcml.py [--photons N] [--marble-photons N] [--numpy-photons N]
                                    [--mcml-src DIR] [--full]

NUMBA_THREADING_LAYER is set to 'workqueue' (always available) unless given.

Cases: the red channel of Skin1 and of Marble (``ssskit.materials``), semi-infinite (ssskit: an
infinite layer; MCML: one layer 10^7 cm thick, as the supplement's section F), g = 0, refractive
index 1.3 (Skin1) / 1.5 (Marble) under an ambient of 1.0, on the supplement's radial grid
(``supplement_grid``: dr = min MFP / 20, nr = ceil(32 max MFP / dr)). Both engines trace the same
number of photons. MCML's input is written in cm and cm^-1 (ssskit works in mm and mm^-1).

C MCML. Its source is not part of this repository. Put the C files of the public repository
lhvwang/MCML, folder ``V1/mcR5unix/mcmlcode`` (mcml.h, mcmlmain.c, mcmlgo.c, mcmlio.c, mcmlnr.c),
into ``benchmarks/.mcml-src/`` (git-ignored), e.g.

    git clone https://github.com/lhvwang/MCML /tmp/MCML
    mkdir -p benchmarks/.mcml-src && cp /tmp/MCML/V1/mcR5unix/mcmlcode/* benchmarks/.mcml-src/

or, from a bare mirror of that repository,

    git --git-dir=<mirror> archive HEAD V1/mcR5unix/mcmlcode | tar -x --strip-components=3 -C benchmarks/.mcml-src

or point ``--mcml-src`` at any folder holding them. The script then compiles them once with
``gcc -O2`` into ``benchmarks/.mcml-build/`` (git-ignored; rebuilt only when a source is newer),
writes an MCML input file (.mci) per case there, runs the program and times the run (wall time,
one process, one core: MCML is single-threaded). Its total diffuse reflectance (RAT section of the
.mco output) is reported next to ssskit's ``total_rd`` and standard error. Without the source the
JSON says so (``"c_mcml": "not run: source not found in <dir>"``) and no C figure is given.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import subprocess
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
    n = res.rd.shape[0] - 1
    if rd_r_cm2.shape[0] != res.rd.shape[0]:
        return {"error": f"MCML wrote {rd_r_cm2.shape[0]} radial bins, ssskit has {res.rd.shape[0]}"}
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


def run_numba(cfg: MCConfig, threads: int):
    r = simulate(cfg, threads=threads, use_cache=False)
    return cfg.photons / r.seconds, r


def rate_numpy(cfg: MCConfig) -> float:
    t0 = time.perf_counter()
    simulate_numpy(cfg)
    return cfg.photons / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--photons", type=int, default=1_000_000, help="photons of the Skin1 case (both engines)")
    ap.add_argument("--marble-photons", type=int, default=None,
                    help="photons of the Marble case (both engines; default: --photons)")
    ap.add_argument("--numpy-photons", type=int, default=100_000, help="photons of the numpy twin, per case")
    ap.add_argument("--mcml-src", type=Path, default=DEFAULT_SRC, help="folder holding MCML 1.2.2's C files")
    ap.add_argument("--full", action="store_true", help="also time the supplement's full Skin1 RGB simulation")
    args = ap.parse_args()
    marble_photons = args.marble_photons or args.photons

    # compile once, outside the timings
    simulate(config_for_material(get_material("skin1"), 0, photons=1_000), use_cache=False)
    simulate_numpy(config_for_material(get_material("skin1"), 0, photons=100))
    cores = numba.config.NUMBA_NUM_THREADS
    out: dict = {"machine": {"cpu_count": os.cpu_count(), "numba_threads": cores, "python": platform.python_version(),
                             "numba": numba.__version__, "threading_layer": os.environ["NUMBA_THREADING_LAYER"],
                             "cpu": _cpu_name()},
                 "date": time.strftime("%Y-%m-%d"), "c_mcml": None, "cases": {}}

    code = find_sources(args.mcml_src)
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

    for name, ch, photons in (("Skin1", 0, args.photons), ("Marble", 0, marble_photons)):
        label = f"{name} {'RGB'[ch]}"
        m = get_material(name)
        cfg = config_for_material(m, ch, photons=photons)
        one, res = run_numba(cfg, 1)
        two, _ = run_numba(cfg, min(2, cores))
        npy = rate_numpy(config_for_material(m, ch, photons=args.numpy_photons))
        case = {
            "photons": photons,
            "grid": {"dr_mm": cfg.dr_mm, "nr": cfg.nr},
            "numba_1_thread_photons_per_s": round(one),
            "numba_2_threads_photons_per_s": round(two),
            "scaling_1_to_2_threads": round(two / one, 3),
            "numpy_photons": args.numpy_photons,
            "numpy_vectorised_photons_per_s": round(npy),
            "numba_1_thread_over_numpy": round(one / npy, 2),
        }
        if exe is None:
            case["c_mcml"] = c_status
        else:
            try:
                mci = write_mci(cfg, f"{name.lower()}_{'RGB'[ch]}")
                secs, rat, rd_r = run_mcml(exe, mci)
            except (RuntimeError, OSError, subprocess.TimeoutExpired) as exc:
                case["c_mcml"] = f"failed: {exc}"
            else:
                c_rate = photons / secs
                case.update({
                    "c_mcml_1_core_seconds": round(secs, 2),
                    "c_mcml_1_core_photons_per_s": round(c_rate),
                    "numba_1_thread_over_c_mcml": round(one / c_rate, 3),
                    "numba_2_threads_over_c_mcml": round(two / c_rate, 3),
                })
                rd_c = rat["Rd"]
                case["total_rd"] = {
                    "c_mcml": rd_c,
                    "ssskit": round(res.total_rd, 6),
                    "ssskit_se": round(res.total_rd_se, 6),
                    # C MCML's own error is about the same as ssskit's (same photon count), so the
                    # difference's standard error is about sqrt(2) * ssskit_se
                    "difference_over_ssskit_se": None if rd_c is None else round((rd_c - res.total_rd) / res.total_rd_se, 2),
                    "rsp_c_mcml": rat["Rsp"], "rsp_ssskit": round(res.rsp, 6),
                }
                case["rd_r_profile"] = profile_agreement(rd_r, res)
        out["cases"][label] = case

    if args.full:
        m = get_material("skin1")
        t0 = time.perf_counter()
        for ch in range(3):
            simulate(config_for_material(m, ch, photons=10_000_000), use_cache=False)
        out["skin1_full_rgb_1e7_photons_per_channel_seconds"] = round(time.perf_counter() - t0, 1)
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
