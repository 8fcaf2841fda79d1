"""The screenshot of the served viewer's controls in docs/view.md (docs/img/view-controls.png): ``ssskit view
--scene head`` served (the server's code, in this process), the front view with Skin1, the path-traced reference
beside the frame (from ssskit's reference cache: ``python docs/head_references.py`` renders it; without it the
panel says so), taken in headless Chromium through ssskit.view.browser (SwiftShader).

    PYTHONPATH=src python docs/view_screenshot.py [--out docs/img/view-controls.png] [--size 480x270]
"""

from __future__ import annotations

import argparse
import io
import sys
import threading


def main(argv: list[str] | None = None) -> None:
    from ssskit.figures.head import cached_reference_layers
    from ssskit.view.browser import headless_page
    from ssskit.view.server import ViewServer
    from ssskit.view.site import MaterialRequest, page_data

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/img/view-controls.png")
    ap.add_argument("--size", default="480x270")
    args = ap.parse_args(argv)
    w, _, h = args.size.partition("x")
    width, height = int(w), int(h)
    log = io.StringIO()
    srv = ViewServer(page_data("head", {"skin1": MaterialRequest("skin1")}, "skin1", served=True), 0, log,
                     references=cached_reference_layers)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    try:
        with headless_page(width=width + 720, height=max(height, 880)) as (page, plog):
            page.goto(srv.url + f"?w={width}&h={height}")
            page.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=180_000)
            page.evaluate("() => window.ssskit.ready()")
            page.evaluate("() => window.ssskit.showReference(true)")
            page.evaluate("() => window.ssskit.render()")
            page.evaluate("() => window.ssskit.referenceLevels()")
            page.screenshot(path=args.out)
            plog.check()
    finally:
        srv.shutdown()
        srv.server_close()
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
