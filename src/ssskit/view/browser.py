"""One headless-browser driver for every client that runs in a browser here.

The live viewer's tests, ``benchmarks/bench_view.py`` and the Babylon.js client tests all open pages
through :func:`headless_page`: Playwright for Python driving the system's Chromium (Debian's
``chromium`` package; Playwright's own browser download is never used, so nothing is fetched). A page
may load ``file://`` URLs and 127.0.0.1 only: any other request is aborted and recorded, so a page that
reaches for the internet fails its test instead of silently passing offline.

The renderer is chosen by ``gl``: ``"swiftshader"`` (ANGLE on SwiftShader's Vulkan, Chromium's software
GPU, the default on a machine without one), ``"gl"`` (ANGLE on the system's OpenGL ES through EGL: Mesa's
llvmpipe here, a real GPU on a desktop; ``--use-angle=gl`` alone fell back to SwiftShader in Chromium 156, while
``--use-gl=angle --use-angle=gl-egl`` starts it) or ``"default"`` (Chromium's own choice).
"""
from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from ..quantities import Choice

#: where the system Chromium is looked for, after ``$SSSKIT_CHROMIUM``
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

#: Chromium's flags per renderer (``gl=``)
GL_FLAGS = {
    "swiftshader": ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"],
    "gl": ["--use-gl=angle", "--use-angle=gl-egl", "--ignore-gpu-blocklist"],
    "default": [],
}

#: the performance notes Chromium logs as console errors on a software renderer (not the page's own)
BENIGN_CONSOLE = ("GPU stall due to ReadPixels", "GL_CLOSE_PATH_NV", "Automatic fallback to software WebGL")


def chromium_path() -> str | None:
    """The Chromium executable: ``$SSSKIT_CHROMIUM`` if set, else the first of :data:`CHROMIUM_NAMES` on PATH."""
    env = os.environ.get("SSSKIT_CHROMIUM")
    if env:
        return env if os.path.exists(env) else None
    for name in CHROMIUM_NAMES:
        found = shutil.which(name)
        if found:
            return found
    return None


def browser_available() -> tuple[bool, str]:
    """``(ok, why_not)``: whether :func:`headless_page` can run here (Playwright importable, Chromium found)."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return False, "Playwright for Python is not installed (pip install playwright)"
    if chromium_path() is None:
        return False, "no Chromium found (apt-get install chromium, or set SSSKIT_CHROMIUM)"
    return True, ""


@dataclass
class PageLog:
    """What a page said while it ran: console errors (less :data:`BENIGN_CONSOLE`), uncaught exceptions
    and the requests that were refused because they left this machine."""

    errors: list[str] = field(default_factory=list)
    blocked: list[str] = field(default_factory=list)
    messages: list[str] = field(default_factory=list)

    def check(self) -> None:
        """Raise ``AssertionError`` naming every error and blocked request, if any."""
        problems = [f"console error: {e}" for e in self.errors] + [f"blocked request: {u}" for u in self.blocked]
        if problems:
            raise AssertionError("; ".join(problems))


def _local(url: str) -> bool:
    if url.startswith(("file:", "data:", "blob:", "about:")):
        return True
    from urllib.parse import urlsplit

    host = urlsplit(url).hostname or ""
    return host in ("127.0.0.1", "localhost", "[::1]", "::1")


@contextmanager
def headless_page(
    *, gl: str = "swiftshader", width: int = 800, height: int = 600, timeout_s: float = 60.0
) -> Iterator[tuple[Any, PageLog]]:
    """A fresh headless Chromium page and its :class:`PageLog`; the browser closes on exit.

    ``gl`` picks the renderer (:data:`GL_FLAGS`). Non-local requests are aborted and logged. Raises
    ``RuntimeError`` with the reason where :func:`browser_available` says no.
    """
    ok, why = browser_available()
    if not ok:
        raise RuntimeError(why)
    gl = Choice("gl", tuple(GL_FLAGS)).check(gl)
    from playwright.sync_api import sync_playwright

    log = PageLog()
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium_path(), args=GL_FLAGS[gl], headless=True)
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.set_default_timeout(timeout_s * 1000)

            def on_console(msg: Any) -> None:
                text = msg.text
                log.messages.append(f"{msg.type}: {text}")
                if msg.type == "error" and not any(b in text for b in BENIGN_CONSOLE):
                    log.errors.append(text)

            def on_route(route: Any) -> None:
                url = route.request.url
                if _local(url):
                    route.continue_()
                else:
                    log.blocked.append(url)
                    route.abort()

            page.on("console", on_console)
            page.on("pageerror", lambda exc: log.errors.append(str(exc)))
            page.route("**/*", on_route)
            yield page, log
        finally:
            browser.close()
