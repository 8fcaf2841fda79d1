"""The supplement's Monte Carlo profiles, shipped with the package: the 11 measured materials (and
Skin1 index-matched, eta = 1, which the demo's shadow-edge study uses) simulated once at the
separable-SSS supplement's settings (section F: 10^7 photons per channel, dr = min MFP / 20, 32 max
MFP of support, seed 1), with their standard errors.

:func:`~ssskit.profiles.montecarlo.simulate` reads them like a read-only cache that comes with the
install: a configuration equal to a shipped one (every input but the engine version, see
:func:`config_id`) returns the shipped result at once, so the demo, the figures and every command at
the default photon count start from the supplement's profiles without simulating. ``shipped=False``
(``ssskit demo --full``, ``--no-cache``) simulates instead.

The file is ``data/supplement_profiles.npz`` beside this module, written by
``python docs/supplement_profiles.py`` (about an hour on 2 cores) and checked by
``tests/profiles/test_shipped.py``, which re-simulates a subset with fewer photons and compares the
two within their standard errors. Stored: per configuration the regular bins' R(r) and its standard
error as float32 (trailing empty bins dropped: R = 0 there), the totals, the exit-direction tally,
the engine version and the run time that made it.

The transmission tables (:func:`~ssskit.profiles.montecarlo.transmission.transmission_table`: MCML's T(t) of a
slab per channel with its batch standard errors, the diffuse reflectance, the spread of Tt(r)) of the same 11
materials are shipped too, at the product's defaults (2 x 10^5 photons per run, seed 101, the default grid and
floor): ``data/transmission_tables.json``, written by ``python docs/transmission_tables.py`` and checked by
``tests/profiles/test_shipped_tables.py``. A table request answers from it when its
:func:`~ssskit.profiles.montecarlo.transmission.table_key` matches, i.e. when every simulation it would run has
the same cache key (engine version included) and the floor and the table's derivation are the same; so ``ssskit
export --format unreal|unity``, ``ssskit render --transmission on`` and the demo simulate no slab for these
materials. :func:`recompute` turns it off as it does the profiles.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import hashlib
import json
from dataclasses import asdict, replace
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ...materials import MATERIALS, Material
from .config import DEFAULT_BATCH, DEFAULT_PHOTONS, ENGINE_VERSION, MCConfig, channel_seed, config_for_material
from .result import MCResult

#: the shipped file (package data)
SHIPPED_FILE = Path(__file__).parent / "data" / "supplement_profiles.npz"
#: the seed of every shipped simulation (channel c uses the stream ``3 * seed + c``, as
#: config.channel_seed, as :func:`~ssskit.profiles.montecarlo.simulate_material`)
SHIPPED_SEED = 1
#: the order of the scalars stored per configuration
_SCALARS = ("total_rd", "total_rd_se", "tt", "tt_se", "absorbed", "absorbed_se", "rsp", "seconds", "overflow",
            "overflow_se")


def config_id(cfg: MCConfig) -> str:
    """Every input of ``cfg`` but the engine version, hashed: a shipped result stands for the
    configuration whatever version of the engine made it (``tests/profiles/test_shipped.py`` checks
    it against the engine of the day within the standard errors)."""
    data = asdict(cfg)
    if cfg.roughness == 0:
        del data["roughness"]
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=repr).encode()).hexdigest()[:24]


def shipped_materials() -> list[tuple[str, Material]]:
    """(label, material) of every shipped set of profiles: the 11 measured materials of supplement G
    and Skin1 at eta = 1 (index-matched: the demo's shadow-edge study)."""
    out: list[tuple[str, Material]] = [(name, m) for name, m in MATERIALS.items()]
    out.append(("Skin1 (eta = 1)", replace(MATERIALS.get("skin1"), eta=1.0)))
    return out


def shipped_configs(photons: int = DEFAULT_PHOTONS) -> list[tuple[str, str, MCConfig]]:
    """(label, channel, configuration) of every shipped simulation, in the file's order; ``photons``
    other than the supplement's 10^7 gives the same simulations with fewer photons (the test's)."""
    out = []
    for label, m in shipped_materials():
        for c, ch in enumerate("RGB"):
            cfg = config_for_material(m, c, photons, channel_seed(SHIPPED_SEED, c), DEFAULT_BATCH)
            out.append((label, ch, cfg))
    return out


_ENABLED: contextvars.ContextVar[bool] = contextvars.ContextVar("ssskit_shipped_profiles", default=True)


@contextlib.contextmanager
def recompute() -> Iterator[None]:
    """Within the block, :func:`~ssskit.profiles.montecarlo.simulate` ignores the shipped profiles and
    simulates (``ssskit demo --full``)."""
    token = _ENABLED.set(False)
    try:
        yield
    finally:
        _ENABLED.reset(token)


@functools.lru_cache(maxsize=1)
def _index() -> dict[str, int]:
    """{config id: entry} of the shipped file ({} when the file is absent)."""
    if not SHIPPED_FILE.is_file():
        return {}
    with np.load(SHIPPED_FILE) as z:
        ids = [str(s) for s in z["ids"]]
    return {cid: i for i, cid in enumerate(ids)}


def manifest() -> list[dict[str, Any]]:
    """What the shipped file holds: per entry label, channel, config id, photons, bins, engine
    version, seconds and when and where it was made ([] when the file is absent)."""
    if not SHIPPED_FILE.is_file():
        return []
    with np.load(SHIPPED_FILE) as z:
        return list(json.loads(str(z["manifest"])))


def shipped_result(cfg: MCConfig) -> MCResult | None:
    """The shipped result of ``cfg``, or None if ``cfg`` is not one of the shipped simulations (or
    inside a :func:`recompute` block)."""
    if not _ENABLED.get():
        return None
    i = _index().get(config_id(cfg))
    if i is None:
        return None
    with np.load(SHIPPED_FILE) as z:
        n_reg = cfg.nr - 1
        rd = np.zeros(n_reg)
        rd_se = np.zeros(n_reg)
        stored = z[f"rd_{i}"].astype(np.float64)
        rd[: stored.shape[0]] = stored
        rd_se[: stored.shape[0]] = z[f"rd_se_{i}"].astype(np.float64)
        s = dict(zip(_SCALARS, (float(v) for v in z[f"scalars_{i}"])))
        exit_rd, exit_rd_se = z[f"exit_rd_{i}"].copy(), z[f"exit_rd_se_{i}"].copy()
    return MCResult(config=cfg, r_mm=(np.arange(n_reg) + 0.5) * cfg.dr_mm, rd=rd, rd_se=rd_se,
                    total_rd=s["total_rd"], total_rd_se=s["total_rd_se"], tt=s["tt"], tt_se=s["tt_se"],
                    absorbed=s["absorbed"], absorbed_se=s["absorbed_se"], rsp=s["rsp"], seconds=s["seconds"],
                    photons=cfg.photons, overflow=s["overflow"], overflow_se=s["overflow_se"], exit_rd=exit_rd,
                    exit_rd_se=exit_rd_se, extra={"shipped": True}, tt_r=np.zeros(n_reg), tt_r_se=np.zeros(n_reg),
                    exit_tt=np.zeros_like(exit_rd), exit_tt_se=np.zeros_like(exit_rd))  # semi-infinite: no Tt


def write_shipped(entries: list[tuple[str, str, MCResult]], path: Path = SHIPPED_FILE,
                  made: dict[str, Any] | None = None) -> Path:
    """Write ``(label, channel, result)`` entries as the shipped file (atomically); ``made``: where and
    when they were simulated, kept in the manifest."""
    from ...io import atomic_output

    arrays: dict[str, np.ndarray] = {}
    info = []
    for i, (label, ch, res) in enumerate(entries):
        nz = np.flatnonzero(res.rd)
        keep = int(nz[-1]) + 1 if nz.size else 0
        arrays[f"rd_{i}"] = res.rd[:keep].astype(np.float32)
        arrays[f"rd_se_{i}"] = res.rd_se[:keep].astype(np.float32)
        arrays[f"scalars_{i}"] = np.array([float(getattr(res, k)) for k in _SCALARS])
        arrays[f"exit_rd_{i}"] = np.asarray(res.exit_rd, float)
        arrays[f"exit_rd_se_{i}"] = np.asarray(res.exit_rd_se, float)
        info.append({"label": label, "channel": ch, "id": config_id(res.config), "photons": res.photons,
                     "seed": res.config.seed, "nr": res.config.nr, "dr_mm": res.config.dr_mm, "bins_stored": keep,
                     "engine_version": ENGINE_VERSION, "seconds": round(float(res.seconds), 1)})
    arrays["ids"] = np.array([d["id"] for d in info])
    arrays["manifest"] = np.array(json.dumps(info))
    arrays["made"] = np.array(json.dumps(made or {}))
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)  # type: ignore[arg-type]  # (numpy stubs: allow_pickle)
    _index.cache_clear()
    return path


# ---- the transmission tables ----------------------------------------------------------------------------------

#: the shipped transmission tables (package data)
TABLES_FILE = Path(__file__).parent / "data" / "transmission_tables.json"


def table_materials() -> list[tuple[str, Material]]:
    """(label, material) of every shipped transmission table: the 11 measured materials of supplement G."""
    return list(MATERIALS.items())


@functools.lru_cache(maxsize=1)
def _tables() -> dict[str, dict[str, Any]]:
    """{table key: entry} of the shipped tables file ({} when the file is absent)."""
    if not TABLES_FILE.is_file():
        return {}
    data = json.loads(TABLES_FILE.read_text())
    return {e["key"]: e for e in data["tables"]}


def shipped_table(key: str) -> dict[str, Any] | None:
    """The shipped transmission table of ``key`` (:func:`~.transmission.table_key`) as
    :meth:`~.transmission.TransmissionTable.to_dict` wrote it (NaN as None), or None if no table of that key is
    shipped (or inside a :func:`recompute` block)."""
    if not _ENABLED.get():
        return None
    entry = _tables().get(key)
    return None if entry is None else dict(entry["table"])


def tables_manifest() -> dict[str, Any]:
    """What the shipped tables file holds: ``made`` (where and when), ``defaults`` (the request the tables answer)
    and ``tables``, per table its label, key, engine version, number of thicknesses, photons, seed and the seconds
    its simulations took ({} when the file is absent)."""
    if not TABLES_FILE.is_file():
        return {}
    data = json.loads(TABLES_FILE.read_text())
    tables = [{"label": e["label"], "key": e["key"], "engine_version": e["engine_version"], "seconds": e["seconds"],
               "thicknesses": len(e["table"]["thickness_mm"]), "photons": e["table"]["photons"],
               "seed": e["table"]["seed"]} for e in data["tables"]]
    return {"made": data.get("made", {}), "defaults": data.get("defaults", {}), "tables": tables}


def write_tables(entries: list[tuple[str, str, dict[str, Any], float]], path: Path = TABLES_FILE,
                 made: dict[str, Any] | None = None, defaults: dict[str, Any] | None = None) -> Path:
    """Write ``(label, key, table.to_dict(), seconds simulated)`` entries as the shipped tables file (atomically,
    one table a line, floats exact: JSON keeps every float's shortest repr; NaN as null); ``made``: where and
    when they were simulated; ``defaults``: the request they answer."""
    import math

    from ...io import atomic_output

    def plain(v: Any) -> Any:
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if isinstance(v, list):
            return [plain(x) for x in v]
        return v

    lines = [json.dumps({"label": label, "key": key, "engine_version": ENGINE_VERSION, "seconds": round(float(sec), 1),
                         "table": {k: plain(v) for k, v in table.items()}}, allow_nan=False)
             for label, key, table, sec in entries]
    head = json.dumps({"made": made or {}, "defaults": defaults or {}}, allow_nan=False)[:-1]
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        Path(tmp).write_text(head + ',\n"tables": [\n' + ",\n".join(lines) + "\n]}\n")
    _tables.cache_clear()
    return path


__all__ = ["SHIPPED_FILE", "SHIPPED_SEED", "TABLES_FILE", "config_id", "manifest", "recompute", "shipped_configs",
           "shipped_materials", "shipped_result", "shipped_table", "table_materials", "tables_manifest", "write_shipped",
           "write_tables"]
