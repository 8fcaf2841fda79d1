"""The viewer's golden screenshots: one per pass of the static bust page (Skin1, 192x144, SwiftShader), compared by
FLIP in tests/view/test_view.py. Regenerate them (after a deliberate change of the page or a pass) with

    PYTHONPATH=src python -m tests.view.goldens

which writes tests/view/goldens/<pass>.png; look at them before committing."""
from __future__ import annotations

import base64
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent / "goldens"
#: the page's size for the goldens (the tests' size)
W, H = 192, 144
#: pass name -> the page state of its frame (adaptive: the third frame of a new history)
STATES = {
    "off": {"pass": "off", "transmission": False},
    "separable": {"pass": "separable", "transmission": False},
    "burley": {"pass": "burley", "spp": 16, "transmission": False},
    "adaptive": {"pass": "adaptive", "transmission": False},
    "transmission": {"pass": "separable", "transmission": True, "light": {"az": 2.6, "el": 0.3, "scale": 1}},
}


def frames(page) -> dict[str, np.ndarray]:
    """(H, W, 3) uint8 displayed frame per pass (rows from the top), the page left as it was found."""
    out = {}
    for name, state in STATES.items():
        page.evaluate(f"() => window.ssskit.set({json.dumps({'auto': False, 'material': 'skin1', 'seed': 0, **state})})")
        for _ in range(3 if name == "adaptive" else 1):
            page.evaluate("() => window.ssskit.render()")
        raw = base64.b64decode(page.evaluate("() => window.ssskit.readDisplay()"))
        out[name] = np.frombuffer(raw, np.uint8).reshape(H, W, 4)[::-1, :, :3].copy()
    page.evaluate("() => window.ssskit.set({auto: true, pass: 'separable', transmission: true, "
                  "light: {az: 0, el: 0, scale: 1}})")
    return out


def main() -> None:
    import imageio.v3 as iio

    from ssskit.view.browser import headless_page

    with tempfile.TemporaryDirectory() as tmp:
        site = Path(tmp) / "site"
        subprocess.run([sys.executable, "-m", "ssskit", "view", "--scene", "bust", "--no-open", "--out", str(site),
                        "--presets", "none"], check=True)
        with headless_page(width=W + 320, height=max(H, 500)) as (page, log):
            page.goto((site / "index.html").as_uri() + f"?w={W}&h={H}")
            page.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=60_000)
            shots = frames(page)
            log.check()
    HERE.mkdir(exist_ok=True)
    for name, img in shots.items():
        iio.imwrite(HERE / f"{name}.png", img)
        print(f"wrote {HERE / name}.png")


if __name__ == "__main__":
    main()
