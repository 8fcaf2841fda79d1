"""``ssskit view``: the live WebGL2 viewer (:mod:`ssskit.view`), served on 127.0.0.1 or written as a static folder."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from ..errors import SsskitError
from ..quantities import Choice, refuse_unused
from .options import OutputDir, RGBFloats, examples

RGB = tuple[float, float, float]


@click.command("view", epilog=examples(
    "ssskit view --scene bust --material skin1",
    "ssskit view --scene my_head.obj --albedo 0.8,0.6,0.5 --mfp 3.7,1.4,0.7",
    "ssskit view --scene bust --no-open --out site --presets skin1,marble"))
@click.option("--scene", default="head", show_default=True,
              help="The scanned head (head: Lee Perry-Smith, Infinite-Realities, CC BY 3.0), a generated mesh (bust, icosphere, "
                   "torus) or a mesh file (.obj, .ply, .glb, .gltf; mm).")
@click.option("--material", default=None, help="A preset name or a material file (default skin1).")
@click.option("--albedo", type=RGBFloats(), default=None,
              help="Artists' terms: the albedo R,G,B in (0, 1] (one number: grey; with --mfp).")
@click.option("--mfp", type=RGBFloats(), default=None,
              help="Artists' terms: the mean free path R,G,B in mm (one number: the same for R, G, B; with --albedo).")
@click.option("--port", type=click.IntRange(0, 65535), default=8765, show_default=True,
              help="The port on 127.0.0.1 (0: any free port).")
@click.option("--no-open", is_flag=True, help="Do not open a browser.")
@click.option("--out", "out", default=None, type=OutputDir(),
              help="Write a static folder (works from file://, presets precomputed) instead of serving.")
@click.option("--presets", default=None,
              help="--out: the presets precomputed beside the material, NAME,NAME... (default: "
                   "skin1,skin2,marble,ketchup,apple; 'none': the material alone).")
def view(scene: str, material: str | None, albedo: RGB | None, mfp: RGB | None, port: int, no_open: bool,
         out: str | None, presets: str | None) -> None:
    """A live WebGL2 viewer of a material on a mesh: the G-buffer pass, the separable and Burley passes as the
    fragment shaders ssskit export writes, composite and tone mapping, with per-pass frame times."""
    from ..materials import MATERIALS
    from ..view.site import PRESETS, MaterialRequest, check_scene, page_data, write_static

    # the request states its rules once (MaterialRequest.check: the material once, artists' terms together); an
    # empty --material is refused by name (MaterialRequest.resolve), not taken for the default
    req = MaterialRequest("skin1" if material is None and albedo is None and mfp is None else material, albedo, mfp)
    if presets is not None and out is None:
        refuse_unused(["--presets"], "a", ("static folder (--out)",), "served page, which asks the server for any preset")
    names = PRESETS if presets is None else tuple(n.strip().lower() for n in presets.split(",") if n.strip())
    if names == ("none",):
        names = ()
    names = tuple(Choice("--presets", MATERIALS.names()).check(n).lower() for n in names)
    check_scene(scene)  # (--out: a writable folder, OutputDir; what it holds: write_static, before any work)
    key = "artist" if req.material is None else str(req.material).lower()
    req.resolve()  # an unknown preset or a bad file fails here, before any work
    mats = {key: req}
    if out is not None:  # the static folder: the presets precomputed beside the chosen material
        for name in names:
            mats.setdefault(name, MaterialRequest(name))
        dest = write_static(out, scene, mats, key)
        click.echo(f"# wrote {dest}/index.html (open it from the file system: file://{dest.resolve()}/index.html)")
        if not no_open:
            import webbrowser

            webbrowser.open((dest.resolve() / "index.html").as_uri())
        return
    from ..view.server import ViewServer, serve

    data = page_data(scene, mats, key, served=True)
    references: Callable[[str, str], dict[str, Any]] | None = None
    if scene.lower() == "head":  # the head's views have path-traced references (docs/head_references.json)
        from ..figures.head import cached_reference_layers

        references = cached_reference_layers
    try:
        given = {} if req.material is None or str(req.material).lower() in MATERIALS else {key: str(req.material)}
        server = ViewServer(data, port, references=references, given=given)
    except OSError as exc:
        raise SsskitError(f"cannot listen on 127.0.0.1:{port}: {exc.strerror or exc}") from None
    click.echo(f"# ssskit view at {server.url} (Ctrl-C ends it)", err=True)
    server.warm(tuple(n for n in PRESETS if n != key))  # the presets the page lists, computed while it loads
    if not no_open:
        import webbrowser

        webbrowser.open(server.url)
    serve(server)
