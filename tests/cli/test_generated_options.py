"""The options of ``render`` and ``export`` are generated from the declared settings fields (issue 34, build 2):
name, type, default and the range in the help come from the field and its quantity, and the settings class
checks the value once, the error naming the option."""

import dataclasses

import click
import pytest
from click.testing import CliRunner

from ssskit.cli import cli
from ssskit.cli.options import SettingOption, setting_option
from ssskit.cli.render_options import own
from ssskit.export import ExportSettings
from ssskit.pipeline.settings import PASSES, RenderSettings
from ssskit.quantities import Choice, Flag, Quantity
from ssskit.settings import Settings, setting


@dataclasses.dataclass(frozen=True)
class Toy(Settings):
    n: int = setting(Quantity("n", 1, 9, "", "a toy's count", integer=True), 3)
    mode: str = setting(Choice("mode", ("a", "b")), "a")
    on: bool = setting(Flag("on"), False)


@click.command()
@setting_option(Toy, "n")
@setting_option(Toy, "mode")
@setting_option(Toy, "on")
@click.pass_context
def toy(ctx: click.Context, **values: object) -> None:
    changes = {k: v for p in ctx.command.params if isinstance(p, SettingOption) and p.name
               for k, v in p.changes(ctx.params[p.name]).items()}
    click.echo(repr(Toy(**changes)))


def test_an_option_takes_its_fields_name_type_default_and_range():
    r = CliRunner().invoke(toy, ["--help"])
    text = " ".join(r.output.split())
    assert "--n INTEGER a toy's count (in [1, 9]). [default: 3]" in text
    assert "--mode [a|b]" in text and "[default: a]" in text and "--on " in text
    assert CliRunner().invoke(toy, []).output.strip() == repr(Toy())
    assert CliRunner().invoke(toy, ["--n", "5", "--mode", "B", "--on"]).output.strip() == repr(Toy(5, "b", True))
    # the range is the settings class's to check (one rule, one wording)
    r = CliRunner().invoke(toy, ["--n", "12"])
    assert r.exit_code != 0 and "n must lie in [1, 9], got 12 (a toy's count)" in str(r.exception)


def _generated(command: str) -> list[SettingOption]:
    return [p for p in cli.commands[command].params if isinstance(p, SettingOption)]


@pytest.mark.parametrize("command", ["render", "export"])
def test_every_generated_option_has_its_fields_default_and_range(command):
    options = _generated(command)
    assert len(options) >= (30 if command == "render" else 15)
    for p in options:
        fields = {f.name: f for f in dataclasses.fields(p.settings_class)}
        f = fields[p.fields[0]]
        q = f.metadata["quantity"]
        default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
        if p.invert:
            assert p.default is False and p.changes(True) == {f.name: not default}
        elif len(p.fields) == 1 and p.convert is None:
            assert p.default == default, p.name
            if isinstance(q, Quantity):
                assert q.interval in (p.help or ""), p.name  # the range, stated by the quantity


def test_render_options_belong_to_the_pass_of_their_settings_class():
    owned = own(cli.commands["render"].params)
    for p in _generated("render"):
        cls = p.settings_class
        if cls is not RenderSettings:
            assert p.name in owned[cls.name], (p.name, cls.name)
    # the top-level fields declared to apply to the separable pass only
    assert {"model", "photons", "taps", "tap_method", "kernel_spec"} <= set(owned["separable"])
    assert set(owned) == set(PASSES.names())


def test_export_options_are_the_export_settings_fields():
    names = {p.fields[0] for p in _generated("export") if p.settings_class is ExportSettings}
    declared = {f.name for f in dataclasses.fields(ExportSettings) if f.metadata.get("quantity") is not None}
    assert declared - {"format"} == names
