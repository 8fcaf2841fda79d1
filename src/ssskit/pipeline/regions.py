"""The region-wise comparison of one rendered frame with its ground truths.

Diffuse parts only (the G-buffer's specular layer subtracted on every side: the same rough
dielectric reflection), divided by the white diffuse layer E / pi, per region of
:func:`ssskit.metrics.region_masks` (lit plateau, shadow-edge band, terminator, silhouette):

* the **level** of each region (mean diffuse part / mean E / pi: the effective albedo there) of the
  screen-space pass, the exact 2D convolution with the same profile, and the path-traced reference
  with its standard error;
* the **shape** across a straight shadow edge (the slab scene): the column profile across the edge
  divided by each image's own plateau level, compared as RMSE with the reference's noise floor.

The exact 2D convolution sits between the two: screen space vs exact is the kernel's (and the
pass's) error, exact vs reference the screen-space model's (a flat, infinitely thick medium lit
from the front, whose light leaves like a Lambertian surface of albedo Rd) error against the light
transport itself.
"""

from __future__ import annotations

from typing import Any

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from ..profiles.base import RGBProfile
    from ..scenes.reference import Reference
    from ..screenspace.gbuffer import GBuffer

from ..metrics import REGIONS, edge_profile, profile_rmse, region_level, region_masks


def pixel_mm(gbuffer: GBuffer) -> float:
    """The size of a pixel (mm) at the SSS objects' median depth: depth / fx."""
    cam = gbuffer.camera
    depth = float(np.median(gbuffer.depth[gbuffer.mask]))
    return depth / cam.fx / cam.world_units_per_mm


def _ratio(a: ArrayLike, b: ArrayLike, b_se: ArrayLike | None = None) -> tuple[Any, list[float] | None]:
    a, b = np.asarray(a, float), np.asarray(b, float)
    r = a / b
    se = None if b_se is None else (np.abs(r) * np.asarray(b_se, float) / np.abs(b)).tolist()
    return r.tolist(), se


def compare_regions(gbuffer: GBuffer, profile: RGBProfile, sss: np.ndarray, exact: np.ndarray | None,
                    reference: Reference | None = None,
                    fraction: float = 0.99) -> dict[str, Any]:
    """The region table and the edge shape of one frame (module docstring). ``sss``: the pass's blurred
    diffuse layer; ``exact``: the exact 2D convolution's (or None); ``reference``: a
    :class:`ssskit.scenes.Reference` (or None). The regions reach the profile's ``fraction`` radius."""
    gb = gbuffer
    mask = gb.mask
    e = gb.diffuse.astype(np.float64)
    assert gb.specular is not None, "the region comparison needs the G-buffer's specular layer"
    spec = gb.specular.astype(np.float64)
    px = pixel_mm(gb)
    radius_px = float(np.max(profile.radius_at_fraction(fraction))) / px
    masks = region_masks(e, mask, radius_px)
    parts = {"screen_space": gb.albedo * sss}
    if exact is not None:
        parts["exact_2d"] = gb.albedo * exact
    ref_se = None
    if reference is not None:
        parts["path_traced"] = np.asarray(reference.image, np.float64) - spec
        ref_se = np.asarray(reference.pixel_se, np.float64)
    out: dict[str, Any] = {"radius_px": radius_px, "pixel_mm": px, "regions": {}}
    for name in REGIONS:
        region = masks[name]
        row: dict[str, Any] = {"pixels": int(region.sum())}
        for key, part in parts.items():
            row[key] = region_level(part, e, region, ref_se if key == "path_traced" else None)
        if region.any() and "path_traced" in row:
            ref = row["path_traced"]
            for key in ("screen_space", "exact_2d"):
                if key in row:
                    r, se = _ratio(row[key]["level"], ref["level"], ref["se"])
                    row[f"{key}_vs_path_traced"] = {"ratio": r, "se": se}
        out["regions"][name] = row
    shape = _edge_shape(masks, parts, e, ref_se)
    if shape is not None:
        out["edge_shape"] = shape
    return out


def _edge_shape(masks: dict[str, np.ndarray], parts: dict[str, np.ndarray], e: np.ndarray,
                ref_se: np.ndarray | None) -> dict[str, Any] | None:
    """The normalised profile across a straight vertical shadow edge (the slab's), or None if the frame
    has none: the edge band's pixels must lie in a few columns' reach of one column."""
    band, plateau = masks["shadow_edge"], masks["plateau"]
    if not (band.any() and plateau.any()):
        return None
    cols = np.flatnonzero(band.any(axis=0))
    rows = band.any(axis=1)
    # a straight vertical edge: every band row spans the same columns
    if not np.all(band[rows][:, cols]):
        return None
    region = np.zeros_like(band)
    region[np.ix_(rows, cols)] = True
    profiles, ses = {}, {}
    for key, part in parts.items():
        level = region_level(part, e, plateau)["level"]
        ebar = e[plateau].mean(axis=0)
        lev = np.asarray(level) * ebar  # the plateau's diffuse radiance
        prof, se = edge_profile(part, region, lev, ref_se if key == "path_traced" else None)
        profiles[key] = prof[cols]
        if se is not None:
            ses[key] = se[cols]
    out: dict[str, Any] = {"columns": [int(cols[0]), int(cols[-1])], "rows": int(rows.sum()),
                           "profiles": {k: v.tolist() for k, v in profiles.items()}}
    pairs = [("screen_space", "exact_2d"), ("exact_2d", "path_traced"), ("screen_space", "path_traced")]
    for a, b in pairs:
        if a in profiles and b in profiles:
            out[f"rmse_{a}_vs_{b}"] = profile_rmse(profiles[a], profiles[b], ses.get(b))
    return out


def format_regions(table: dict[str, Any] | None) -> list[str]:
    """Text lines of :func:`compare_regions`' table: per region its level (R, G, B) per image, the
    reference's with its standard error, and the edge shape's RMSEs; a table whose regions are all empty
    (no lit level inside the SSS mask, :func:`ssskit.metrics.region_masks`: a frame lit from behind) is one line
    with that reason."""
    if not table:
        return []
    if not any(row["pixels"] for row in table["regions"].values()):
        return ["# regions: none (they are cut from the front light E/pi's lit level, its 98th percentile inside the "
                "SSS mask, which is 0: the frame is lit from behind)"]
    fmt = lambda v: ", ".join("nan" if v is None or v != v else f"{x:.4f}" for x in v)  # noqa: E731
    lines = [f"# regions (level = mean diffuse part / mean E/pi; reach {table['radius_px']:.1f} px)"]
    for name, row in table["regions"].items():
        if not row["pixels"]:
            continue
        parts = [f"{key} {fmt(row[key]['level'])}" for key in ("screen_space", "exact_2d") if key in row]
        if "path_traced" in row:
            ref = row["path_traced"]
            parts.append(f"path_traced {fmt(ref['level'])} ± {fmt(ref['se'])}")
        lines.append(f"{name:12s} {row['pixels']:6d} px  " + "  ".join(parts))
    shape = table.get("edge_shape")
    if shape:
        for key, val in shape.items():
            if key.startswith("rmse_"):
                lines.append(f"edge shape {key[5:]}: RMSE {val['rmse']:.4f} ± {val['rmse_se']:.4f} "
                             f"(reference noise {val['noise']:.4f}{'' if val['resolved'] else ', not resolved'})")
    return lines


__all__ = ["compare_regions", "format_regions", "pixel_mm"]
