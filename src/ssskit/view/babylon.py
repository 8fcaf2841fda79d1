"""The Babylon.js client: a page (``babylon_page/``) that loads ``@babylonjs/core`` (npm, the pinned
:data:`ssskit.export.babylon.BABYLON_VERSION`, never committed) and ssskit's Babylon export from a server on
127.0.0.1, renders a slab with a straight shadow edge (a directional light at 45 degrees, a blocker outside the view
casting the edge at x = 0, a perspective camera far above with a narrow field of view), and hands back
the linear float pixels after Babylon's subsurface pass, through :func:`ssskit.view.browser.headless_page`.

Where Babylon is looked for: ``$SSSKIT_BABYLON_MODULES`` (a ``node_modules`` folder), else
``.babylon/node_modules`` under the working directory (``.ci/run`` installs it there:
``npm install --prefix .babylon @babylonjs/core@VERSION``).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import threading
from functools import partial
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import numpy as np

from ..export.babylon import BABYLON_VERSION
from .browser import browser_available, headless_page

PAGE = Path(__file__).with_name("babylon_page")


def babylon_modules() -> Path:
    """The ``node_modules`` folder that should hold ``@babylonjs/core``."""
    env = os.environ.get("SSSKIT_BABYLON_MODULES")
    return Path(env) if env else Path.cwd() / ".babylon" / "node_modules"


def babylon_available() -> tuple[bool, str]:
    """``(ok, why_not)``: a headless browser and ``@babylonjs/core`` at :data:`BABYLON_VERSION`."""
    ok, why = browser_available()
    if not ok:
        return False, why
    pkg = babylon_modules() / "@babylonjs" / "core" / "package.json"
    if not pkg.is_file():
        return False, (f"@babylonjs/core is not installed in {pkg.parent.parent.parent} (npm install --prefix .babylon "
                       f"@babylonjs/core@{BABYLON_VERSION}, or set SSSKIT_BABYLON_MODULES)")
    version = json.loads(pkg.read_text()).get("version")
    if version != BABYLON_VERSION:
        return False, f"@babylonjs/core {version} is installed; the client is pinned to {BABYLON_VERSION}"
    return True, ""


class _Quiet(SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base class's name
        pass


def render_babylon(module_text: str, jobs: list[dict[str, Any]], gl: str = "swiftshader",
                   timeout_s: float = 300.0) -> list[dict[str, Any]]:
    """Render each job of ``jobs`` with the exported ES module ``module_text`` (``babylon_module``).

    A job: ``width``, ``height`` (pixels), ``extent`` (the view's half-width, scene units), ``intensity``
    (the light), ``white`` (a white PBR material without
    subsurface instead: the irradiance reference), ``material`` (a name in the export), ``variant``,
    optional ``override`` ({"color": [r, g, b], "metersPerUnit": m}: the same export with another colour,
    for the colour-question renders), ``frames``, ``shape`` ("slab", the default: the shadow edge at x = 0;
    "sphere": a sphere of ``radius`` at the origin under the same 45-degree sun, its terminator from N.L) and
    ``gbuffer`` (true: also read back what Babylon's subsurface pass reads). Returns per job {"image": (H, W, 3)
    float32, rows top down, "info": what the page reports (post-processes, profiles, filter radii, version)}
    and, with ``gbuffer``, "gbuffer": {"irradiance": (H, W, 3) the pre-pass's diffuse lighting over
    sqrt(albedo) clamped to [0, 1], "profile": (H, W) Babylon's profile index, "sss": (H, W) where its pass
    blurs (testLightingForSSS: alpha < 1, so the cleared background's 255 is out), "depth":
    (H, W) view z in scene units (16 bits over "depth_range"), "fov": the camera's vertical field of view}."""
    ok, why = babylon_available()
    if not ok:
        raise RuntimeError(why)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for f in PAGE.iterdir():
            shutil.copy(f, root / f.name)
        (root / "export.js").write_text(module_text)
        (root / "node_modules").symlink_to(babylon_modules().resolve(), target_is_directory=True)
        server = ThreadingHTTPServer(("127.0.0.1", 0), partial(_Quiet, directory=str(root)))
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        out = []
        try:
            with headless_page(gl=gl, width=4200, height=64, timeout_s=timeout_s) as (page, log):
                page.goto(f"http://127.0.0.1:{server.server_address[1]}/index.html")
                page.wait_for_function("window.ssskitReady === true")
                for job in jobs:
                    res = page.evaluate("o => window.ssskitRender(o)", {"module": "./export.js", **job})
                    img = np.asarray(res["pixels"], dtype=np.float32).reshape(job["height"], job["width"], 3)
                    item = {"image": img[::-1].copy(), "info": res["info"]}
                    if res.get("gbuffer"):
                        g = res["gbuffer"]
                        irr = np.asarray(g["irradiance"], dtype=np.float32).reshape(job["height"], job["width"], 4)
                        z = np.asarray(g["depth"], dtype=np.float32).reshape(job["height"], job["width"])
                        item["gbuffer"] = {"irradiance": irr[::-1, :, :3].copy(),
                                           "profile": np.rint(irr[::-1, :, 3] * 255.0).astype(np.int32),
                                           "sss": irr[::-1, :, 3] < 1.0,  # testLightingForSSS: alpha < 1
                                           "depth": z[::-1].copy(), "depth_range": g["depthRange"], "fov": g["fov"]}
                    out.append(item)
                log.check()
        finally:
            server.shutdown()
            server.server_close()
    return out


def crop_view(image: np.ndarray, extent: float, reach: float) -> tuple[np.ndarray, float]:
    """The columns of a slab render (half-width ``extent``) more than ``reach`` from both screen edges, and
    their half-width: Babylon's samples past the screen's edge read the other side (docs/exports.md), so the
    pixels within a filter radius of an edge are left out of every measurement."""
    width = image.shape[1]
    keep = int(round(width * (extent - reach) / (2.0 * extent)))
    if keep < 8:
        raise ValueError(f"the view (half-width {extent}) is too narrow for a reach of {reach}")
    lo = (width - 2 * keep) // 2
    return image[:, lo:lo + 2 * keep], extent * (2 * keep) / width


def babylon_gbuffer(g: dict[str, Any], depth_scale: float = 1.0) -> Any:
    """ssskit's :class:`~ssskit.screenspace.GBuffer` of what Babylon's subsurface pass read (a job's
    ``"gbuffer"`` from :func:`render_babylon`): diffuse = the pre-pass irradiance (over sqrt(albedo), so the
    albedo layer is 1 and the pass's own sqrt(albedo) factor stays outside), depth = view z (scene units; the
    page's scenes are in mm), profile id = Babylon's index where its pass blurs (0 elsewhere), and the pinhole
    camera of the page's vertical field of view with square pixels. ``depth_scale`` multiplies every depth
    step on the profiled pixels about their median depth (2: what the export's ``metersPerUnit`` x 2 does to
    Babylon's bilateral weight, ``relZ * mmPerUnit``)."""
    import math

    from ..screenspace import Camera, GBuffer

    irr = g["irradiance"]
    height, width = irr.shape[:2]
    f = 0.5 * height / math.tan(0.5 * float(g["fov"]))
    cam = Camera(width, height, f, f, 0.5 * width, 0.5 * height)
    ids = np.where(g["sss"], g["profile"], 0).astype(np.int32)
    depth = np.asarray(g["depth"], dtype=np.float32)
    if depth_scale != 1.0:
        z0 = float(np.median(depth[ids > 0]))
        depth = np.where(ids > 0, z0 + depth_scale * (depth - z0), depth).astype(np.float32)
    return GBuffer(diffuse=irr, albedo=np.ones_like(irr), depth=depth, profile_id=ids, camera=cam)


def ssskit_pass(g: dict[str, Any], albedo: Any, d_mm: Any, depth_scale: float = 1.0) -> np.ndarray:
    """ssskit's numpy Burley pass (:func:`ssskit.screenspace.burley_sss`, Golubev's stratified sampler as
    Babylon's pass, no mips, the footprint-capped 64 samples) on the read-back G-buffer
    (:func:`babylon_gbuffer`) with Burley's ``albedo`` and ``d_mm`` for Babylon's profile index 1 (the page's
    one material): the blurred irradiance (H, W, 3), to compare with Babylon's output over sqrt(albedo)."""
    from ..screenspace import BurleyParams, burley_sss

    a = [float(v) for v in albedo]
    d = [float(v) for v in d_mm]
    params = BurleyParams((a[0], a[1], a[2]), (d[0], d[1], d[2]))
    return burley_sss(babylon_gbuffer(g, depth_scale), {1: params}, sampler="golubev", spp=64, mips=False,
                      backend="numpy")


def terminator_regions(g: dict[str, Any], pixel_mm: float, d_mm: float) -> dict[str, np.ndarray]:
    """Masks of a sphere render chosen from its G-buffer alone (``"gbuffer"`` of :func:`render_babylon`), away
    from the silhouette by ``d_mm`` (where samples meet the background or a depth jump): lit (N.L, the
    irradiance's sum over its maximum, >= 0.5), twilight (0 < N.L < 0.1) and the dark side 0-1 and 1-3
    ``d_mm`` past the terminator (screen distance to the nearest lit pixel)."""
    from scipy.ndimage import distance_transform_edt

    on = g["sss"] & (g["profile"] > 0)
    s = g["irradiance"].sum(axis=-1)
    nl = s / s[on].max()
    lit = on & (nl > 1e-4)
    past = distance_transform_edt(~lit) * pixel_mm
    dark = on & ~lit
    inner = distance_transform_edt(on) * pixel_mm > d_mm
    return {"lit (N.L >= 0.5)": on & inner & (nl >= 0.5),
            "twilight (0 < N.L < 0.1)": on & inner & lit & (nl < 0.1),
            "dark, 0-1 d past": dark & inner & (past <= d_mm),
            "dark, 1-3 d past": dark & inner & (past > d_mm) & (past <= 3 * d_mm)}


__all__ = ["PAGE", "babylon_available", "babylon_gbuffer", "babylon_modules", "crop_view", "render_babylon",
           "ssskit_pass", "terminator_regions"]
