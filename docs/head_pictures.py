"""Readable path-traced pictures of the head (docs/head.md, "Why the path traces speckle"; issue 35, Build 6):
per view, a Mitsuba ``volpathmis`` render of Skin1 inside the shipped rough dielectric
(:class:`ssskit.scenes.reference.ReferenceRenderer`, the references' scene), in independent chunks, shown
unfiltered and as its display copy (:func:`ssskit.figures.display.display_copy`: box means of b x b pixels,
the smallest b that brings the relative noise over the SSS pixels to 10 %; display only). Writes the figure
(``docs/img/head_pathtraced.png``) and a JSON record (per view: spp, the box, the samples per shown pixel, the
noise before and after, the seconds).

These renders are for looking at only: the numbers of docs/head.md come from the cached references
(docs/head_references.py), never from these images or their box means. Their seed (1) differs from the
references' (0).

    nice -n 10 python docs/head_pictures.py [--size 48x36] [--spp 16384] [--views close ear front]
        [--png docs/img/head_pathtraced.png] [--json docs/head_pictures.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np

CHUNK_SPP = 256


def picture(view: str, width: int, height: int, spp: int, say: Any = print) -> dict[str, Any]:
    """One view's render (module docstring): its image (diffuse part), per-pixel SE, mask and display copy."""
    from ssskit.figures.head import _homogeneous, head_view
    from ssskit.figures.display import display_copy
    from ssskit.materials import get_material
    from ssskit.scenes.reference import ReferenceRenderer, batch_mean_se

    sc = head_view(view, "skin1", width, height)
    r = ReferenceRenderer(sc.spec, _homogeneous(get_material("skin1")), width, height, seed=1)
    chunks = max(2, spp // CHUNK_SPP)
    t0 = time.perf_counter()
    imgs = []
    for i in range(chunks):
        imgs.append(r.chunk(i, CHUNK_SPP))
        if (i + 1) % 8 == 0:
            say(f"{view}: {(i + 1) * CHUNK_SPP} spp")
    mean, se = batch_mean_se(np.stack(imgs))
    part = mean - sc.gbuffer.specular.astype(np.float64)
    mask = sc.gbuffer.mask
    shown, block, rel = display_copy(part, se, mask)
    return {"view": view, "spp": chunks * CHUNK_SPP, "seconds": time.perf_counter() - t0, "block": block,
            "spp_per_shown_pixel": chunks * CHUNK_SPP * block ** 2, "noise_unfiltered": _noise(part, se, mask),
            "noise_shown": rel, "image": part, "shown": shown, "mask": mask}


def _noise(img: np.ndarray, se: np.ndarray, mask: np.ndarray) -> float:
    """The relative noise of an image over ``mask`` as display_copy measures it at block 1: RMS(se) / mean."""
    level = float(img[mask].mean())
    return float(np.sqrt(np.mean(se[mask] ** 2)) / level) if level > 0 else float("inf")


def plot(rows: list[dict[str, Any]], path: Path) -> Path:
    from ssskit.figures.plots import pyplot, save_figure
    from ssskit.settings import HEAD_ATTRIBUTION

    plt = pyplot()
    fig, axes = plt.subplots(2, len(rows), figsize=(3.6 * len(rows), 5.6), squeeze=False)
    for i, r in enumerate(rows):
        scale = float(np.percentile(r["shown"][r["mask"]], 99.5)) or 1.0
        for j, (img, title) in enumerate(((r["image"], f"{r['view']}: {r['spp']} spp per pixel, unfiltered\n"
                                          f"noise {r['noise_unfiltered']:.0%} (RMS SE / mean)"),
                                         (r["shown"], f"display copy: {r['block']}x{r['block']} box means,\n"
                                          f"{r['spp_per_shown_pixel']} spp per shown pixel, noise {r['noise_shown']:.0%}"))):
            ax = axes[j][i]
            ax.imshow(np.clip(np.asarray(img) / scale, 0, 1) ** (1 / 2.2), interpolation="nearest")
            ax.set_title(title, fontsize=8)
            ax.axis("off")
    fig.suptitle("The head, Skin1, volumetric path trace (Mitsuba volpathmis, rough dielectric boundary; display "
                 f"only, the numbers use the cached references). {HEAD_ATTRIBUTION}", fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    save_figure(fig, path)
    return path


def main(argv: list[str] | None = None) -> dict[str, Any]:
    import sys

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="48x36")
    ap.add_argument("--spp", type=int, default=16384)
    ap.add_argument("--views", nargs="+", default=["close", "ear", "front"], choices=["close", "ear", "front"])
    ap.add_argument("--png", default="docs/img/head_pathtraced.png")
    ap.add_argument("--json", default="docs/head_pictures.json")
    args = ap.parse_args(argv)
    w, _, h = args.size.lower().partition("x")
    t0 = time.time()
    load0 = os.getloadavg()
    rows = [picture(v, int(w), int(h), args.spp) for v in args.views]
    png = plot(rows, Path(args.png))
    out = {"command": "python docs/head_pictures.py " + " ".join(sys.argv[1:] if argv is None else argv),
           "png": str(png), "size": [int(w), int(h)],
           "rows": [{k: v for k, v in r.items() if k not in ("image", "shown", "mask")}
                    for r in rows],
           "seconds": time.time() - t0,
           "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "load_avg_before": load0,
                       "load_avg_after": os.getloadavg()}}
    Path(args.json).write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
