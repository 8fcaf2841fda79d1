"""Paper Eq. 1 over the seen surface instead of the image plane (:func:`surface_convolution`): the
control of the attribution's curvature and grazing-view experiments (:mod:`lab.attribution`), which
asks how much of a region's difference is the image-plane model itself."""

from __future__ import annotations

import math

import numpy as np

from ssskit.errors import SignalError


def surface_convolution(gbuffer, profile, fraction: float = 0.999, min_cos: float = 0.1) -> np.ndarray:
    """Paper Eq. 1 taken over the seen surface instead of the image plane: the diffuse part (H, W, 3)

        L_i = Rd / N_i * sum_j (E_j / pi) R(|x_i - x_j|) A_j

    with x the pixels' 3D surface points (from depth), R the profile (mm^-2) at their Euclidean
    distance, and A_j = (pixel size at depth z_j)^2 / max(cos theta_j, ``min_cos``) the surface area
    a pixel covers (theta_j: the angle between the normal and the view direction), over the pixels
    of the same SSS region within the largest channel's ``fraction`` radius: the kernel in world
    space, as section 6 of the separable-SSS paper sizes it by the pixel's projected area, and as
    [JMLH01]'s BSSRDF integrates over the surface (here without its Fresnel factors). N_i is the same
    sum for a uniformly lit fronto-parallel plane through x_i (every offset, cos = 1), so that the
    discretisation (R is steep near r = 0; each pixel's own term is the profile's energy within the
    disk of its area, the others point evaluations) cancels: on a flat, face-on, uniformly lit
    surface L = Rd E / pi exactly, like ``albedo * exact_screen_space``, which it is compared with.

    What it adds to :func:`exact_screen_space`: the light that enters where the surface turns away
    from the camera (a pixel there covers up to 1 / ``min_cos`` times its fronto-parallel area), true
    3D distances across depth steps and curved surfaces, and no light from beyond the silhouette (the
    image model's boundary rule lends the centre value there; off the image both take the pixel's own
    level). What it leaves out like the image
    model: light entering the surface the camera does not see, Fresnel, the non-Lambertian exit.
    Pixels without SSS are 0. O(pixels x kernel pixels).
    """
    from collections.abc import Mapping

    if not (0 < min_cos <= 1):
        raise SignalError(f"min_cos must lie in (0, 1], got {min_cos!r}")
    gb = gbuffer
    cam = gb.camera
    e_full = gb.diffuse.astype(np.float64)
    out = np.zeros_like(e_full)
    finite = np.isfinite(gb.depth)
    pos_full, cos_full = gb.positions(), gb.view_cosine()
    ids = [int(i) for i in np.unique(gb.profile_id[gb.profile_id > 0])]
    for pid in ids:
        prof = profile.get(pid) if isinstance(profile, Mapping) else profile
        if prof is None:
            raise SignalError(f"no profile given for profile id {pid}")
        m_full = (gb.profile_id == pid) & finite
        ys, xs = np.nonzero(m_full)
        win = (slice(ys.min(), ys.max() + 1), slice(xs.min(), xs.max() + 1))
        m, e = m_full[win], e_full[win]
        z = np.where(m, gb.depth[win], 1.0).astype(np.float64)
        pos, cos = pos_full[win], cos_full[win]  # the window's surface points and view cosines
        px_mm = z / cam.fx / cam.world_units_per_mm
        area = px_mm**2 / np.maximum(cos, min_cos)
        radius = float(np.max(prof.radius_at_fraction(fraction)))
        h, w = m.shape
        hh, ww = gb.shape
        rows, cols = np.arange(win[0].start, win[0].stop), np.arange(win[1].start, win[1].stop)
        half = int(min(np.ceil(radius / float(np.min(px_mm[m]))), max(h, w)))
        src = np.where(m[..., None], e * area[..., None], 0.0)  # E_j / pi * A_j
        own = lambda a: np.stack([c.energy_within(np.sqrt(a / np.pi)) for c in prof.channels], axis=-1)  # noqa: E731
        acc = e * own(area)
        norm = own(px_mm**2)
        wpos = np.pad(pos, ((half, half), (half, half), (0, 0)))
        wsrc = np.pad(src, ((half, half), (half, half), (0, 0)))
        for dy in range(-half, half + 1):
            for dx in range(-half, half + 1):
                if (dy or dx) and dy * dy + dx * dx <= half * half:
                    p = wpos[half + dy:half + dy + h, half + dx:half + dx + w]
                    s = wsrc[half + dy:half + dy + h, half + dx:half + dx + w]
                    acc += s * prof.eval(np.linalg.norm(p - pos, axis=-1))
                    # off the image nothing is known: left out of the plane's sum too (the image
                    # model's rule: the missing light is the pixel's own level)
                    inside = (((rows + dy >= 0) & (rows + dy < hh))[:, None]
                              & ((cols + dx >= 0) & (cols + dx < ww))[None, :])
                    norm += prof.eval(math.hypot(dy, dx) * px_mm) * (inside * px_mm**2)[..., None]
        res = acc * np.asarray(prof.total_rd()) / norm
        out[win][m] = res[m]
    return out.astype(np.float32)


__all__ = ["surface_convolution"]
