"""Regenerate the numbers of docs/head.md (the papers' head figures on the scanned head) into
docs/head_numbers.json and the tables of docs/head.md (between its "numbers" markers).

    nice -n 10 python docs/head_numbers.py [--sections scale fig7 fig9 fig1] [--quick]
        [--json docs/head_numbers.json] [--md docs/head.md]

Sections: ``scale`` (the head's breadth and length, and the region levels at 0.9x, 1x, 1.1x the scale),
``fig7`` (Xie Fig. 7: Eq. 21 against exact Burley sampling), ``fig9`` (Xie Fig. 9: the adaptive pass against
the path trace per region, without and with transmission; the path traces come from the cache that
docs/head_references.py fills, else they are rendered here), ``fig1`` (Xie Fig. 1 in kind: the three-view
study). ``--quick``: a small case (48 x 36, few samples, the front view; no path trace) for the test.
Each section's wall time, the machine and its load average are recorded.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

SECTIONS = ("scale", "fig7", "fig9", "fig1", "separable")
BEGIN, END = "<!-- numbers: docs/head_numbers.py -->", "<!-- end of numbers -->"


def compute(sections: list[str], quick: bool, say: Any = print) -> dict[str, Any]:
    from ssskit.figures.head import S2_KERNELS, fig7_numbers, fig9_numbers, scale_sensitivity, separable_numbers
    from ssskit.figures.views import study_json, three_view_study
    from ssskit.scenes.head import ATTRIBUTION, MM_PER_UNIT, head_measures

    out: dict[str, Any] = {"attribution": ATTRIBUTION, "quick": quick, "seconds": {}}
    size = (48, 36) if quick else (96, 72)
    for sec in sections:
        t0 = time.time()
        say(f"section {sec}")
        if sec == "scale":
            units = head_measures()
            out["scale"] = {"mm_per_unit": MM_PER_UNIT, "units": units,
                            "mm": {k: v * MM_PER_UNIT for k, v in units.items()},
                            "sensitivity": scale_sensitivity(views=("front",) if quick else ("front", "ear", "close"),
                                                             width=size[0], height=size[1],
                                                             spp=256 if quick else 2048)}
        elif sec == "fig7":
            res = fig7_numbers(views=("front",) if quick else ("front", "ear", "close"),
                               width=48 if quick else 192, height=36 if quick else 144, spp=256 if quick else 4096,
                               progress=say)
            out["fig7"] = {k: v for k, v in res.items() if k != "images"}
        elif sec == "fig9":
            out["fig9"] = [{k: v for k, v in fig9_numbers(v, width=size[0], height=size[1], progress=say).items()
                            if k != "images"} for v in ("front", "ear")]
        elif sec == "fig1":
            study = three_view_study(scene="head", width=64 if quick else 128, height=48 if quick else 96,
                                     frames=4 if quick else 16, reference_spp=256 if quick else 4096,
                                     repeats=1, views=("front",) if quick else ("close", "ear", "front"),
                                     progress=say)
            out["fig1"] = study_json(study)
        elif sec == "separable":
            res = separable_numbers(views=("front",) if quick else ("close", "ear", "front"), width=size[0],
                                    height=size[1], path_traced=not quick, repeats=1 if quick else 3,
                                    kernels=("preintegrated", "svd:1") if quick else S2_KERNELS, progress=say)
            out["separable"] = {k: v for k, v in res.items() if k != "images"}
        out["seconds"][sec] = time.time() - t0
    out["machine"] = {"cpus": os.cpu_count(), "platform": platform.platform(), "load_avg": os.getloadavg()}
    return out


def _pct(x: float) -> str:
    return f"{100 * x:.2f} %"


def tables(n: dict[str, Any]) -> str:
    """The markdown tables of docs/head.md from the numbers."""
    lines: list[str] = []
    if "references" in n:
        r0 = n["references"]
        lines += ["### References", "",
                  f"`{r0['command'].strip()}`: {r0['seconds']:.0f} s in all on {r0['machine']['cpus']} cores, load average "
                  f"{r0['machine']['load_avg'][0]:.1f} (the machine shared with other jobs). Level (green) +- standard "
                  "error (from the per-pixel errors of independent chunks) and relative SE per region.", "",
                  "| view, material | spp | seconds | target met | region | pixels | level (R, G, B) | relative SE (G) |",
                  "|---|---|---|---|---|---|---|---|"]
        for r in r0["rows"]:
            for reg, row in r["regions"].items():
                if not row["pixels"]:
                    continue
                lines.append(f"| {r['view']}, {r['material']} | {r['spp']} | {r['seconds']:.0f} | {'yes' if r['converged'] else 'no'} "
                             f"({r['driving_region']}) | {reg} | {row['pixels']} | "
                             + ", ".join(f"{x:.4f}" for x in row["level"]) + f" | {_pct(row['rel_se'][1])} |")
        lines.append("")
    if "scale" in n:
        s = n["scale"]
        lines += ["### Scale", "", f"{s['mm_per_unit']:g} mm per unit: head breadth {s['units']['breadth']:.4f} units = "
                  f"{s['mm']['breadth']:.1f} mm (men's mean 155, SD 6), head length {s['units']['length']:.4f} units = "
                  f"{s['mm']['length']:.1f} mm (men's mean 195, SD 8).", "",
                  "Region levels (green channel: diffuse part / (E / pi)) at 0.9x, 1x and 1.1x the scale, same camera and "
                  "lights; Burley: the exact sampler's converged limit; separable: the burley_fit kernel, 7 taps.", "",
                  "| view | region | pixels | Burley 0.9x | 1x | 1.1x | separable 0.9x | 1x | 1.1x |", "|---|---|---|---|---|---|---|---|---|"]
        rows = s["sensitivity"]["rows"]
        for v in dict.fromkeys(r["view"] for r in rows):
            by = {r["factor"]: r for r in rows if r["view"] == v}
            base = by[1.0]["regions"]
            for reg, b in base.items():
                vals = [by[f]["regions"].get(reg) for f in (0.9, 1.0, 1.1)]
                if any(x is None for x in vals):
                    continue
                lines.append(f"| {v} | {reg} | {b['pixels']} | " + " | ".join(f"{x['burley']:.4f}" for x in vals) + " | "
                             + " | ".join(f"{x['separable']:.4f}" for x in vals) + " |")
        lines.append("")
    if "fig7" in n:
        f = n["fig7"]
        lines += ["### Xie Fig. 7 on the head", "",
                  f"Eq. 21 against the exact inverse CDF, {f['spp']} spp each, {f['size'][0]} x {f['size'][1]}, "
                  "no mips, the same random numbers; noise floor: two exact runs of different seeds.", "",
                  "| view | RMS (relative) | noise floor | mean bias | Xie (PBRT, 2k spp) |", "|---|---|---|---|---|"]
        for r in f["rows"]:
            lines.append(f"| {r['view']} | {_pct(r['rms'])} | {_pct(r['noise_floor'])} | {100 * r['mean_bias']:+.3f} % | "
                         f"{_pct(f['xie_rms'])} |")
        lines.append("")
    if "fig9" in n:
        lines += ["### Xie Fig. 9 on the head", "",
                  "Region levels (green) of the adaptive pass (sigma0^2 = 1e-3, kappa = 0.2, 8-64 spp, last of 16 "
                  "frames), its converged limit (exact Burley sampling, 4096 spp: the Burley-diffusion truth) and the "
                  "path trace (volumetric, Mitsuba) +- its standard error; ratio = pass / path traced +- SE.", "",
                  "| view | transmission | region | pixels | adaptive | Burley limit | path traced +- SE | ratio +- SE |",
                  "|---|---|---|---|---|---|---|---|"]
        for res in n["fig9"]:
            for name, run in res["runs"].items():
                for reg, row in run["regions"].items():
                    if not row["pixels"]:
                        continue
                    pt = row["path_traced"]
                    ratio = row["screen_space_vs_path_traced"]
                    lines.append(f"| {res['view']} | {name} | {reg} | {row['pixels']} | {row['screen_space']['level'][1]:.4f} | "
                                 f"{row['exact_2d']['level'][1]:.4f} | {pt['level'][1]:.4f} +- {pt['se'][1]:.4f} | "
                                 f"{ratio['ratio'][1]:.3f} +- {ratio['se'][1]:.3f} |")
            lines.append(f"| {res['view']} | reference | {res['reference']['spp']} spp, "
                         f"{'converged' if res['reference']['converged'] else 'budget spent'} on "
                         f"{res['reference']['driving_region']} | | | | | |")
        lines.append("")
    if "fig1" in n:
        st = n["fig1"]
        lines += ["### Xie Fig. 1 in kind on the head", "",
                  "Gray PSNR (dB) inside the SSS mask against the pass's converged limit (exact sampler, no mips; Xie: "
                  "\"a reference image at 2k samples per pixel\"), last frame / after TAA; mean samples per pixel; ms per frame "
                  "on numba (taken at a load average near 20 on 2 cores: indicative only).", "",
                  "| view | method | PSNR | PSNR after TAA | mean spp | ms per frame |", "|---|---|---|---|---|---|"]
        for r in st["rows"]:
            p = "" if r.get("psnr_gray") is None else f"{r['psnr_gray']:.2f}"
            pt = "" if r.get("psnr_gray_taa") is None else f"{r['psnr_gray_taa']:.2f}"
            lines.append(f"| {r['view']} | {r['method']} | {p} | {pt} | {r['mean_spp']:.1f} | {r['ms']:.1f} |")
        if "limit" in st:
            lines += ["", "Noise floor (a second converged limit of another seed against the first): "
                      + ", ".join(f"{k} {v['psnr_gray_second_seed']:.1f} dB" for k, v in st["limit"].items()) + "."]
        if "golubev_minus_eq21" in st:
            lines += ["", "PSNR(Golubev 64) - PSNR(Eq. 21 at 64), dB, last frame / after TAA, against Xie's: "
                      + ", ".join(f"{v} {st['golubev_minus_eq21'][v]:+.2f} / {st['golubev_minus_eq21_taa'][v]:+.2f} "
                                  f"(Xie {st['xie'][v]:+.2f})" for v in st["golubev_minus_eq21"]) + "."]
        lines.append("")
    if "separable" in n:
        sp = n["separable"]
        lines += ["### The separable-SSS paper on the head (Fig. 1, S.2, S.8)", "",
                  f"Every kernel ({sp['taps']} importance-sampled taps, Skin1's Monte Carlo profile, {sp['size'][0]} x "
                  f"{sp['size'][1]}) against the exact 2D convolution of the same profile: relative RMSE over the SSS "
                  "pixels (the kernel's error; it ranks the kernels). The views are S.8's close, medium and far shots "
                  "(camera distance, pixel footprint). Times are in the JSON only (taken on a machine at load ~20).", "",
                  "| kernel | rank | " + " | ".join(f"{v} ({k}, {d:.0f} mm, {p:.2f} mm/px)" for v, k, d, p in
                                                    dict.fromkeys((r["view"], {vv: kk for kk, vv in sp["s8"].items()}[r["view"]],
                                                                   r["camera_mm"], r["pixel_mm"]) for r in sp["rows"])) + " |",
                  "|---|---|" + "---|" * len({r["view"] for r in sp["rows"]})]
        views = list(dict.fromkeys(r["view"] for r in sp["rows"]))
        for k in dict.fromkeys(r["kernel"] for r in sp["rows"]):
            by = {r["view"]: r for r in sp["rows"] if r["kernel"] == k}
            lines.append(f"| {k} | {by[views[0]]['rank']} | " + " | ".join(_pct(by[v]["rel_rmse_exact"]) for v in views) + " |")
        lvl = []
        for v in views:
            reg = (sp["rows"][[r["view"] for r in sp["rows"]].index(v)].get("regions") or {}).get("shadow_edge")
            if reg and reg["ratio"]:
                lvl.append(f"{v} {reg['ratio']['ratio'][1]:.3f} +- {reg['ratio']['se'][1]:.3f}")
        if lvl:
            lines += ["", "Against the path trace, every kernel gives the same shadow-edge level (each kernel keeps the "
                      "profile's energy, so a region's level is the profile's total reflectance, whatever the kernel): "
                      "level / path traced (green) " + ", ".join(lvl) + ". The path trace ranks the profile, not the "
                      "kernels; its per-pixel noise (the Fig. 9 images) is far above the kernels' differences."]
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sections", nargs="+", choices=SECTIONS, default=list(SECTIONS))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", default=None)
    ap.add_argument("--md", default=None)
    args = ap.parse_args(argv)
    n: dict[str, Any] = {}
    for sec in args.sections:  # each section saved as it completes
        part = compute([sec], args.quick)
        part["command"] = "python docs/head_numbers.py " + " ".join(argv or [])
        if args.json:
            old = json.loads(Path(args.json).read_text()) if Path(args.json).is_file() else {}
        else:
            old = n
        old.update({k: v for k, v in part.items() if k != "seconds"})
        old.setdefault("seconds", {}).update(part["seconds"])
        n = old
        if args.json:
            Path(args.json).write_text(json.dumps(n, indent=1) + "\n")
    refs = Path(__file__).parent / "head_references.json"
    if refs.is_file() and not args.quick:
        n["references"] = json.loads(refs.read_text())
    if args.md:
        md = Path(args.md)
        text = md.read_text()
        new = f"{BEGIN}\n{tables(n)}\n{END}"
        text = re.sub(re.escape(BEGIN) + ".*?" + re.escape(END), lambda m: new, text, flags=re.S)
        md.write_text(text)
    print(json.dumps({k: v for k, v in n.items() if k in ("seconds", "machine")}, indent=1))
    return n


if __name__ == "__main__":
    main()
