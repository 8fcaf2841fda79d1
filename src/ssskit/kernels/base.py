"""One kernel type for every separable approximation, plus the engines' tap kernels.

A :class:`Kernel` is a signed rank-N sum of separable terms per RGB channel,

    A_c(x, y) = sum_i s_ci a_ci(x) a_ci(y)          (separable-SSS paper, Eq. 2)

with each 1D function a_ci tabulated on a uniform grid of cell centres x_mm (odd length, the
origin at the centre cell). The tabulated values are **cell averages** in mm^-1, so a_ci * h is
the energy weight of a cell of width h and the 2D cell weights are sum_i s_i (a_i h)(a_i h)^T,
directly comparable with :meth:`RGBProfile.discretize_2d` on the same grid. Signs s_ci = +-1
let SVD / eigen terms with negative eigenvalues and residual corrections be represented exactly.

A :class:`TapKernel` is what engines ship: a list of 1D tap offsets (mm) and RGB weights, centre
tap first; :meth:`TapKernel.to_kernel` deposits it onto a grid (linear interpolation, as the GPU's
bilinear fetches do) so it can be compared and convolved like every other kernel.
"""

from __future__ import annotations

import dataclasses
import math
import io
import json
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import KernelError
from ..io import atomic_output, check_suffix
from ..profiles.base import RGBProfile
from ..profiles.discretize import check_grid, grid_coordinates
from ..quantities import KERNEL_CELLS, POSITIVE, Quantity, check_keys, check_shape

CHANNELS = ("R", "G", "B")

#: the largest rank of an SVD kernel (svd, svd_l1) and of preintegrated_svd's residual, for the API and the
#: method specs alike (``svd:N``); each needs 2 N 1D convolutions, and the grid (n cells) bounds it too
MAX_SVD_RANK = 64
#: the rank of an SVD kernel (and of preintegrated_svd's residual): 1 to MAX_SVD_RANK, and at most the grid's cells
SVD_RANK = Quantity("SVD rank", 1, MAX_SVD_RANK, "", "terms of the truncated SVD, each two 1D convolutions",
                    integer=True)


#: taps of a tap kernel (:class:`TapKernel`; the centre first)
TAP_COUNT = Quantity("taps", 1, math.inf, "", "a tap kernel's offsets and weights, the centre first", integer=True,
                     hi_open=True)


#: a kernel's grid: at least 3 cells (:func:`~ssskit.profiles.discretize.check_grid`)
_check_grid = partial(check_grid, error=KernelError, what="kernel ", cells=KERNEL_CELLS)


def per_channel(value: ArrayLike, what: str, q: Quantity) -> NDArray[np.float64]:
    """``value`` (one number or three) as a (3,) array, R, G, B, each in ``q``'s range (finite), or a KernelError
    naming ``what``: a kernel's scale factors, the engine kernel's strength and falloff."""
    return q.check_array(np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy(), what, KernelError, "channels")


def default_grid(profile: RGBProfile, n: int = 201, fraction: float = 0.999) -> tuple[float, int]:
    """(cell_mm, n): an n-cell grid whose half-width is the largest channel radius holding ``fraction``.

    For a profile with a finite domain (binned Monte Carlo), the radius is capped by the domain.
    """
    _check_grid(1.0, n)
    radius = POSITIVE.check(np.max(profile.radius_at_fraction(fraction)), f"a kernel grid's radius (holding {fraction} "
                            "of the profile's energy)", KernelError)
    return 2.0 * radius / n, int(n)


def _cumulative_edges(values: np.ndarray, cell_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Cell-edge coordinates and the running integral of piecewise-constant cell averages."""
    n = values.shape[-1]
    edges = (np.arange(n + 1) - n / 2.0) * cell_mm
    cum = np.concatenate([np.zeros(values.shape[:-1] + (1,)), np.cumsum(values * cell_mm, axis=-1)], axis=-1)
    return edges, cum


@dataclass(frozen=True, eq=False)
class Kernel:
    """A signed rank-N separable kernel per channel (see the module docstring).

    ``components``: (3, N, n) cell averages of a_ci in mm^-1; ``signs``: (3, N) of +-1;
    ``cell_mm``: grid spacing; ``method``/``params``: how it was made; ``source``: the profile
    it approximates (model, name, provenance); ``depth_sigma_mm``: the width of the depth
    correction exp(-d_z^2 / (2 depth_sigma_mm^2)) that the screen-space pass applies to this kernel
    (separable-SSS supplement E, for the two-Gaussian model: max(sigma_near, sigma_far)), or None
    for kernels without one.
    """

    cell_mm: float
    components: np.ndarray
    signs: np.ndarray
    method: str
    params: dict[str, Any] = field(default_factory=dict)
    source: dict[str, Any] = field(default_factory=dict)
    depth_sigma_mm: float | None = None

    def __post_init__(self) -> None:
        comps = check_shape(self.components, "kernel components", (3, "N", "n"), KernelError, dtype=float, finite=True)
        SVD_RANK.within(hi=1 << 20, reason="terms of a separable kernel").check(comps.shape[1], "kernel rank N",
                                                                                 KernelError)
        _check_grid(float(self.cell_mm), comps.shape[2])
        signs = np.asarray(self.signs, dtype=float)
        if signs.shape != comps.shape[:2] or not np.all(np.abs(signs) == 1.0):
            raise KernelError(f"kernel signs must be +-1 with shape {comps.shape[:2]}, got {signs.shape}")
        object.__setattr__(self, "components", comps)
        object.__setattr__(self, "signs", signs)
        object.__setattr__(self, "cell_mm", float(self.cell_mm))

    # ---- shape -------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        return int(self.components.shape[2])

    @property
    def rank(self) -> int:
        """Number of separable terms N (per channel; channels run in parallel in one pass)."""
        return int(self.components.shape[1])

    @property
    def convolutions_1d(self) -> int:
        """1D convolutions per image (RGB together): 2N (paper Eq. 2)."""
        return 2 * self.rank

    @property
    def x_mm(self) -> np.ndarray:
        return grid_coordinates(self.cell_mm, self.n)

    @property
    def radius_mm(self) -> float:
        return self.cell_mm * self.n / 2.0

    # ---- values ------------------------------------------------------------------------------
    def cell_weights(self) -> np.ndarray:
        """Energy weights of the 1D cells, (3, N, n): a_ci * h."""
        return self.components * self.cell_mm

    def to_2d(self) -> np.ndarray:
        """2D cell weights A[y, x, c] = sum_i s_ci w_ci[y] w_ci[x] (paper Eq. 2), shape (n, n, 3)."""
        w = self.cell_weights()
        return np.einsum("ci,ciy,cix->yxc", self.signs, w, w)

    def total(self) -> np.ndarray:
        """Total energy per channel, sum of A over the plane: sum_i s_i (sum a_i h)^2; shape (3,)."""
        sums = self.cell_weights().sum(axis=2)
        return np.sum(self.signs * sums**2, axis=1)

    def l1_norm(self) -> np.ndarray:
        """||A||_1 per channel (sum of |A| over the cells), shape (3,)."""
        return np.abs(self.to_2d()).sum(axis=(0, 1))

    def axis_slice(self) -> np.ndarray:
        """A(x, 0) in mm^-2 at x_mm, shape (n, 3) (paper Fig. 5, axis slices)."""
        c = self.n // 2
        return np.einsum("ci,cix,ci->xc", self.signs, self.components, self.components[:, :, c])

    def diagonal_slice(self) -> np.ndarray:
        """A(x, x) in mm^-2 at the radii sqrt(2) |x_mm|, shape (n, 3) (paper Fig. 5, diagonal slices)."""
        return np.einsum("ci,cix->xc", self.signs, self.components**2)

    def width_mm(self) -> np.ndarray:
        """Standard deviation of the 1D kernel's energy along an axis, per channel, shape (3,).

        The axis marginal m(x) = sum_y A(x, y); sqrt(sum x^2 m / sum m). Used to compare how
        sharp or wide approximations are (guided k = 0 vs 4).
        """
        marg = self.to_2d().sum(axis=0)  # (n, 3): sum over y
        x2 = self.x_mm[:, None] ** 2
        return np.sqrt((x2 * marg).sum(axis=0) / marg.sum(axis=0))

    # ---- transforms --------------------------------------------------------------------------
    def scaled(self, factors: ArrayLike) -> "Kernel":
        """The kernel with each channel's A multiplied by ``factors`` (3,) (must be > 0)."""
        f = per_channel(factors, "kernel scale factors", POSITIVE)
        return self._replace(components=self.components * np.sqrt(f)[:, None, None])

    def normalised(self, total: ArrayLike = 1.0) -> "Kernel":
        """Each channel scaled so that its total (sum of A) equals ``total`` (scalar or (3,))."""
        t = POSITIVE.check_array(self.total(), "the totals of a kernel to normalise", KernelError, "channels")
        return self.scaled(np.broadcast_to(np.asarray(total, dtype=float), (3,)) / t)

    def resample(self, cell_mm: float, n: int | None = None) -> "Kernel":
        """The kernel on a new grid, conserving each component's integral over every new cell.

        Components are treated as piecewise constant over their cells; the new cell averages are
        exact integrals of that function (so totals are preserved wherever the grids overlap).
        """
        if n is None:
            n = int(np.ceil(self.n * self.cell_mm / cell_mm))
            n += 1 - n % 2
        _check_grid(cell_mm, n)
        edges, cum = _cumulative_edges(self.components, self.cell_mm)
        new_edges = (np.arange(n + 1) - n / 2.0) * cell_mm
        flat = cum.reshape(-1, cum.shape[-1])
        c_new = np.stack([np.interp(new_edges, edges, row, left=0.0, right=row[-1]) for row in flat])
        comps = np.diff(c_new, axis=-1).reshape(3, self.rank, n) / cell_mm
        return self._replace(cell_mm=cell_mm, components=comps)

    def truncated(self, rank: int) -> "Kernel":
        """The first ``rank`` terms."""
        SVD_RANK.within(hi=self.rank, reason="the kernel's own terms").check(rank, "rank", KernelError)
        return self._replace(components=self.components[:, :rank], signs=self.signs[:, :rank])

    def _replace(self, **changes: Any) -> "Kernel":
        return dataclasses.replace(self, **changes)

    # ---- comparison --------------------------------------------------------------------------
    def compare(self, profile: RGBProfile) -> dict[str, Any]:
        """Errors of A against the profile's exact cell integrals on the kernel's own grid.

        ``frobenius``: ||Rd - A||_F per channel; ``relative_frobenius``: divided by ||Rd||_F;
        ``relative_l1``: ||Rd - A||_1 / ||Rd||_1; ``total_ratio``: sum A / sum Rd.
        """
        rd = profile.discretize_2d(self.cell_mm, self.n)
        diff = rd - self.to_2d()
        fro = np.sqrt((diff**2).sum(axis=(0, 1)))
        return {
            "frobenius": fro.tolist(),
            "relative_frobenius": (fro / np.sqrt((rd**2).sum(axis=(0, 1)))).tolist(),
            "relative_l1": (np.abs(diff).sum(axis=(0, 1)) / np.abs(rd).sum(axis=(0, 1))).tolist(),
            "total_ratio": (self.total() / rd.sum(axis=(0, 1))).tolist(),
        }

    # ---- serialisation -----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The JSON shape of ``ssskit kernel --json`` for tabulated kernels."""
        return {
            "type": "tabulated",
            "method": self.method,
            "params": _jsonable(self.params),
            "source": _jsonable(self.source),
            "rank": self.rank,
            "convolutions_1d": self.convolutions_1d,
            "cell_mm": self.cell_mm,
            "x_mm": self.x_mm.tolist(),
            "units": "components are cell averages of a_i(x) in mm^-1; A(x,y) = sum_i sign_i a_i(x) a_i(y)",
            "total": self.total().tolist(),
            "channels": {
                ch: {"signs": self.signs[i].tolist(), "components": self.components[i].tolist()}
                for i, ch in enumerate(CHANNELS)
            },
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Kernel":
        """The kernel of :meth:`to_dict`'s object (a KeyError, TypeError or ValueError where ``d`` is none:
        :func:`load_kernel` words them)."""
        comps = np.array([d["channels"][ch]["components"] for ch in CHANNELS], dtype=float)
        signs = np.array([d["channels"][ch]["signs"] for ch in CHANNELS], dtype=float)
        return cls(float(d["cell_mm"]), comps, signs, str(d["method"]), dict(d.get("params", {})),
                   dict(d.get("source", {})))


@dataclass(frozen=True, eq=False)
class TapKernel:
    """A 1D tap kernel as engines ship it: offsets (mm) and RGB weights, centre tap first.

    Applied as a horizontal then a vertical pass with the same taps, i.e. a rank-1 separable
    kernel A(x, y) = k(x) k(y) with k = sum_i w_i delta(x - o_i).
    """

    offsets_mm: np.ndarray
    weights: np.ndarray
    method: str
    params: dict[str, Any] = field(default_factory=dict)
    source: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        o = check_shape(self.offsets_mm, "tap offsets", ("N",), KernelError, dtype=float, finite=True)
        TAP_COUNT.check(o.size, "a tap kernel's taps", KernelError)
        w = check_shape(self.weights, "tap weights", (o.size, 3), KernelError, dtype=float, finite=True)
        object.__setattr__(self, "offsets_mm", o)
        object.__setattr__(self, "weights", w)

    @property
    def taps(self) -> int:
        return int(self.offsets_mm.size)

    rank = 1
    convolutions_1d = 2

    def total(self) -> np.ndarray:
        return self.weights.sum(axis=0) ** 2

    def scaled(self, factors: ArrayLike) -> "TapKernel":
        f = per_channel(factors, "kernel scale factors", POSITIVE)
        return TapKernel(self.offsets_mm, self.weights * np.sqrt(f), self.method, self.params, self.source)

    def to_kernel(self, cell_mm: float, n: int | None = None) -> Kernel:
        """Deposit the taps onto a grid of cell size ``cell_mm`` by linear interpolation between
        the two nearest cell centres (what a bilinear texture fetch at that offset returns)."""
        if n is None:
            n = 2 * int(np.ceil(np.max(np.abs(self.offsets_mm)) / cell_mm)) + 3
        _check_grid(cell_mm, n)
        pos = self.offsets_mm / cell_mm + (n - 1) / 2.0
        if np.any(pos < 0) or np.any(pos > n - 1):
            raise KernelError(f"taps reach {np.max(np.abs(self.offsets_mm)):.4g} mm, beyond a {n}-cell grid")
        lo = np.floor(pos).astype(int)
        frac = pos - lo
        hi = np.minimum(lo + 1, n - 1)
        comp = np.zeros((3, 1, n))
        for c in range(3):
            np.add.at(comp[c, 0], lo, self.weights[:, c] * (1.0 - frac))
            np.add.at(comp[c, 0], hi, self.weights[:, c] * frac)
        return Kernel(cell_mm, comp / cell_mm, np.ones((3, 1)), self.method, self.params, self.source)

    def to_dict(self) -> dict[str, Any]:
        """The JSON shape of ``ssskit kernel --json`` for tap kernels (engine order, centre first)."""
        return {
            "type": "taps",
            "method": self.method,
            "params": _jsonable(self.params),
            "source": _jsonable(self.source),
            "taps": self.taps,
            "convolutions_1d": self.convolutions_1d,
            "units": "offsets in mm; weights per tap as [r, g, b]",
            "offsets": self.offsets_mm.tolist(),
            "weights": self.weights.tolist(),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "TapKernel":
        """The kernel of :meth:`to_dict`'s object (as :meth:`Kernel.from_dict`)."""
        return cls(np.array(d["offsets"], dtype=float), np.array(d["weights"], dtype=float), str(d["method"]),
                   dict(d.get("params", {})), dict(d.get("source", {})))


AnyKernel = Kernel | TapKernel


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def save_kernel(kernel: AnyKernel, path: str | Path) -> None:
    """Write a kernel as ``.json`` (the ``--json`` object) or ``.npz`` (arrays + a JSON ``meta``)."""
    suffix = check_suffix(path, (".json", ".npz"), "kernel output")
    d = kernel.to_dict()
    with atomic_output(path) as tmp:
        if suffix == ".json":
            tmp.write_text(json.dumps(d, indent=1), encoding="utf-8")
            return
        if isinstance(kernel, TapKernel):
            arrays = {"offsets_mm": kernel.offsets_mm, "weights": kernel.weights}
        else:
            arrays = {"x_mm": kernel.x_mm, "components": kernel.components, "signs": kernel.signs}
        meta = {k: v for k, v in d.items() if k not in ("channels", "offsets", "weights", "x_mm")}
        with open(tmp, "wb") as fh:
            np.savez(fh, allow_pickle=True, meta=json.dumps(meta), **arrays)  # the default, named (io.save_arrays)


def load_kernel(path: str | Path) -> AnyKernel:
    """Read a kernel written by :func:`save_kernel`."""
    from ..io import parse_document, read_input

    p = Path(path)
    suffix = p.suffix.lower()
    raw = read_input(p, "kernel file", KernelError, (".json", ".npz"))
    try:
        if suffix == ".json":
            d = parse_document(raw.decode("utf-8"), suffix)
        else:
            with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                d = json.loads(str(z["meta"]))
                if d.get("type") == "taps":
                    d["offsets"], d["weights"] = z["offsets_mm"].tolist(), z["weights"].tolist()
                else:
                    comps, signs = z["components"], z["signs"]
                    d["channels"] = {ch: {"components": comps[i].tolist(), "signs": signs[i].tolist()}
                                     for i, ch in enumerate(CHANNELS)}
    except (OSError, ValueError, KeyError) as exc:  # (a UnicodeDecodeError too)
        raise KernelError(f"cannot read kernel file {str(p)!r}: {exc}") from None
    check_keys(d, f"kernel file {str(p)!r}", error=KernelError)  # (a JSON object: a table)
    taps = d.get("type") == "taps"
    try:
        return TapKernel.from_dict(d) if taps else Kernel.from_dict(d)
    except KernelError:  # (a ValueError too: the kernel's own rules, in their words)
        raise
    except (KeyError, TypeError, ValueError) as exc:  # what the object lacks or holds wrongly
        raise KernelError(f"not {'an ssskit tap' if taps else 'a tabulated ssskit'} kernel: {exc}") from None
