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
    for the colour-question renders) and ``frames``. Returns per job {"image": (H, W, 4) float32, rows top
    down, "info": what the page reports (post-processes, profiles, filter radii, version)}."""
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
                    out.append({"image": img[::-1].copy(), "info": res["info"]})
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


__all__ = ["PAGE", "crop_view", "babylon_available", "babylon_modules", "render_babylon"]
