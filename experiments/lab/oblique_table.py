"""A flat medium lit at any incidence angle and seen at any exit angle: MCML's total diffuse
reflectance Rd(theta_i) of an oblique beam and its exit-direction radiance factor, tabulated over
theta_i and interpolated per pixel.

The screen-space model gives a lit pixel the radiance Rd(0) E / pi: the normal-incidence profile's
total reflectance and a Lambertian exit. A flat, semi-infinite medium lit by a beam at theta_i and
seen at exit cosine mu_v instead sends

    L = E / pi * Rd(theta_i) * f(theta_i, mu_v),

with E the irradiance on the surface (cos theta_i included), Rd(theta_i) MCML's total diffuse
reflectance of a beam launched at theta_i (Wang, Jacques & Zheng 1995, section 3.2 "launching a
photon packet", with the Fresnel specular reflectance at theta_i, Born & Wolf Eq. 1.5.21/22, taken off
the launched weight; :meth:`~ssskit.profiles.montecarlo.MCConfig.specular_reflectance`) and f the
radiance factor (:meth:`~ssskit.profiles.montecarlo.MCResult.radiance_factor`: radiance per
exit-direction bin relative to a Lambertian exit of the same total, from the exit-direction tally;
1 for a Lambertian exit). For an oblique beam the tally is an average over the exit azimuth: the
single-scattered light, which prefers the forward direction of the refracted beam, is spread over
all azimuths (a few percent of Rd for Skin1, more for the red channel's forward-peaked phase
function; isotropic scattering has none: Chandrasekhar 1950, Eq. IV.70, checked in
tests/profiles/test_montecarlo.py).

:func:`oblique_table` runs one simulation per angle and channel (cached like every MCML run);
:class:`ObliqueTable` interpolates Rd(theta_i) / Rd(0) linearly in cos theta_i and f linearly in
cos theta_i and in mu_v^2 (the tally's bins are uniform in mu_v^2; their centres are the nodes,
clamped beyond the first and the last centre).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ssskit.errors import ProfileError
from ssskit.materials import LayeredMaterial, Material
from ssskit.profiles.montecarlo.config import N_EXIT_BINS, config_for_material
from ssskit.profiles.montecarlo.run import simulate

#: incidence angles (degrees) of the default table: dense where cos theta_i changes fastest in the
#: quantities (grazing light), up to 89 degrees (MCML's launch needs theta_i < 90)
OBLIQUE_ANGLES_DEG = (0.0, 20.0, 35.0, 45.0, 55.0, 62.0, 68.0, 73.0, 77.0, 81.0, 85.0, 89.0)


@dataclass(frozen=True)
class ObliqueTable:
    """MCML's oblique-beam results of one material: ``angles_deg`` (A,) increasing from 0;
    ``rd`` / ``rd_se`` (3, A): total diffuse reflectance per channel and angle (MCML's Rd, all
    diffusely reflected light, the specular part excluded); ``radiance`` / ``radiance_se``
    (3, A, N_EXIT_BINS): the radiance factor per exit bin (bins uniform in mu_v^2, the last one
    nearest the normal); ``roughness``: the top surface's Beckmann alpha (0: smooth)."""

    angles_deg: np.ndarray
    rd: np.ndarray
    rd_se: np.ndarray
    radiance: np.ndarray
    radiance_se: np.ndarray
    eta: float
    photons: int
    roughness: float = 0.0

    def _weights(self, cos_i: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return cos_brackets(self.angles_deg, cos_i)

    def rd_at(self, cos_i) -> np.ndarray:
        """(3, ...) Rd at incidence cosines ``cos_i`` (linear in cos theta_i between the table's angles;
        beyond the last angle, its value)."""
        lo, hi, t = self._weights(cos_i)
        return self.rd[:, lo] * (1.0 - t) + self.rd[:, hi] * t

    def rd_rel_se(self, cos_i) -> np.ndarray:
        """(3, ...) the relative standard error of :meth:`rd_at` (the nodes' relative errors with the
        interpolation's weights, added linearly: an upper bound)."""
        lo, hi, t = self._weights(cos_i)
        rel = self.rd_se / self.rd
        return rel[:, lo] * (1.0 - t) + rel[:, hi] * t

    def rd_ratio(self, cos_i) -> np.ndarray:
        """(3, ...) Rd(theta_i) / Rd(0): how much more (or less) light a flat medium returns of a beam
        at theta_i than of one along the normal, per unit irradiance."""
        ratio = self.rd_at(cos_i)
        return ratio / self.rd[:, 0].reshape((3,) + (1,) * (ratio.ndim - 1))

    def radiance_factor(self, cos_i, cos_v) -> np.ndarray:
        """(3, ...) the radiance factor f(theta_i, mu_v) (module docstring), bilinear in (cos theta_i,
        mu_v^2) between the table's angles and the exit bins' centres."""
        return self._bilinear(self.radiance, cos_i, cos_v)

    def radiance_factor_se(self, cos_i, cos_v) -> np.ndarray:
        """(3, ...) the standard errors of the four exit bins :meth:`radiance_factor` uses, with its
        weights (added linearly: an upper bound of the interpolated value's error)."""
        return self._bilinear(self.radiance_se, cos_i, cos_v)

    def _bilinear(self, values: np.ndarray, cos_i, cos_v) -> np.ndarray:
        lo, hi, t = self._weights(cos_i)
        centres = (np.arange(N_EXIT_BINS) + 0.5) / N_EXIT_BINS
        m2 = np.clip(np.asarray(cos_v, float) ** 2, centres[0], centres[-1])
        k = np.clip(np.searchsorted(centres, m2, side="right") - 1, 0, N_EXIT_BINS - 2)
        s = (m2 - centres[k]) / (centres[k + 1] - centres[k])

        def at(ai):
            return values[:, ai, k] * (1.0 - s) + values[:, ai, k + 1] * s

        return at(lo) * (1.0 - t) + at(hi) * t

    def exit_radiance(self, cos_i, cos_v) -> np.ndarray:
        """(3, ...) Rd(theta_i) f(theta_i, mu_v): the flat medium's radiance per unit E / pi."""
        return self.rd_at(cos_i) * self.radiance_factor(cos_i, cos_v)

    def to_dict(self) -> dict:
        return {"angles_deg": self.angles_deg.tolist(), "eta": self.eta, "photons": self.photons,
                "roughness": self.roughness,
                "Rd": self.rd.tolist(), "Rd_se": self.rd_se.tolist(),
                "Rd_ratio": (self.rd / self.rd[:, :1]).tolist()}


def oblique_table(material: Material | LayeredMaterial, angles_deg: Sequence[float] = OBLIQUE_ANGLES_DEG,
                  photons: int = 1_000_000, seed: int = 21, threads: int | None = None,
                  roughness: float = 0.0) -> ObliqueTable:
    """MCML (the supplement's grid for the material, :func:`config_for_material`) with the beam at each
    of ``angles_deg`` (the first must be 0, increasing, each < 90), ``photons`` per channel and angle;
    every run cached (:func:`simulate`). ``roughness``: Beckmann alpha of the top surface (0: MCML's
    smooth Fresnel boundary; > 0: the references' single-scattering rough dielectric,
    :class:`~ssskit.profiles.montecarlo.MCConfig`)."""
    angles = np.asarray([float(a) for a in angles_deg])
    if angles.size < 2 or angles[0] != 0.0 or np.any(np.diff(angles) <= 0) or angles[-1] >= 90.0:
        raise ProfileError("incidence angles must start at 0, increase and stay below 90 degrees, "
                           f"got {list(angles_deg)!r}")
    if isinstance(photons, bool) or not (isinstance(photons, int) and photons >= 2 * 10_000):
        raise ProfileError(f"photons must be an integer of at least two batches (20000), got {photons!r}")
    rd = np.empty((3, angles.size))
    rd_se = np.empty_like(rd)
    rad = np.empty((3, angles.size, N_EXIT_BINS))
    rad_se = np.empty_like(rad)
    for c in range(3):
        base = config_for_material(material, c, photons=photons, seed=seed, roughness=roughness)
        for a, ang in enumerate(angles):
            res = simulate(dataclasses.replace(base, incidence_deg=float(ang)), threads=threads)
            rd[c, a], rd_se[c, a] = res.total_rd, res.total_rd_se
            rad[c, a] = res.radiance_factor()
            rad_se[c, a] = N_EXIT_BINS * res.exit_rd_se / res.total_rd
    eta = float(material.layers[0].eta if isinstance(material, LayeredMaterial) else material.eta)
    return ObliqueTable(angles, rd, rd_se, rad, rad_se, eta, photons, float(roughness))


def cos_brackets(angles_deg, cos_i) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear interpolation in cos theta between ``angles_deg`` (increasing from 0) at ``cos_i``:
    indices (lo, hi) into ``angles_deg`` of the two angles around each cos theta_i and the weight of
    hi (1 - that of lo); beyond the first and the last angle, that angle's value."""
    angles = np.asarray(angles_deg, float)
    nodes = np.cos(np.radians(angles))[::-1]  # increasing cosines
    c = np.clip(np.asarray(cos_i, float), nodes[0], nodes[-1])
    j = np.clip(np.searchsorted(nodes, c, side="right") - 1, 0, nodes.size - 2)
    t = (c - nodes[j]) / (nodes[j + 1] - nodes[j])
    a = angles.size - 1
    return a - j, a - (j + 1), t  # back to indices of angles_deg (decreasing cos)


def incidence_cosines(points: np.ndarray, normals: np.ndarray, light: Sequence[float]) -> np.ndarray:
    """(...,) cos theta_i = n . (light - p) / |light - p| of a point light at ``light`` on surface
    points ``points`` (..., 3) with unit normals ``normals`` (..., 3), clipped to [0, 1] (0: the light
    is below the surface's horizon)."""
    d = np.asarray(light, float) - np.asarray(points, float)
    n = np.asarray(normals, float)
    cos = np.sum(n * d, axis=-1) / np.maximum(np.linalg.norm(d, axis=-1) * np.linalg.norm(n, axis=-1), 1e-300)
    return np.clip(cos, 0.0, 1.0)


def fresnel_transmittance(cos_i, eta: float) -> np.ndarray:
    """1 - R of unpolarised light entering a smooth boundary from index 1 into ``eta`` at cos theta_i
    (Born & Wolf, Eq. 1.5.21/22, averaged over s and p)."""
    ci = np.clip(np.asarray(cos_i, float), 1e-12, 1.0)
    st = np.sqrt(np.maximum(1.0 - ci * ci, 0.0)) / eta
    ct = np.sqrt(np.maximum(1.0 - st * st, 0.0))
    rs = ((ci - eta * ct) / (ci + eta * ct)) ** 2
    rp = ((eta * ci - ct) / (eta * ci + ct)) ** 2
    return 1.0 - 0.5 * (rs + rp)


__all__ = ["OBLIQUE_ANGLES_DEG", "ObliqueTable", "cos_brackets", "fresnel_transmittance", "incidence_cosines", "oblique_table"]

