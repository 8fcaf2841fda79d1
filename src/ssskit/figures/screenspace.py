"""The screen-space figures of ``ssskit demo``: every built-in scene with several kernels, the exact 2D
convolution and a path-traced reference, with the region-wise comparison; and the slab's shadow-edge
profile (screen space vs exact 2D vs a converged reference).

Both are cached on disk (``cache_dir("reference")``, keyed by every input and the code version): a
second ``ssskit demo`` reads the images and numbers instead of rendering them again.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from collections.abc import Iterable
from typing import Any, Callable, TypeVar

import numpy as np

from ..backends import DEFAULT_BACKEND
from ..metrics import region_metrics, tonemap
from ..pipeline import RenderResult, RenderSettings, SeparablePass, render
from ..pipeline.regions import compare_regions
from ..scenes import front_lit_scenes
from ..screenspace import GBuffer, PassSettings
from .display import DISPLAY_BLOCKS, DISPLAY_REL_SE, display_copy  # noqa: F401 - re-exported (ssskit.report)
from .plots import CHANNEL_COLORS, pyplot, save_figure
from .stored import stored

_T = TypeVar("_T")

#: (label, kernel spec, taps, tap placement) shown per scene
SCREEN_SPACE_METHODS = (
    ("pre-integrated, 7 IS taps", "preintegrated", 7, "importance"),
    ("pre-integrated, 7 uniform taps", "preintegrated", 7, "uniform"),
    ("artist (two-Gaussian), 7 IS taps", "artist", 7, "importance"),
    ("Jimenez 2012 engine, 11 taps", "jimenez2012", 11, "importance"),
)

#: bumped when what the cached figures hold changes
_FIGURE_VERSION = 6


def _cached(name: str, key: dict[str, Any], make: Callable[[], _T]) -> _T:
    """``make()`` once per ``key``: pickled in the reference cache (the demo's screen-space results)."""
    return stored("reference", name, {**key, "v": _FIGURE_VERSION}, make)


def screen_space_comparison(out: Path, material: str = "skin1", scenes: Iterable[str] | None = None, width: int = 160, height: int = 120,
                            spp: int = 16, reference_spp: int = 32, reference_max_spp: int = 128,
                            model: str = "montecarlo", photons: int = 10_000_000,
                            progress: Callable[[str], None] | None = None,
                            sss: PassSettings | None = None) -> tuple[Path, list[dict[str, Any]], dict[str, Any]]:
    """Render every scene (default: the built-in ones lit from the front, :func:`ssskit.scenes.front_lit_scenes`)
    with :data:`SCREEN_SPACE_METHODS`; write ``screenspace.png``.

    ``model``: the profile of the kernels and the exact 2D convolution (the Monte Carlo profile by
    default, ``photons`` per channel). Each scene's G-buffer, exact 2D convolution and path trace
    (``reference_spp`` to ``reference_max_spp`` spp, until the SSS mask's relative standard error is
    1%) are made once and shared by the methods. ``sss``: the pass settings (default: 10% jitter).
    Returns (png path, rows, regions) with rows = [{scene, method, exact_2d {psnr, flip...},
    path_traced {...}}] and regions = {scene: the region table of the first method
    (:func:`ssskit.pipeline.regions.compare_regions`) and its reference's summary}. Cached.
    """
    sss = PassSettings(jitter=0.1) if sss is None else sss
    scenes = list(scenes or front_lit_scenes())
    key = dict(material=material, scenes=scenes, width=width, height=height, spp=spp, ref=reference_spp,
               ref_max=reference_max_spp, model=model, photons=photons, sss=sss.to_dict())
    grid, rows, regions = _cached("screenspace", key, lambda: _render_scenes(
        material, scenes, width, height, spp, reference_spp, reference_max_spp, model, photons, progress, sss))
    plt = pyplot()
    ncol = max(len(line) for _, line in grid)
    # per scene two rows: the whole frames, then each frame's shadow edge zoomed (the box drawn above),
    # where the methods differ; full width in the report (each panel ~400 px across)
    fig, axes = plt.subplots(2 * len(grid), ncol, figsize=(3.9 * ncol, 2 * 2.9 * len(grid)), squeeze=False)
    for r, (scene, line) in enumerate(grid):
        peak = float(np.percentile(line[-1][1], 99.5)) or 1.0  # one exposure along a row
        crop = regions.get(scene, {}).get("crop")
        for c in range(ncol):
            ax, zoom = axes[2 * r, c], axes[2 * r + 1, c]
            ax.axis("off")
            zoom.axis("off")
            if c >= len(line):
                continue
            img = tonemap(line[c][1], peak)
            ax.imshow(img)
            ax.set_title(f"{scene}: {line[c][0]}" if c == 0 else line[c][0], fontsize=9)
            if crop is not None:
                y0, y1, x0, x1 = crop
                ax.add_patch(plt.Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fill=False, ec="#ffcc00", lw=1))
                zoom.imshow(img[y0:y1, x0:x1], interpolation="nearest")
                zoom.set_title(f"the sharpest light step, x{img.shape[1] // max(x1 - x0, 1)}", fontsize=8)
    fig.suptitle(f"Screen-space separable SSS, {material} ({model} profile); each scene tone-mapped to its "
                 "path-traced peak; below each frame its sharpest step of light (the slab's shadow edge) zoomed", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.5 / fig.get_figheight()))
    path = Path(out) / "screenspace.png"
    save_figure(fig, path)
    return path, rows, regions


def _edge_window(gb: GBuffer, table: dict[str, Any] | None) -> tuple[int, int, int, int] | None:
    """(y0, y1, x0, x1): a quarter-size window of the frame centred on its sharpest step of light inside
    the SSS mask (the largest jump of E/pi between two SSS neighbours: a shadow edge where the scene has
    one), or None when the frame has no SSS pixels."""
    light = gb.diffuse.astype(float).mean(axis=-1)
    m = gb.mask
    if not m.any():
        return None
    jump = np.zeros(light.shape)
    dx = np.abs(np.diff(light, axis=1)) * (m[:, 1:] & m[:, :-1])
    dy = np.abs(np.diff(light, axis=0)) * (m[1:, :] & m[:-1, :])
    jump[:, 1:] = np.maximum(jump[:, 1:], dx)
    jump[1:, :] = np.maximum(jump[1:, :], dy)
    cy, cx = np.unravel_index(int(np.argmax(jump)), jump.shape)
    h, w = light.shape
    hh, hw = max(h // 4, 4), max(w // 4, 4)
    y0, x0 = min(max(int(cy) - hh // 2, 0), h - hh), min(max(int(cx) - hw // 2, 0), w - hw)
    return y0, y0 + hh, x0, x0 + hw


def _render_scenes(material: str, scenes: list[str], width: int, height: int, spp: int, reference_spp: int,
                   reference_max_spp: int, model: str, photons: int, progress: Callable[[str], None] | None,
                   sss: PassSettings) -> tuple[list[tuple[str, list[tuple[str, np.ndarray]]]], list[dict[str, Any]],
                                               dict[str, Any]]:
    say = progress or (lambda msg: None)
    rows: list[dict[str, Any]] = []
    grid: list[tuple[str, list[tuple[str, np.ndarray]]]] = []
    regions: dict[str, Any] = {}
    for scene in scenes:
        line: list[tuple[str, np.ndarray]] = []
        ref_budget: dict[str, Any] = dict(reference_spp=reference_spp, reference_max_spp=reference_max_spp)
        base: RenderResult | None = None
        for label, spec, taps, placement in SCREEN_SPACE_METHODS:
            say(f"screen space: {scene}, {label}")
            first = base is None
            settings = RenderSettings(material=material, model=model, photons=photons, kernel=spec, taps=taps,
                                      tap_method=placement, width=width, height=height, spp=spp, exact=first,
                                      reference=first, frame=sss.frame, seed=sss.seed,
                                      **(ref_budget if first else {}),
                                      backend=sss.backend,
                                      pass_=SeparablePass(jitter=sss.jitter, depth_mode=sss.depth_mode))
            r = render(scene if base is None else base.gbuffer, settings, progress=say)
            assert isinstance(r, RenderResult)  # the separable pass
            if base is None:
                base = r
                line.append(("no SSS", r.gbuffer.composite()))
                regions[scene] = {"table": r.metrics.get("regions"),
                                  "reference": r.metrics["path_traced"]["reference"],
                                  "crop": _edge_window(r.gbuffer, r.metrics.get("regions"))}
            assert base.reference is not None  # the first render path-traces
            mask = r.gbuffer.mask
            row: dict[str, Any] = {"scene": scene, "method": label}
            if base.exact is not None:
                row["exact_2d"] = r.metrics["exact_2d"] if first else region_metrics(
                    r.gbuffer.composite(base.exact), r.image, mask)
            row["path_traced"] = r.metrics["path_traced"] if first else region_metrics(base.reference, r.image, mask)
            # each kernel's own region levels against the reference's (with its standard errors): unlike the
            # per-pixel PSNR against the path trace, which its noise sets alike for every kernel
            row["regions"] = (r.metrics["regions"] if first else
                              compare_regions(r.gbuffer, r.profile, r.sss, base.exact, base.reference_info))["regions"]
            rows.append(row)
            line.append((label, r.image))
        assert base is not None and base.reference is not None  # SCREEN_SPACE_METHODS is not empty
        if base.exact is not None:
            line.append(("exact 2D convolution", base.gbuffer.composite(base.exact)))
        else:
            line.append(("exact 2D (non-square pixels)", np.zeros_like(base.image)))
        ref = base.reference_info
        shown, block, rel = display_copy(np.asarray(base.reference, float), np.asarray(ref.pixel_se, float),
                                         base.gbuffer.mask)
        what = "path traced (volpathmis)" if block == 1 else f"path traced, {block}x{block} block means (display)"
        line.append((f"{what}; rel. noise {rel:.0%}", shown))
        grid.append((scene, line))
    return grid, rows, regions


def slab_edge_profile(out: Path, material: str = "skin1", photons: int = 10_000_000, width: int = 128,
                      height: int = 48, reference_spp: int = 64, reference_max_spp: int = 4096,
                      target_rel_se: float = 0.002, progress: Callable[[str], None] | None = None,
                      backend: str = DEFAULT_BACKEND) -> tuple[Path, dict[str, Any]]:
    """The slab's shadow-edge profile: 7 importance-sampled taps of the Monte Carlo profile's
    pre-integrated kernel vs the exact 2D convolution vs the path-traced reference, each divided by
    its own plateau (shape apart from level), with the reference's standard error; RMSEs with
    standard errors. Written to ``slab_edge.png``; returns (path, numbers). The pass runs on ``backend``.

    The index-matched set-up (the material at eta = 1, Mitsuba ``null`` boundary, MCML at eta = 1):
    its reference converges ~100x faster than the rough dielectric's (whose point-light paths must
    pass a narrow Beckmann lobe), so the shape is resolved; the rough-dielectric slab's plateau level
    is in the scene table.
    """
    key = dict(material=material, photons=photons, w=width, h=height, spp=reference_spp, max=reference_max_spp,
               rel=target_rel_se, backend=backend)
    data = _cached("slab_edge", key, lambda: _slab_edge(material, photons, width, height, reference_spp,
                                                         reference_max_spp, target_rel_se, progress, backend))
    shape = data["shape"]
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2), sharey=True)
    x = (np.arange(shape["columns"][0], shape["columns"][1] + 1) + 0.5 - width / 2) * data["pixel_mm"]
    styles = {"screen_space": ("-", "screen space, 7 IS taps"), "exact_2d": ("--", "exact 2D convolution"),
              "path_traced": ("", "path traced (index-matched)")}
    for c, ax in enumerate(axes):
        for key_, (ls, label) in styles.items():
            prof = np.asarray(shape["profiles"][key_])[:, c]
            if key_ == "path_traced":
                se = np.asarray(data["reference_profile_se"])[:, c]
                ax.fill_between(x, prof - 2 * se, prof + 2 * se, color=CHANNEL_COLORS[c], alpha=0.25, lw=0,
                                label="reference ± 2 SE")
                ax.plot(x, prof, ".", color=CHANNEL_COLORS[c], ms=3, label=label)
            else:
                ax.plot(x, prof, ls, color="k" if key_ == "exact_2d" else CHANNEL_COLORS[c], lw=1.2, label=label)
        ax.axvline(0, color="0.6", lw=0.8)
        ax.set_title(f"channel {'RGB'[c]}")
        ax.set_xlabel("distance from the shadow edge [mm]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("diffuse part / plateau level")
    axes[2].legend(loc="center left", bbox_to_anchor=(1.02, 0.5), fontsize=8, frameon=False)
    fig.suptitle(f"Slab shadow edge, {data['material']} (Monte Carlo profile at eta = 1, index-matched reference, "
                 f"{data['reference']['spp']} spp)", fontsize=10)
    fig.tight_layout()
    path = Path(out) / "slab_edge.png"
    save_figure(fig, path)
    return path, data


def _slab_edge(material: str, photons: int, width: int, height: int, reference_spp: int, reference_max_spp: int,
               target_rel_se: float, progress: Callable[[str], None] | None, backend: str) -> dict[str, Any]:
    from ..kernels import build_kernel, default_grid
    from ..materials import Material, get_material
    from ..pipeline.regions import compare_regions
    from ..profiles import profile_for_material
    from ..sampling.taps import make_taps
    from ..scenes import render_gbuffer, render_reference
    from ..screenspace import separable_sss
    from ..truth import exact_screen_space

    say = progress or (lambda msg: None)
    homogeneous = get_material(material)
    assert isinstance(homogeneous, Material), "the slab edge needs a homogeneous material"
    mat = dataclasses.replace(homogeneous, eta=1.0)
    say(f"slab edge: Monte Carlo profile of {mat.name} at eta = 1 ({photons:,} photons per channel)")
    prof = profile_for_material(mat, "montecarlo", photons=photons)
    cell, n = default_grid(prof)
    taps = make_taps(build_kernel("preintegrated", prof, cell, n), 7, "importance")
    gb = render_gbuffer("slab", np.clip(prof.total_rd(), 0, 1), eta=1.0, width=width, height=height, spp=16,
                        material=mat.name)
    sss = separable_sss(gb, taps, PassSettings(jitter=0.0, backend=backend))
    exact = exact_screen_space(gb, prof)
    say(f"slab edge: path tracing (index-matched, {reference_spp} to {reference_max_spp} spp)")
    ref = render_reference("slab", mat, width=width, height=height, spp=reference_spp, max_spp=reference_max_spp,
                           target_rel_se=target_rel_se, boundary="index-matched", progress=progress is not None)
    table = compare_regions(gb, prof, sss, exact, ref)
    shape = table["edge_shape"]
    # the reference profile's standard error (per column, normalised by its plateau)
    from ..metrics import edge_profile, region_level

    cols = np.arange(shape["columns"][0], shape["columns"][1] + 1)
    region = np.zeros(gb.mask.shape, bool)
    region[:, cols] = True
    plateau = table["regions"]["plateau"]
    e = gb.diffuse.astype(float)
    lev = np.asarray(plateau["path_traced"]["level"]) * e[region_mask(table, gb)].mean(axis=0)
    _, se = edge_profile(np.asarray(ref.image, float) - gb.specular, region, lev, ref.pixel_se)
    assert se is not None  # the reference's pixel standard errors were given
    return {"material": mat.name, "shape": shape, "plateau": plateau, "reference": ref.summary(),
            "reference_profile_se": se[cols].tolist(), "pixel_mm": table["pixel_mm"],
            "radius_px": table["radius_px"], "profile_total_rd": prof.total_rd().tolist(),
            "region_level": region_level(np.asarray(ref.image, float), e, region)["level"]}


def region_mask(table: dict[str, Any], gb: GBuffer) -> np.ndarray:
    """The plateau mask of a region table's frame (recomputed from the G-buffer and the table's reach)."""
    from ..metrics import region_masks

    return region_masks(gb.diffuse, gb.mask, table["radius_px"])["plateau"]


#: the head's separable-paper numbers the demo opens with: the ``separable`` part of docs/head_numbers.json
#: (``python docs/head_numbers.py --sections separable``, 220 s on 2 cores with the path traces cached, each
#: ~6 min per view), shipped with the package so an installed ssskit shows them (:func:`ship_head_numbers`)
HEAD_NUMBERS = Path(__file__).resolve().parents[1] / "scenes" / "data" / "head_separable.json"


def ship_head_numbers(source: Path | None = None, target: Path = HEAD_NUMBERS) -> dict[str, Any]:
    """Copy the ``separable`` part of the repository's docs/head_numbers.json (``source``) to the package's
    :data:`HEAD_NUMBERS` (run after ``docs/head_numbers.py``; a test checks the two agree); returns it."""
    import json

    from ..io import write_text

    source = source or Path(__file__).resolve().parents[3] / "docs" / "head_numbers.json"
    part = json.loads(source.read_text(encoding="utf-8"))["separable"]
    write_text(target, json.dumps(part, indent=1) + "\n")
    return part


def head_opener(out: Path, kernel: str, taps: int = 7, width: int = 192, height: int = 144,
                backend: str = DEFAULT_BACKEND, progress: Callable[[str], None] | None = None
                ) -> tuple[Path, dict[str, Any]]:
    """The demo's first figure: the built-in head (Skin1, the front view) rendered now by the separable pass with
    ``kernel`` (``taps`` importance-sampled taps of the Monte Carlo profile), beside that kernel's region levels
    over the converged path trace's, ±2 standard errors, per view and region, from the shipped numbers
    (:data:`HEAD_NUMBERS`: the path traces take ~6 min per view on 2 cores, too long for the demo). Written to
    ``head.png``; returns (path, {"rows": the kernel's shipped rows, "shipped": the file's figure, size, taps,
    attribution}); rows is empty when the shipped numbers have no row for ``kernel``."""
    import json

    from ..kernels import build_kernel, default_grid, parse_method_spec
    from ..materials import get_material
    from ..profiles import profile_for_material
    from ..sampling.taps import make_taps
    from ..screenspace import separable_sss
    from ..settings import HEAD_ATTRIBUTION
    from .head import head_view

    say = progress or (lambda msg: None)
    shipped = json.loads(HEAD_NUMBERS.read_text(encoding="utf-8"))
    rows = [r for r in shipped["rows"] if r["kernel"] == kernel and r.get("regions")]
    say(f"the head: its front G-buffer, {width}x{height} (Mitsuba), and the separable pass with {kernel}")
    prof = profile_for_material(get_material("skin1"), "montecarlo")
    cell, n = default_grid(prof)
    method, params, label = parse_method_spec(kernel)
    tp = make_taps(build_kernel(method.name, prof, cell, n, **params), taps)
    gb = head_view("front", "skin1", width, height, spp=32).gbuffer
    gb = dataclasses.replace(gb, albedo=np.where(gb.mask[..., None], np.clip(prof.total_rd(), 0, 1),
                                                 gb.albedo).astype(np.float32))
    image = gb.composite(separable_sss(gb, {1: tp}, PassSettings(backend=backend)))
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.6), gridspec_kw={"width_ratios": [1, 1.25]})
    left.imshow(tonemap(image, float(np.percentile(image[gb.mask], 99.5)) or 1.0))
    left.set_title(f"Skin1 on the head, the separable pass with {label}, {tp.taps} taps (rendered now)", fontsize=9)
    left.axis("off")
    labels, k = [], 0
    for row in rows:
        for region, r in row["regions"].items():
            level, ref, se = (np.asarray(r[key], float) for key in ("screen_space", "path_traced", "path_traced_se"))
            for c in range(3):
                ratio = level[c] / ref[c]
                right.errorbar(k + (c - 1) * 0.22, ratio, yerr=2 * ratio * se[c] / ref[c], fmt="o",
                               color=CHANNEL_COLORS[c], ms=5, capsize=3)
            labels.append(f"{row['view']}\n{region.replace('_', ' ')}\n{r['pixels']} px")
            k += 1
    right.axhline(1.0, color="0.3", lw=1)
    right.set_xticks(range(len(labels)), labels, fontsize=7)
    right.set_ylabel("kernel's level / path traced (R, G, B; ± 2 SE)")
    right.set_title("1 = the path-traced truth: a point whose bar crosses 1 agrees within its noise\n"
                    f"(shipped numbers: {shipped['size'][0]}x{shipped['size'][1]} path traces, docs/head_numbers.json)",
                    fontsize=9)
    right.grid(alpha=0.3, axis="y")
    fig.suptitle(HEAD_ATTRIBUTION, fontsize=8, y=0.02)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    path = Path(out) / "head.png"
    save_figure(fig, path)
    return path, {"rows": rows, "figure": shipped["figure"], "size": shipped["size"], "taps": shipped["taps"],
                  "attribution": shipped.get("attribution", HEAD_ATTRIBUTION)}
