"""A catalogue of hostile inputs to every command, each run as a user would (``python -m ssskit.cli`` in a folder of
its own holding the files below, with its own cache): bad numbers, NaN and infinities, wrong suffixes, missing,
empty, corrupt and deeply nested files, huge values, wrong types in TOML/JSON, unknown options, options that do
not apply, directories where files go, outputs equal to inputs, meshes that crash readers, addresses that are not
services.

The rule each case is held to (docs/commands.md, the project's rules): exit status 2, exactly one line on stderr
(``ssskit: error: ...``), nothing on stdout, nothing written (the folder and the cache unchanged), before any
work. Prints one JSON object: per case its arguments, exit status, stderr lines, wall seconds, the files it wrote
and whether it kept the rule; then a summary with the machine's load average.

    python benchmarks/hostile_inputs.py [--jobs N] [--only SUBSTRING] [--fast]

``--fast``: the cases of :data:`FAST` (tests/cli/test_hostile_inputs.py runs them); ``--jobs``: cases run at once
(default: the CPU count). Wall seconds depend on the machine's load: read them with the load average printed;
with ``--jobs 1`` each case's CPU seconds (user + system of its process) are given too, which depend on it much
less.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import struct
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_PLY_HEAD = ("ply\nformat {fmt} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1\nproperty list uchar int vertex_indices\nend_header\n")
_GOOD_MESH = "v 0 0 0\nv 10 0 0\nv 0 10 0\nv 0 0 10\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def _gbuffer_exr(**attributes: object) -> bytes:
    """A 4x4 G-buffer EXR (the four required layers) with these header ``attributes`` (OpenEXR's own types: an
    int, a float, a V3f written from three float32s)."""
    import numpy as np
    import OpenEXR

    layers = {"diffuse": np.ones((4, 4, 3), np.float32), "albedo": np.ones((4, 4, 3), np.float32),
              "depth": np.ones((4, 4), np.float32), "profile_id": np.ones((4, 4), np.uint32)}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "g.exr"
        with OpenEXR.File({"type": OpenEXR.scanlineimage, **attributes}, layers) as f:
            f.write(str(path))
        return path.read_bytes()


_SCENE = b'[shapes.ball]\ntype = "mesh"\nfile = "ball.obj"\nunits = "mm"\n'
#: the rest of an explicit [camera] (after its origin, target and up) and its explicit light
_FOV_AND_LIGHT = b'fov = 30.0\n[lights.key]\ntype = "point"\nposition = [0, 0, 100]\nintensity = 1.0\n'
_CAMERA_JSON = ('{"width": 4, "height": 4, "fx": 4.0, "fy": 4.0, "cx": 2.0, "cy": 2.0, "world_to_camera": '
                '[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "world_units_per_mm": 1.0}')


def _glb(doc: bytes) -> bytes:
    doc += b" " * (-len(doc) % 4)
    body = struct.pack("<I4s", len(doc), b"JSON") + doc
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


#: the files every case finds in its folder (name -> bytes); "dir.ply/", "folder/" and "x.exr/" are folders
FILES: dict[str, bytes] = {
    # materials
    "m.json": b'{"sigma_a": 0.01, "sigma_s": 1.0}',
    "m.toml": b"sigma_a = 0.01\nsigma_s = 1.0\n",
    "nan.json": b'{"sigma_a": NaN, "sigma_s": 1.0}',
    "inf.toml": b"sigma_a = inf\nsigma_s = 1.0\n",
    "neg.json": b'{"sigma_a": -1, "sigma_s": 1.0}',
    "str.json": b'{"sigma_a": "lots", "sigma_s": 1.0}',
    "bool.toml": b"sigma_a = true\nsigma_s = 1.0\n",
    "four.json": b'{"sigma_a": [0.1, 0.1, 0.1, 0.1], "sigma_s": 1.0}',
    "nested.json": b'{"sigma_a": {"r": 1}, "sigma_s": 1.0}',
    "list.json": b"[0.01, 1.0]",
    "unknown_key.json": b'{"sigma_a": 0.01, "sigma_s": 1.0, "colour": "red"}',
    "missing_key.toml": b"sigma_a = 0.01\n",
    "empty.json": b"",
    "empty.toml": b"",
    "corrupt.json": b'{"sigma_a": 0.01, ',
    "corrupt.toml": b"sigma_a = = 1\n",
    "binary.json": bytes(range(256)),
    "latin1.toml": "name = 'caf\xe9'\n".encode("latin-1"),
    "deep.json": b"[" * 100_000 + b"]" * 100_000,
    "deep.toml": b"a = " + b"[" * 100_000 + b"]" * 100_000,
    "huge.json": b'{"sigma_a": 1e300, "sigma_s": 1e300}',
    "overflow.json": b'{"sigma_a": 1e999, "sigma_s": 1.0}',
    "eta.json": b'{"sigma_a": 0.01, "sigma_s": 1.0, "eta": 0.5}',
    "g.json": b'{"sigma_a": 0.01, "sigma_s": 1.0, "g": 1.5}',
    "noscatter.json": b'{"sigma_a": 0.5, "sigma_s": 0}',
    "material.yaml": b"sigma_a: 0.01\n",
    "notes.txt": b"not a material",
    # meshes
    "oob.ply": _PLY_HEAD.format(fmt="ascii").encode() + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2000000000\n",
    "oob_bin.ply": _PLY_HEAD.format(fmt="binary_little_endian").encode()
    + struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + b"\x03" + struct.pack("<3i", 0, 1, -7),
    "short.ply": _PLY_HEAD.format(fmt="ascii").encode() + b"0 0 0\n1 0 0\n",
    "empty.ply": b"",
    "junk.ply": b"this is not a ply file\n",
    "noend.ply": b"ply\nformat ascii 1.0\nelement vertex 3\n",
    "nan.obj": b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
    "inf.obj": b"v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n",
    "noface.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\n",
    "oob.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
    "flat.obj": b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
    "ball.obj": _GOOD_MESH.encode(),
    "junk.glb": b"not a gltf at all",
    "junk.gltf": b"{not json",
    "noasset.gltf": b'{"meshes": []}',
    "deep.gltf": b'{"asset": {"version": "2.0"}, "x": ' + b"[" * 100_000 + b"]" * 100_000 + b"}",
    "lines.glb": _glb(b'{"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, '
                      b'"mode": 1}]}], "accessors": [{"count": 3}]}'),
    "model.stl": b"solid x\nendsolid x\n",
    "huge.ply": b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\n"
                b"property float z\nelement face 2000000000\nproperty list uchar uint vertex_indices\nend_header\n",
    # scene files
    "units5.toml": b'units = 5\n[shapes.ball]\ntype = "mesh"\nfile = "ball.obj"\n',
    "unitsinch.toml": b'units = "inch"\n[shapes.ball]\ntype = "mesh"\nfile = "ball.obj"\n',
    "noshape.toml": b'[shapes.ball]\ntype = "teapot"\n',
    "nofile.toml": b'[shapes.ball]\ntype = "mesh"\nfile = "missing.obj"\n',
    "oobscene.toml": b'[shapes.ball]\ntype = "mesh"\nfile = "oob.ply"\n',
    "badkey.toml": b'colour = "red"\n[shapes.ball]\ntype = "mesh"\nfile = "ball.obj"\n',
    "shapestr.toml": b'shapes = "ball"\n',
    "lightnan.toml": b'[shapes.ball]\ntype = "mesh"\nfile = "ball.obj"\nunits = "mm"\n[lights.key]\nintensity = nan\n',
    "camfov.toml": b'[shapes.ball]\ntype = "mesh"\nfile = "ball.obj"\nunits = "mm"\n[camera]\nfov = 500.0\n'
                   b'origin = [0, 0, 100]\ntarget = [0, 0, 0]\n',
    "sssstr.toml": b'[shapes.ball]\ntype = "mesh"\nfile = "ball.obj"\nsss = "yes"\n',
    # render settings files
    "s_unknown.toml": b"colour = 1\n",
    "s_nan.json": b'{"width": NaN}',
    "s_str.toml": b'spp = "many"\n',
    "s_neg.toml": b"width = -5\n",
    "s_pass.toml": b"[teapot]\nx = 1\n",
    "s_corrupt.json": b"{",
    # G-buffers and kernels
    "g.exr": b"not an exr file",
    "empty.exr": b"",
    "k.json": b'{"type": "taps"}',
    "kdeep.json": b"[" * 100_000 + b"]" * 100_000,
    # the hunt of issue 34 (each a traceback, a recursion or work done before the refusal)
    "e_Unreal.json": b'{"engine": "Unreal"}',
    "e_UNITY.json": b'{"engine": "UNITY"}',
    "e_materialx.json": b'{"engine": "materialx", "base_color": [0.5, 0.5, 0.5]}',
    "e_sd_empty.json": b'{"engine": "unity", "scatteringDistance": [], "scatteringDistanceMultiplier": 1.0, '
                       b'"worldScale": 1.0, "ior": 1.4, "base_color": [0.5, 0.5, 0.5]}',
    "file5.toml": b'[shapes.ball]\ntype = "mesh"\nfile = 5\n',
    "filelist.toml": b'[shapes.ball]\ntype = "mesh"\nfile = ["ball.obj"]\n',
    "center5.toml": _SCENE + b'[shapes.s]\ntype = "sphere"\ncenter = 5\nradius = 1.0\n',
    "center2.toml": _SCENE + b'[shapes.s]\ntype = "sphere"\ncenter = [0, 0]\nradius = 1.0\nsss = true\n',
    "radiusstr.toml": _SCENE + b'[shapes.s]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = "big"\n',
    "radiusnan.toml": _SCENE + b'[shapes.s]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = nan\nsss = true\n',
    "radiusneg.toml": _SCENE + b'[shapes.s]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = -10.0\nsss = true\n',
    "scalestr.toml": _SCENE + b'[shapes.c]\ntype = "cube"\nscale = "huge"\n',
    "scalezero.toml": _SCENE + b'[shapes.c]\ntype = "cube"\nscale = [0, 0, 0]\nsss = true\n',
    "camsame.toml": _SCENE + b"[camera]\norigin = [0, 0, 0]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\n" + _FOV_AND_LIGHT,
    "camupview.toml": _SCENE + b"[camera]\norigin = [0, 0, 100]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\n" + _FOV_AND_LIGHT,
    "matunknown.toml": _SCENE + b'material = "unobtainium"\n',
    "matnum.toml": _SCENE + b"material = 5\n",
    "meshesdict.gltf": b'{"asset": {"version": "2.0"}, "meshes": {"a": 1}}',
    "cam_int.exr": _gbuffer_exr(ssskit_camera=5),
    "mats_float.exr": _gbuffer_exr(ssskit_camera=_CAMERA_JSON, ssskit_materials=0.5),
    "meta_v3f.exr": _gbuffer_exr(ssskit_camera=_CAMERA_JSON, ssskit_meta=(1.0, 2.0, 3.0)),
    "light_int.exr": _gbuffer_exr(ssskit_camera=_CAMERA_JSON, ssskit_light=5),
}
FOLDERS = ("dir.ply", "folder", "x.exr", "out.png")


def _cases() -> list[tuple[str, list[str]]]:
    """(name, arguments) of every case."""
    c: list[tuple[str, list[str]]] = []

    def add(name: str, *args: str) -> None:
        c.append((name, list(args)))

    # ---- the group, unknown commands and options
    add("unknown command", "frobnicate")
    add("unknown option", "materials", "--colour")
    add("materials takes no argument", "materials", "skin1")
    add("backends takes no argument", "backends", "numba")
    add("profile unknown option", "profile", "--material", "skin1", "--frobnicate", "1")
    add("render unknown option", "render", "--scene", "slab", "--quality", "high")
    # ---- profile: numbers
    for v in ("nan", "inf", "-inf", "-1", "0", "1e400", "abc", "", "1e8"):
        add(f"profile --r-max {v!r}", "profile", "--material", "skin1", "--r-max", v)
    for v in ("0", "-5", "nan", "1.5", "1e12", "x"):
        add(f"profile --points {v!r}", "profile", "--material", "skin1", "--points", v)
    for v in ("0", "-1", "nan", "1e30", "2.5"):
        add(f"profile --photons {v!r}", "profile", "--material", "skin1", "--model", "montecarlo", "--photons", v)
    for v in ("0", "1", "nan", "-0.5", "2"):
        add(f"profile --grid-fraction {v!r}", "profile", "--material", "skin1", "--model", "montecarlo",
            "--grid-fraction", v)
    for v in ("-0.1", "nan", "1.5", "inf"):
        add(f"profile --roughness {v!r}", "profile", "--material", "skin1", "--model", "montecarlo", "--roughness", v)
    for v in ("0", "-2", "nan", "1000"):
        add(f"profile --gaussians {v!r}", "profile", "--material", "skin1", "--model", "gaussians", "--gaussians", v)
    add("profile unknown model", "profile", "--material", "skin1", "--model", "teapot")
    add("profile unknown configuration", "profile", "--material", "skin1", "--model", "burley", "--configuration", "x")
    # ---- profile: options that do not apply
    add("profile --photons with dipole", "profile", "--material", "skin1", "--model", "dipole", "--photons", "1000")
    add("profile --gaussians with dipole", "profile", "--material", "skin1", "--model", "dipole", "--gaussians", "3")
    add("profile --roughness with burley", "profile", "--material", "skin1", "--model", "burley", "--roughness", "0.1")
    add("profile --configuration with dipole", "profile", "--material", "skin1", "--model", "dipole",
        "--configuration", "searchlight")
    add("profile --albedo-source with dipole", "profile", "--material", "skin1", "--albedo-source", "dipole")
    add("profile --material with deon2007", "profile", "--model", "deon2007", "--material", "marble")
    # ---- profile: material files
    for f in ("nan.json", "inf.toml", "neg.json", "str.json", "bool.toml", "four.json", "nested.json", "list.json",
              "unknown_key.json", "missing_key.toml", "empty.json", "empty.toml", "corrupt.json", "corrupt.toml",
              "binary.json", "latin1.toml", "deep.json", "deep.toml", "huge.json", "overflow.json", "eta.json",
              "g.json", "material.yaml", "notes.txt", "missing.json", "folder", "dir.ply"):
        add(f"profile --material {f}", "profile", "--material", f)
    add("profile --material unknown preset", "profile", "--material", "unobtainium")
    add("profile --material empty", "profile", "--material", "")
    add("profile no scattering in montecarlo", "profile", "--material", "noscatter.json", "--model", "montecarlo")
    # ---- profile: outputs
    add("profile --out wrong suffix", "profile", "--material", "skin1", "--out", "p.txt")
    add("profile --out a folder", "profile", "--material", "skin1", "--out", "folder")
    add("profile --out under a file", "profile", "--material", "skin1", "--out", "notes.txt/p.csv")
    add("profile --out no suffix", "profile", "--material", "skin1", "--out", "table")
    add("profile --plot wrong suffix", "profile", "--material", "skin1", "--plot", "p.gif")
    add("profile --plot a folder", "profile", "--material", "skin1", "--plot", "out.png")
    add("profile --out equals --plot", "profile", "--material", "skin1", "--out", "p.npz", "--plot", "p.npz")
    # ---- simulate
    for v in ("0", "-1", "nan", "1e30", "many"):
        add(f"simulate --photons {v!r}", "simulate", "--material", "skin1", "--photons", v)
    for v in ("-1", "nan", "1e30", "9223372036854775808"):
        add(f"simulate --seed {v!r}", "simulate", "--material", "skin1", "--seed", v, "--photons", "1000")
    for v in ("0", "-3", "nan", "100000"):
        add(f"simulate --threads {v!r}", "simulate", "--material", "skin1", "--threads", v, "--photons", "1000")
    for v in ("0", "-1", "nan"):
        add(f"simulate --batch-size {v!r}", "simulate", "--material", "skin1", "--batch-size", v)
    add("simulate --jobs 0", "simulate", "--material", "skin1,marble", "--jobs", "0")
    add("simulate --channel X", "simulate", "--material", "skin1", "--channel", "X")
    add("simulate --backend cuda", "simulate", "--material", "skin1", "--backend", "cuda")
    add("simulate no material", "simulate", "--material", ",,")
    add("simulate --resume and --restart", "simulate", "--material", "skin1", "--resume", "--restart")
    add("simulate --resume with --no-cache", "simulate", "--material", "skin1", "--resume", "--no-cache")
    add("simulate --out with a sweep", "simulate", "--material", "skin1,marble", "--out", "s.npz")
    add("simulate --threads with a sweep", "simulate", "--material", "skin1,marble", "--threads", "1")
    add("simulate --out wrong suffix", "simulate", "--material", "skin1", "--out", "s.csv")
    add("simulate --out a folder", "simulate", "--material", "skin1", "--out", "folder")
    add("simulate duplicate materials", "simulate", "--material", "skin1,skin1", "--jobs", "2")
    add("simulate --material deep.json", "simulate", "--material", "deep.json")
    add("simulate --material noscatter.json", "simulate", "--material", "noscatter.json")
    add("simulate --scheduler nonsense", "simulate", "--material", "skin1,marble", "--scheduler", "nonsense")
    add("simulate --scheduler http scheme", "simulate", "--material", "skin1,marble", "--scheduler", "http://x:1")
    # ---- xie-c
    for v in ("0", "-1", "nan", "1e12", "x"):
        add(f"xie-c --points {v!r}", "xie-c", "--points", v)
    # ---- kernel
    add("kernel unknown method", "kernel", "--material", "skin1", "--method", "teapot")
    for v in ("0", "-1", "nan", "x", "1e9"):
        add(f"kernel --rank {v!r}", "kernel", "--material", "skin1", "--method", "svd", "--rank", v)
    for v in ("0", "-3", "4", "nan"):
        add(f"kernel --size {v!r}", "kernel", "--material", "skin1", "--size", v)
    add("kernel --rank with preintegrated", "kernel", "--material", "skin1", "--method", "preintegrated", "--rank", "3")
    add("kernel inline and option", "kernel", "--material", "skin1", "--method", "svd:2", "--rank", "3")
    add("kernel --taps 0", "kernel", "--method", "jimenez2012", "--taps", "0")
    add("kernel --preset unknown", "kernel", "--method", "artist", "--preset", "teapot")
    add("kernel --out wrong suffix", "kernel", "--material", "skin1", "--out", "k.txt")
    add("kernel --out equals --material", "kernel", "--material", "m.json", "--out", "m.json")
    add("kernel --out a folder", "kernel", "--material", "skin1", "--out", "folder")
    add("kernel --material nan.json", "kernel", "--material", "nan.json")
    add("kernel --photons with dipole", "kernel", "--material", "skin1", "--model", "dipole", "--photons", "100")
    # ---- evaluate
    add("evaluate unknown signal", "evaluate", "--material", "skin1", "--signal", "noise")
    add("evaluate unknown method", "evaluate", "--material", "skin1", "--methods", "zzz")
    for v in ("0", "-1", "nan", "100000", "7"):
        add(f"evaluate --size {v!r}", "evaluate", "--material", "skin1", "--size", v)
    add("evaluate --material corrupt.toml", "evaluate", "--material", "corrupt.toml")
    # ---- render: numbers
    for v in ("0x0", "-5x5", "nanx4", "100000x100000", "abc", "64", "64x48x2", "1e3x1e3"):
        add(f"render --size {v!r}", "render", "--scene", "slab", "--size", v)
    for v in ("0", "-1", "nan", "1e9", "x"):
        add(f"render --spp {v!r}", "render", "--scene", "slab", "--spp", v)
    for v in ("nan", "-0.1", "inf", "5"):
        add(f"render --jitter {v!r}", "render", "--scene", "slab", "--jitter", v)
    for v in ("0", "4", "-7", "1001"):
        add(f"render --taps {v!r}", "render", "--scene", "slab", "--taps", v)
    for v in ("-1", "nan", "1e30"):
        add(f"render --seed {v!r}", "render", "--scene", "slab", "--seed", v)
    for v in ("-1", "nan"):
        add(f"render --frame {v!r}", "render", "--scene", "slab", "--frame", v)
    for v in ("0", "nan", "-1", "2"):
        add(f"render --reference-rel-se {v!r}", "render", "--scene", "slab", "--reference", "--reference-rel-se", v)
    add("render --reference-max-spp below --reference-spp", "render", "--scene", "slab", "--reference",
        "--reference-spp", "64", "--reference-max-spp", "8")
    # ---- render: options that do not apply
    add("render --sampler with separable", "render", "--scene", "slab", "--sampler", "xie")
    add("render --frames with burley", "render", "--scene", "slab", "--pass", "burley", "--frames", "4")
    add("render --taps with burley", "render", "--scene", "slab", "--pass", "burley", "--taps", "9")
    add("render --c with exact sampler", "render", "--scene", "slab", "--pass", "burley", "--sampler", "exact",
        "--c", "2.6")
    add("render --albedo without --dmfp", "render", "--scene", "slab", "--pass", "burley", "--albedo", "0.5")
    add("render --albedo 0", "render", "--scene", "slab", "--pass", "burley", "--albedo", "0", "--dmfp", "1")
    add("render --dmfp nan", "render", "--scene", "slab", "--pass", "burley", "--albedo", "0.5", "--dmfp", "nan")
    add("render --budget reversed", "render", "--scene", "slab", "--pass", "burley-adaptive", "--budget", "32:4")
    add("render --kappa nan", "render", "--scene", "slab", "--pass", "burley-adaptive", "--kappa", "nan")
    add("render --alpha 2", "render", "--scene", "slab", "--pass", "burley-adaptive", "--alpha", "2")
    add("render --units with a built-in", "render", "--scene", "slab", "--units", "mm")
    add("render --material-map with a built-in", "render", "--scene", "slab", "--material-map", "a=skin1")
    add("render --view with a built-in", "render", "--scene", "slab", "--view", "front")
    add("render --pass and --method differ", "render", "--scene", "slab", "--pass", "burley", "--method", "separable")
    # ---- render: scenes
    for f in ("oob.ply", "oob_bin.ply", "short.ply", "empty.ply", "junk.ply", "noend.ply", "nan.obj", "inf.obj",
              "noface.obj", "oob.obj", "flat.obj", "junk.glb", "junk.gltf", "noasset.gltf", "deep.gltf", "lines.glb",
              "model.stl", "huge.ply", "dir.ply", "missing.ply", "units5.toml", "unitsinch.toml", "noshape.toml",
              "nofile.toml", "oobscene.toml", "badkey.toml", "shapestr.toml", "lightnan.toml", "camfov.toml",
              "sssstr.toml", "deep.toml", "corrupt.toml", "empty.toml", "g.exr", "empty.exr", "x.exr", "teapot"):
        add(f"render --scene {f}", "render", "--scene", f)
    add("render --units inch", "render", "--scene", "ball.obj", "--units", "inch")
    add("render --units twice", "render", "--scene", "ball.obj", "--units", "mm", "--units", "m")
    add("render --material-map unknown object", "render", "--scene", "ball.obj", "--units", "mm", "--material-map",
        "head=skin1")
    add("render --material-map no =", "render", "--scene", "ball.obj", "--units", "mm", "--material-map", "ball")
    add("render --view nonsense", "render", "--scene", "ball.obj", "--units", "mm", "--view", "sideways")
    add("render --view nan", "render", "--scene", "ball.obj", "--units", "mm", "--view", "nan,0")
    # ---- render: settings files
    for f in ("s_unknown.toml", "s_nan.json", "s_str.toml", "s_neg.toml", "s_pass.toml", "s_corrupt.json",
              "deep.json", "empty.json", "notes.txt", "missing.toml", "folder"):
        add(f"render --settings {f}", "render", "--scene", "slab", "--settings", f)
    # ---- render: outputs
    add("render --out wrong suffix", "render", "--scene", "slab", "--out", "r.jpg")
    add("render --out a folder", "render", "--scene", "slab", "--out", "out.png")
    add("render --out under a file", "render", "--scene", "slab", "--out", "notes.txt/r.png")
    add("render --save-gbuffer wrong suffix", "render", "--scene", "slab", "--save-gbuffer", "g.png")
    add("render --save-gbuffer equals --out", "render", "--scene", "slab", "--out", "a.exr", "--save-gbuffer", "a.exr")
    add("render --out equals --scene", "render", "--scene", "ball.obj", "--units", "mm", "--out", "ball.obj")
    add("render --frames-dir is a file", "render", "--scene", "slab", "--pass", "burley-adaptive", "--frames-dir",
        "notes.txt")
    # ---- export
    add("export unknown format", "export", "--format", "fbx", "--out", "x.fbx")
    add("export wrong suffix", "export", "--format", "unity", "--out", "x.json")
    add("export no out", "export", "--format", "unity")
    add("export --out a folder", "export", "--format", "json", "--out", "folder")
    add("export --out equals --material", "export", "--format", "json", "--material", "m.json", "--out", "m.json")
    add("export --material missing", "export", "--format", "unity", "--material", "missing.json", "--out", "x.asset")
    add("export --material deep.json", "export", "--format", "unity", "--material", "deep.json", "--out", "x.asset")
    add("export --material nan.json", "export", "--format", "blender", "--material", "nan.json", "--out", "x.py")
    add("export --albedo nan", "export", "--format", "unity", "--albedo", "nan,0.5,0.5", "--mfp", "1,1,1", "--out",
        "x.asset")
    add("export --albedo 2", "export", "--format", "unity", "--albedo", "2,0.5,0.5", "--mfp", "1,1,1", "--out",
        "x.asset")
    add("export --mfp -1", "export", "--format", "unity", "--albedo", "0.5,0.5,0.5", "--mfp", "-1,1,1", "--out",
        "x.asset")
    add("export --mfp two numbers", "export", "--format", "unity", "--albedo", "0.5,0.5,0.5", "--mfp", "1,1",
        "--out", "x.asset")
    add("export --albedo with --material", "export", "--format", "unity", "--material", "skin1", "--albedo",
        "0.5,0.5,0.5", "--out", "x.asset")
    add("export --eta nan", "export", "--format", "unity", "--albedo", "0.5,0.5,0.5", "--mfp", "1,1,1", "--eta",
        "nan", "--out", "x.asset")
    add("export --g 2", "export", "--format", "unity", "--albedo", "0.5,0.5,0.5", "--mfp", "1,1,1", "--g", "2",
        "--out", "x.asset")
    add("export --taps 0", "export", "--format", "hlsl", "--material", "skin1", "--taps", "0", "--out", "k.hlsl")
    add("export --jitter with hlsl arrays", "export", "--format", "hlsl", "--material", "skin1", "--jitter", "0.2",
        "--out", "k.hlsl")
    add("export --standard-surface with unity", "export", "--format", "unity", "--material", "skin1",
        "--standard-surface", "--out", "x.asset")
    add("export --unreal-form with unity", "export", "--format", "unity", "--material", "skin1", "--unreal-form",
        "mfp", "--out", "x.asset")
    add("export --photons with dipole", "export", "--format", "json", "--material", "skin1", "--model", "dipole",
        "--photons", "100", "--out", "x.json")
    # ---- figures
    add("figures unknown name", "figures", "fig99")
    add("figures --out is a file", "figures", "fig2", "--model", "dipole", "--out", "notes.txt")
    add("figures --out under a file", "figures", "fig2", "--model", "dipole", "--out", "notes.txt/figs")
    add("figures --material deep.json", "figures", "fig2", "--material", "deep.json")
    add("figures --scene oob.ply", "figures", "xie-fig1", "--scene", "oob.ply")
    add("figures --photons 0", "figures", "fig2", "--model", "montecarlo", "--photons", "0")
    add("figures --backend cuda", "figures", "fig2", "--backend", "cuda")
    # ---- demo
    for v in ("0", "-1", "nan", "2000"):
        add(f"demo --jobs {v!r}", "demo", "--jobs", v)
    for v in ("0", "-5", "nan"):
        add(f"demo --photons {v!r}", "demo", "--photons", v)
    add("demo --out is a file", "demo", "--out", "notes.txt")
    add("demo --out under a file", "demo", "--out", "notes.txt/demo")
    add("demo --scene oob.ply", "demo", "--scene", "oob.ply")
    add("demo --scene units5.toml", "demo", "--scene", "units5.toml")
    add("demo --material deep.json", "demo", "--material", "deep.json")
    add("demo --units with a built-in", "demo", "--units", "mm")
    add("demo --full and --photons", "demo", "--full", "--photons", "1000")
    # ---- the hunt of issue 34: engine files, scene fields, glTF arrays, G-buffer header attributes
    for f, cmd in (("e_Unreal.json", "export"), ("e_UNITY.json", "profile"), ("e_materialx.json", "export"),
                   ("e_materialx.json", "kernel"), ("e_materialx.json", "render"), ("e_sd_empty.json", "export"),
                   ("e_sd_empty.json", "profile")):
        more = {"export": ("--format", "unreal", "--out", "o.json"), "kernel": ("--method", "preintegrated"),
                "render": ("--scene", "slab")}.get(cmd, ())
        add(f"{cmd} --material {f}", cmd, "--material", f, *more)
    for f in ("file5.toml", "filelist.toml", "center5.toml", "center2.toml", "radiusstr.toml", "radiusnan.toml",
              "radiusneg.toml", "scalestr.toml", "scalezero.toml", "camsame.toml", "camupview.toml",
              "matunknown.toml", "matnum.toml", "meshesdict.gltf", "cam_int.exr", "mats_float.exr", "meta_v3f.exr",
              "light_int.exr"):
        add(f"render --scene {f}", "render", "--scene", f)
    return c


CASES = _cases()
#: a quick cross-section (every command, every kind of input): tests/cli/test_hostile_inputs.py runs it
FAST = ("unknown command", "render --scene oob.ply", "render --scene oob_bin.ply", "render --scene units5.toml",
        "profile --material deep.json", "profile --material deep.toml", "render --scene deep.gltf",
        "render --settings deep.json", "simulate --scheduler nonsense", "profile --r-max 'nan'",
        "profile --material nan.json", "render --size '0x0'", "render --out equals --scene", "kernel --out equals "
        "--material", "export --out equals --material", "figures --out is a file", "demo --jobs '0'",
        "xie-c --points 'nan'", "evaluate --size '7'", "render --scene dir.ply", "render --scene empty.exr",
        "profile --material latin1.toml", "render --settings s_str.toml", "simulate --out with a sweep",
        "export --albedo nan", "render --sampler with separable", "render --scene lines.glb", "render --scene lightnan.toml",
        "render --material-map unknown object", "export --material deep.json", "render --pass and --method differ")


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def setup(folder: Path) -> None:
    """The catalogue's files (:data:`FILES`, :data:`FOLDERS`) in ``folder``."""
    for name, data in FILES.items():
        (folder / name).write_bytes(data)
    for name in FOLDERS:
        (folder / name).mkdir()


def _children_cpu_s() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def run_case(name: str, args: list[str], timeout_s: float = 60.0, cpu: bool = False) -> dict:
    """Run one case in a fresh folder holding the catalogue's files: its exit status, stderr lines, wall and CPU
    seconds, the files it wrote, and whether it kept the rule (exit 2, one line ``ssskit: error: ...``, no stdout,
    nothing written)."""
    with tempfile.TemporaryDirectory(prefix="hostile-") as tmp:
        folder = Path(tmp)
        setup(folder)
        env = {**os.environ, "SSSKIT_CACHE_DIR": str(folder / "cache"), "PYTHONPATH": str(ROOT / "src")}
        before = _listing(folder)
        cpu0 = _children_cpu_s()
        t0 = time.perf_counter()
        proc = subprocess.Popen([sys.executable, "-m", "ssskit.cli", *args], cwd=folder, env=env, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            out, err = proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
        wall = time.perf_counter() - t0
        cpu_s = round(_children_cpu_s() - cpu0, 3) if cpu else None  # exact only when cases run one at a time
        written = sorted(set(_listing(folder)) - set(before))
    lines = err.splitlines()
    ok = (proc.returncode == 2 and len(lines) == 1 and lines[0].startswith("ssskit: error: ") and not out
          and not written)
    # the heartbeat ("  ... still working, 8 s since the last step") speaks after 8 s without progress: only a
    # loaded machine makes a refusal that slow; counted apart so a test can hold the rule on any load
    beats = sum(line.startswith("  ... still working") for line in lines)
    return {"name": name, "args": args, "exit": proc.returncode, "stderr_lines": len(lines), "heartbeat_lines": beats,
            "stderr": err.strip()[-300:], "stdout_bytes": len(out), "wall_s": round(wall, 3), "cpu_s": cpu_s,
            "written": written, "ok": ok}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--only", default="")
    ap.add_argument("--fast", action="store_true")
    a = ap.parse_args(argv)
    cases = [(n, args) for n, args in CASES if a.only in n and (not a.fast or n in FAST)]
    t0 = time.perf_counter()
    load_before = os.getloadavg()
    with ThreadPoolExecutor(max_workers=max(a.jobs, 1)) as pool:
        results = list(pool.map(lambda c: run_case(*c, cpu=a.jobs == 1), cases))
    failed = [r["name"] for r in results if not r["ok"]]
    slow = [r["name"] for r in results if r["wall_s"] > 1.0]
    summary = {"cases": len(results), "ok": len(results) - len(failed), "failed": failed,
               "slower_than_1s_wall": slow, "max_wall_s": max((r["wall_s"] for r in results), default=0),
               "max_cpu_s": max((r["cpu_s"] or 0 for r in results), default=0) if a.jobs == 1 else None,
               "slower_than_1s_cpu": [r["name"] for r in results if (r["cpu_s"] or 0) > 1.0], "jobs": a.jobs,
               "total_s": round(time.perf_counter() - t0, 1), "load_average_before": load_before,
               "load_average_after": os.getloadavg(), "cpus": os.cpu_count(), "python": sys.version.split()[0]}
    print(json.dumps({"summary": summary, "cases": results}, indent=1))
    return 0 if not failed else 1


if __name__ == "__main__":
    sys.exit(main())
