"""``ssskit backends``: every registered backend, whether it runs here, and why not."""

from __future__ import annotations

import click

from .options import echo_json, examples, json_option


@click.command(epilog=examples("ssskit backends", "ssskit backends --json"))
@json_option("Print one JSON object: {name: {available, details, description}}.")
def backends(as_json: bool) -> None:
    """List the backends of the screen-space passes: available here or why not."""
    from ..backends import DEFAULT_BACKEND, backend_status

    status = backend_status()
    if as_json:
        echo_json({"default": DEFAULT_BACKEND, "backends": status})
        return
    width = max((len(n) for n in status), default=7)
    for name, s in status.items():
        state = "available" if s["available"] else "not available"
        click.echo(f"{name:<{width}}  {state:<13}  {s['description']}")
        if s["details"]:
            click.echo(f"{'':<{width}}  {'':<13}  {'' if s['available'] else 'why not: '}{s['details']}")
    click.echo(f"default: {DEFAULT_BACKEND}")
