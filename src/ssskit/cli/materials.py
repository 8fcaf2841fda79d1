"""``ssskit materials``: the preset materials and the artist-friendly presets."""

from __future__ import annotations

import click

from .options import echo_json, examples, json_option


@click.command(epilog=examples("ssskit materials", "ssskit materials --json"))
@json_option()
def materials(as_json: bool) -> None:
    """List the preset materials with their coefficients (mm^-1)."""
    from ..materials import ARTIST_PRESETS, MATERIALS

    if as_json:
        echo_json(
            {
                "materials": {name: m.summary() for name, m in MATERIALS.items()},
                "artist_presets": {
                    name: {"sigma_near": p.sigma_near, "sigma_far": p.sigma_far, "weight": p.weight, "source": p.source}
                    for name, p in ARTIST_PRESETS.items()
                },
            }
        )
        return
    click.echo(f"{'material':<10} {'sigma_a [R G B] (mm^-1)':<26} {'sigma_s [R G B] (mm^-1)':<26} {'eta':>4}  mfp [R G B] (mm)")
    for name, m in MATERIALS.items():
        sa = " ".join(f"{v:.4f}" for v in m.sigma_a)
        ss = " ".join(f"{v:.4f}" for v in m.sigma_s)
        mfp = " ".join(f"{v:.3f}" for v in m.mfp_mm)
        click.echo(f"{name:<10} {sa:<26} {ss:<26} {m.eta:>4.2f}  {mfp}")
    click.echo("\nartist-friendly two-Gaussian presets (paper Table 2): " + ", ".join(ARTIST_PRESETS.names()))
