"""The transmittance pass (ssskit.backends.transmission_plan): its cost per frame against the separable pass
on the same backend in the same run, and the thickness a translucency shadow map gives against the
ray-cast truth on built-in scenes at two map resolutions. Prints one JSON object.

Cost: a 1920x1080 frame, every pixel inside the SSS mask and behind the map's surface (every pixel runs all
of steps 1-5), the 1024^2 map spread over the frame, Skin1's MCML model (4 terms), against the separable pass of 7 importance-sampled taps of
Skin1's pre-integrated kernel with 10 % jitter (the paper's set-up), medians of interleaved repeats, per
backend (numba, gl where available: on llvmpipe without a GPU); and the lateral spread of the pass's result
(backends.spread_plan: Skin1's MCML widths, 4-6 mm of medium behind every pixel, 2 pixels per mm: 5-8 pixels
in red). Besides the wall times, ``cpu_ms`` is the process's CPU time per call (all threads; on a loaded
machine it moves far less than the wall time, and wall ~ cpu / threads on an idle one).

Pipeline: the same frame as a G-buffer through ssskit.pipeline.transmission.add_transmission on numba (the
frame inputs from the G-buffer, the pass, the demodulation by the albedo), and the inputs alone.

Thickness: scenes/lightspace.py ray-casts the map (orthographic, from the scene's first light) and the
exact distance towards the light from each point the camera sees (128 x 128 camera pixels); the error of
the pass's thickness (screenspace.transmission.thickness_from_map) against the chord through the medium
along the light, median and 95th percentile in mm, over the seen points the light reaches through the
medium (truth > 0.05 mm), at maps of 128 and 512 texels.

    NUMBA_THREADING_LAYER is set to 'workqueue' unless given.
    python benchmarks/transmission.py [--repeats 7] [--skip-thickness]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time

os.environ.setdefault("NUMBA_THREADING_LAYER", "workqueue")

import numpy as np  # noqa: E402


def cost(repeats: int) -> dict:
    from ssskit.backends import backend_status, build_separable_plan, get_backend
    from ssskit.kernels import build_kernel, default_grid
    from ssskit.materials import get_material
    from ssskit.profiles import profile_for_material
    from ssskit.sampling.taps import make_taps
    from ssskit.backends.spread_plan import build_spread_plan
    from ssskit.screenspace.transmission import mcml_model, mcml_spread, transmission_plan

    w, h = 1920, 1080
    rng = np.random.default_rng(0)
    image = rng.random((h, w, 3), dtype=np.float32)
    xx = np.arange(w, dtype=np.float32)[None, :]
    yy = np.arange(h, dtype=np.float32)[:, None]
    depth = (400.0 + 0.1 * xx + 0.05 * yy).astype(np.float32)
    slots = np.ones((h, w), np.int32)
    profile = profile_for_material("skin1", "dipole")
    cell, size = default_grid(profile)
    taps = make_taps(build_kernel("preintegrated", profile, cell, size), 7, "importance")
    sep = build_separable_plan({1: taps}, 1000.0, 1000.0, jitter=0.1, depth_mode="follow")
    tplan = transmission_plan({1: mcml_model(get_material("skin1"))})
    splan = build_spread_plan({1: mcml_spread(get_material("skin1"))}, 1000.0, 1000.0)
    hs, ws = 1024, 1024
    shadow = (100.0 + rng.uniform(0, 2, (hs, ws))).astype(np.float32)
    # neighbouring pixels see neighbouring texels (the map covers the frame's object, as a light's map does)
    uvz = np.stack([np.broadcast_to((xx + 0.5) * ws / w, (h, w)), np.broadcast_to((yy + 0.5) * hs / h, (h, w)),
                    np.full((h, w), 106.0)], -1).astype(np.float32)
    ndl = np.full((h, w), -0.7, np.float32)
    light = np.ones((h, w, 3), np.float32)
    out = {}
    for name in ("numba", "gl"):
        if not backend_status()[name]["available"]:
            out[name] = {"available": False}
            continue
        b = get_backend(name)
        exitance = np.ascontiguousarray(b.transmission(tplan, slots, uvz, shadow, ndl, light), np.float32)
        fns = {"separable": lambda: b.separable(sep, image, depth, slots),
               "transmission": lambda: b.transmission(tplan, slots, uvz, shadow, ndl, light),
               "spread": lambda: b.transmission_spread(splan, exitance, depth, slots, uvz, shadow)}
        for fn in fns.values():
            fn()
        times: dict[str, list[float]] = {k: [] for k in fns}
        cpu: dict[str, list[float]] = {k: [] for k in fns}
        for _ in range(repeats):
            for k, fn in fns.items():
                c0, t0 = time.process_time(), time.perf_counter()
                fn()
                times[k].append(1e3 * (time.perf_counter() - t0))
                cpu[k].append(1e3 * (time.process_time() - c0))
        med = {k: statistics.median(v) for k, v in times.items()}
        out[name] = {"separable_ms": round(med["separable"], 2), "transmission_ms": round(med["transmission"], 2),
                     "share_of_separable": round(med["transmission"] / med["separable"], 3),
                     "spread_ms": round(med["spread"], 2),
                     "spread_share_of_separable": round(med["spread"] / med["separable"], 3),
                     "transmission_min_ms": round(min(times["transmission"]), 2),
                     "cpu_ms": {k: round(statistics.median(v), 2) for k, v in cpu.items()},
                     "renderer": backend_status()[name]["details"]}
    return out


def pipeline_cost(repeats: int) -> dict:
    """The pass inside a render at 1080p on numba: the G-buffer's frame inputs (GBuffer.transmission_inputs in
    float32) and the whole of pipeline.transmission.add_transmission (inputs, pass, demodulation), ms."""
    from ssskit.materials import get_material
    from ssskit.pipeline.settings import RenderSettings
    from ssskit.pipeline.transmission import add_transmission
    from ssskit.screenspace import GBuffer
    from ssskit.screenspace.camera import Camera
    from ssskit.screenspace.transmission import LightView

    w, h = 1920, 1080
    rng = np.random.default_rng(0)
    cam = Camera(w, h, 2000.0, 2000.0, w / 2, h / 2, np.eye(4), 1.0)
    normal = np.zeros((h, w, 3), np.float32)
    normal[..., 2] = -1.0
    view = LightView.looking_along(np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 500.0]), 300.0, (w, h))
    depth_back = view.project(np.array([[0.0, 0.0, 505.0]]))[0, 2]
    gb = GBuffer(diffuse=rng.random((h, w, 3), dtype=np.float32), albedo=np.full((h, w, 3), 0.5, np.float32),
                 depth=np.full((h, w), 500.0, np.float32), profile_id=np.ones((h, w), np.uint32), camera=cam,
                 normal=normal, materials=("skin1",), light_depth=np.full((h, w), depth_back, np.float32),
                 light={**view.to_dict(), "irradiance": [1.0, 1.0, 1.0]})
    sss = rng.random((h, w, 3), dtype=np.float32)
    settings = RenderSettings(transmission="on", backend="numba")
    mats = {1: get_material("skin1")}
    fns = {"inputs": lambda: gb.transmission_inputs(np.float32),
           "add_transmission": lambda: add_transmission(gb, sss, settings, mats, lambda msg: None)}
    for fn in fns.values():
        fn()
    out = {}
    for k, fn in fns.items():
        wall, cpu = [], []
        for _ in range(repeats):
            c0, t0 = time.process_time(), time.perf_counter()
            fn()
            wall.append(1e3 * (time.perf_counter() - t0))
            cpu.append(1e3 * (time.process_time() - c0))
        out[k] = {"ms": round(statistics.median(wall), 2), "cpu_ms": round(statistics.median(cpu), 2)}
    return out


def thickness() -> dict:
    from ssskit.scenes.lightspace import depth_map, scene_light_view, seen_truth
    from ssskit.screenspace.transmission import thickness_from_map

    out = {}
    for scene in ("sphere", "ear"):
        rows = {}
        for res in (128, 512):
            view = scene_light_view(scene, res)
            dm = depth_map(scene, view)
            truth = seen_truth(scene, view, 128, 128)
            th = thickness_from_map(view, dm, truth["points"])
            m = truth["chord"] > 0.05
            err = np.abs(th[m] - truth["chord"][m])
            rows[str(res)] = {"texel_mm": round(view.texel_mm, 4), "points": int(m.sum()),
                              "no_map_texel": int(np.isnan(err).sum()),
                              "median_mm": round(float(np.nanmedian(err)), 4),
                              "p95_mm": round(float(np.nanpercentile(err, 95)), 4)}
        out[scene] = rows
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--skip-thickness", action="store_true")
    args = ap.parse_args()
    load0 = os.getloadavg()
    result = {"cost_1080p": cost(args.repeats), "pipeline_1080p_numba": pipeline_cost(args.repeats)}
    if not args.skip_thickness:
        result["thickness_vs_chord"] = thickness()
    result["loadavg_before_after"] = [round(load0[0], 2), round(os.getloadavg()[0], 2)]
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
