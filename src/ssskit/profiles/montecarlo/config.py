"""What determines one MCML simulation: its layers, radial grid, photon count, seed and batches,
and the supplement's settings for a material (separable-SSS supplement, section F).

Supplement F: 10^7 photons per channel; grid spacing dr = min(MFP_rgb) / 20; nr = ceil(32
max(MFP_rgb) / dr) radial bins; semi-infinite medium (10^7 cm); MFP = 1 / (sigma_a + sigma_s').

Everything here is plain data: no engine is imported. :func:`layer_arrays` lays a configuration
out as the arrays both engines (:mod:`.engine_numba`, :mod:`.engine_numpy`) take.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass

import numpy as np

from ...errors import ProfileError
from ...settings import DEFAULT_PHOTONS  # supplement F's 10^7, re-exported here
from ...materials import CHANNELS, LayeredMaterial, Material
from ...quantities import ANISOTROPY, COEFFICIENT, ETA, EXTINCTION, LENGTH_MM, SEED, THICKNESS_MM, Choice, Quantity

#: a layer's fields and a simulation's numbers, each declared once as a quantity (checked in a loop)
LAYER_FIELDS = {"sigma_a": COEFFICIENT, "sigma_s": COEFFICIENT, "g": ANISOTROPY, "eta": ETA,
                "thickness_mm": THICKNESS_MM}
LAYER_COUNT = Quantity("layers", 1, math.inf, "", "a simulation's layers, top first", integer=True, hi_open=True)
CONFIG_FIELDS = {
    "dr_mm": Quantity("grid spacing dr_mm", 0.0, math.inf, "mm", "the radial grid's spacing", lo_open=True,
                      hi_open=True),
    "nr": Quantity("radial bins nr", 2, math.inf, "", "the last bin collects the light beyond the grid", integer=True,
                   hi_open=True),
    "photons": Quantity("photon count", 1, math.inf, "", "photons per channel", integer=True, hi_open=True),
    "seed": SEED.within(hi=2**63 - 1, reason="numpy's seed sequence takes 63 bits"),
    "batch_size": Quantity("batch size", 1, math.inf, "", "photons per batch", integer=True, hi_open=True),
    "eta_above": Quantity("eta_above", 1.0, math.inf, "", ETA.reason, hi_open=True),
    "eta_below": Quantity("eta_below", 1.0, math.inf, "", ETA.reason, hi_open=True),
    "incidence_deg": Quantity("incidence angle", 0.0, 90.0, "degrees", "a beam from above the surface",
                              hi_open=True),
    "roughness": Quantity("surface roughness (Beckmann alpha)", 0.0, 1.0, "", "0 is a smooth surface")}

#: bump when the transport or the tallies change: it is part of every cache key
#: (2: the exit-direction tally, totals of shape (batches, 3 + N_EXIT_BINS); 3: photons traced in float32
#: lanes with one xoshiro128+ stream per lane, other random numbers). The transmitted light's radial and
#: exit-direction tallies (Tt_r, Tt_a) came without a bump: the transport and its random numbers are the same,
#: and :mod:`.run` reads a finished result stored before them (a finite slab's is simulated again)
ENGINE_VERSION = 3
#: bins of the exit-direction tally, uniform in cos^2 of the exit angle outside the medium (each
#: bin holds the same projected solid angle pi / N_EXIT_BINS); the last one is within 12.9 degrees of
#: the normal
N_EXIT_BINS = 20
DEFAULT_BATCH = 10_000


@dataclass(frozen=True)
class MCLayer:
    """One layer of one channel: coefficients in mm^-1, thickness in mm (inf: semi-infinite)."""

    sigma_a: float
    sigma_s: float
    g: float = 0.0
    eta: float = 1.3
    thickness_mm: float = math.inf

    def __post_init__(self) -> None:
        for name, q in LAYER_FIELDS.items():
            q.check(getattr(self, name), f"layer {name}", ProfileError)
        EXTINCTION.check(self.sigma_a + self.sigma_s, "layer sigma_a + sigma_s", ProfileError)


@dataclass(frozen=True)
class MCConfig:
    """Everything that determines a simulation's result (and its cache key).

    ``layers`` top first (only the last may be semi-infinite); radial grid of ``nr`` bins of
    ``dr_mm``; ``photons`` split into batches of ``batch_size`` (the last one shorter), each batch
    its own random stream derived from ``seed``; ambient indices ``eta_above`` / ``eta_below``;
    ``roughness``: Beckmann alpha of the top surface, 0 for MCML's smooth Fresnel boundary, > 0 for
    the single-scattering rough dielectric of Mitsuba 3's ``roughdielectric`` (Walter et al. 2007;
    :func:`~ssskit.profiles.montecarlo.engine_numba._rough_interface`), the path-traced references'
    boundary (:data:`ssskit.scenes.scenes.COAT_ROUGHNESS`).
    """

    layers: tuple[MCLayer, ...]
    dr_mm: float
    nr: int
    photons: int = DEFAULT_PHOTONS
    seed: int = 1
    eta_above: float = 1.0
    eta_below: float = 1.0
    batch_size: int = DEFAULT_BATCH
    incidence_deg: float = 0.0
    roughness: float = 0.0

    def __post_init__(self) -> None:
        LAYER_COUNT.check(len(self.layers), error=ProfileError)
        for k, layer in enumerate(self.layers[:-1]):
            LENGTH_MM.within(reason="only the last layer may be semi-infinite").check(
                layer.thickness_mm, f"layer {k + 1} thickness_mm", ProfileError)
        for name, q in CONFIG_FIELDS.items():
            q.check(getattr(self, name), q.name, ProfileError)

    @property
    def n_batches(self) -> int:
        return -(-self.photons // self.batch_size)

    def batch_sizes(self) -> np.ndarray:
        """Photons per batch, shape (n_batches,): ``batch_size`` each, the last one the rest."""
        sizes = np.full(self.n_batches, self.batch_size, dtype=np.int64)
        sizes[-1] = self.photons - self.batch_size * (self.n_batches - 1)
        return sizes

    def key(self) -> str:
        """Hash of every input and the engine version (a smooth surface's key leaves ``roughness``
        out: its transport did not change when the option came, so its cached results stay valid)."""
        data = asdict(self)
        if self.roughness == 0:
            del data["roughness"]
        data["engine"] = ENGINE_VERSION
        text = json.dumps(data, sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:24]

    def specular_reflectance(self) -> float:
        """Rsp = ((n0 - n1) / (n0 + n1))^2 at normal incidence (MCML's Rspecular, no glass layer); at
        ``incidence_deg`` the unpolarised Fresnel reflectance (Born & Wolf, Eq. 1.5.21/22, averaged).
        The smooth surface's: a rough one's is estimated by the engine (``simulate``)."""
        n0, n1 = self.eta_above, self.layers[0].eta
        if self.incidence_deg == 0:
            return ((n0 - n1) / (n0 + n1)) ** 2
        ci, ct = self._cosines()
        rs = ((n0 * ci - n1 * ct) / (n0 * ci + n1 * ct)) ** 2
        rp = ((n1 * ci - n0 * ct) / (n1 * ci + n0 * ct)) ** 2
        return 0.5 * (rs + rp)

    def _cosines(self) -> tuple[float, float]:
        th = math.radians(self.incidence_deg)
        st = self.eta_above * math.sin(th) / self.layers[0].eta  # Snell's law; eta_above <= eta: no TIR
        return math.cos(th), math.sqrt(max(1.0 - st * st, 0.0))

    def launch_direction(self) -> tuple[float, float]:
        """(ux, uz) of the refracted beam inside the top layer (uy = 0): (0, 1) at normal incidence.
        With a rough top surface the beam outside, which the engine refracts through a microfacet."""
        if self.roughness > 0:
            th = math.radians(self.incidence_deg)
            return math.sin(th), math.cos(th)
        ct = self._cosines()[1]
        return math.sqrt(max(1.0 - ct * ct, 0.0)), ct


def layer_arrays(cfg: MCConfig) -> dict[str, np.ndarray]:
    """The layers of ``cfg`` as the arrays both engines take, each of shape (L + 2,).

    Layers are 1..L (top first): ``mua``, ``mus`` (mm^-1), ``g``, ``z_top``, ``z_bot`` (mm,
    z pointing into the medium); index 0 is the ambient medium above and L + 1 the one below, so
    ``n_idx`` holds ``eta_above``, the layers' indices, ``eta_below``. ``cos_crit_up`` /
    ``cos_crit_down`` are the cosines of the critical angles at each layer's top / bottom
    boundary, 0 where no total internal reflection is possible (MCML's CriticalAngle).
    """
    layers = cfg.layers
    n_l = len(layers)
    mua = np.zeros(n_l + 2)
    mus = np.zeros(n_l + 2)
    g = np.zeros(n_l + 2)
    z_top = np.zeros(n_l + 2)
    z_bot = np.zeros(n_l + 2)
    n_idx = np.zeros(n_l + 2)
    n_idx[0], n_idx[-1] = cfg.eta_above, cfg.eta_below
    z = 0.0
    for i, layer in enumerate(layers, start=1):
        mua[i], mus[i], g[i], n_idx[i] = layer.sigma_a, layer.sigma_s, layer.g, layer.eta
        z_top[i] = z
        z = z + layer.thickness_mm
        z_bot[i] = z
    up = np.zeros(n_l + 2)
    down = np.zeros(n_l + 2)
    for i in range(1, n_l + 1):
        n1 = n_idx[i]
        up[i] = math.sqrt(1.0 - (n_idx[i - 1] / n1) ** 2) if n1 > n_idx[i - 1] else 0.0
        down[i] = math.sqrt(1.0 - (n_idx[i + 1] / n1) ** 2) if n1 > n_idx[i + 1] else 0.0
    return dict(mua=mua, mus=mus, g=g, z_top=z_top, z_bot=z_bot, n_idx=n_idx, cos_crit_up=up, cos_crit_down=down)


def _layers_of(material: Material | LayeredMaterial) -> tuple[Material, ...]:
    return tuple(material.layers) if isinstance(material, LayeredMaterial) else (material,)


#: the supplement's grid reaches 32 reduced mean free paths (section F)
SUPPLEMENT_GRID_MFP = 32.0


#: a channel of a simulation, by name or by index (R, G, B = 0, 1, 2); the reach of its radial grid
CHANNEL = Choice("channel", CHANNELS)
CHANNEL_INDEX = Quantity("channel index", 0, 2, "", "R, G, B", integer=True)
GRID_EXTENT = Quantity("grid extent", 0.0, math.inf, "mean free paths", "the grid's reach", lo_open=True, hi_open=True)


def supplement_grid(material: Material | LayeredMaterial, extent_mfp: float = SUPPLEMENT_GRID_MFP) -> tuple[float, int]:
    """Supplement F's grid: dr = min(MFP_rgb) / 20, nr = ceil(32 max(MFP_rgb) / dr), MFP = 1/sigma_t'
    (over every layer of a layered material); ``extent_mfp`` replaces the 32 (a longer grid for
    materials whose light travels farther, :func:`~ssskit.profiles.montecarlo.simulate_material`'s
    ``grid_fraction``). Returns (dr in mm, nr), nr counting the regular bins and, as MCML's last bin,
    the one that collects every photon beyond them."""
    GRID_EXTENT.check(extent_mfp, error=ProfileError)
    mfp = [v for layer in _layers_of(material) for v in layer.mfp_reduced_mm]
    dr = min(mfp) / 20.0
    return dr, max(int(math.ceil(extent_mfp * max(mfp) / dr - 1e-9)), 2)


def channel_seed(seed: int, c: int) -> int:
    """Distinct, reproducible seeds per channel (the streams are further split per batch)."""
    return (int(seed) * 3 + c) % (2**63)


def config_for_material(material: Material | LayeredMaterial, channel: int | str, photons: int = DEFAULT_PHOTONS,
                        seed: int = 1, batch_size: int = DEFAULT_BATCH,
                        extent_mfp: float = SUPPLEMENT_GRID_MFP, roughness: float = 0.0) -> MCConfig:
    """The supplement's simulation of one channel (index 0-2 or 'R', 'G', 'B') of a material
    (``extent_mfp``: the grid's reach, :func:`supplement_grid`; ``roughness``: Beckmann alpha of
    the top surface, 0 for the supplement's smooth one, :class:`MCConfig`). The material must lie in
    the Monte Carlo model's domain (:func:`ssskit.profiles.domain.check_montecarlo`)."""
    from ..domain import check_montecarlo

    check_montecarlo(material)
    c = CHANNELS.index(CHANNEL.check(channel, error=ProfileError)) if isinstance(channel, str) else \
        CHANNEL_INDEX.check(channel, error=ProfileError)
    dr, nr = supplement_grid(material, extent_mfp)
    layers = tuple(MCLayer(m.sigma_a[c], m.sigma_s[c], m.g[c], m.eta, m.thickness_mm) for m in _layers_of(material))
    if isinstance(material, LayeredMaterial):
        above, below = material.eta_above, material.eta_below
    else:
        above = below = material.eta_ambient
    return MCConfig(layers, dr, nr, photons, seed, above, below, batch_size, roughness=roughness)


__all__ = ["DEFAULT_BATCH", "DEFAULT_PHOTONS", "ENGINE_VERSION", "channel_seed", "N_EXIT_BINS", "SUPPLEMENT_GRID_MFP", "MCConfig", "MCLayer", "config_for_material",
           "layer_arrays", "supplement_grid"]
