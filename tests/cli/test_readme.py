"""The README runs: every ``ssskit ...`` command of its shell blocks exits with status 0, and every
```python block executes. The demo, the suite's one run of it, is the slow part (``test_readme_demo``, marked slow).

How the commands are found: in each ```sh block, every line is cut at its comment (`` #``) and at
``&&``; each part that starts with ``ssskit `` is a command (the README's and docs/commands.md's). Optional parts written ``[--json]`` /
``[--out DIR]`` are left out. Duplicates run once (``ssskit demo`` appears twice).

What runs instead of what the README says (SUBSTITUTIONS, applied in order; each entry must still
match the README, so the table cannot rot):

* the 11 presets' Monte Carlo profiles at the default 10^7 photons are shipped, so those commands run
  as written; simulations of anything else (a material file, 10^6 photons, a sweep) run at 20,000
  photons; the path-traced render is made small (256x192 -> 64x48), the adaptive run short;
* ``--scheduler tcp://host:8786`` points at a ``distributed.LocalCluster`` the test starts.

Placeholder files the README refers to are made first: ``my_material.toml`` is the README's material
file block (``name = "my skin"``), ``frame.toml`` its ``# frame.toml`` block, ``my_gbuffer.exr`` a small slab G-buffer
(``ssskit render --save-gbuffer``). Everything runs in a temporary folder with ``SSSKIT_CACHE_DIR``
inside it (a cold cache: what is not shipped is simulated here).
"""

import re
import shlex
import time
from pathlib import Path

import pytest

from ssskit.cli import main

README = Path(__file__).resolve().parents[2] / "README.md"

#: (README text, what runs instead, why). The 11 presets' Monte Carlo profiles at the default 10^7 photons
#: are shipped, so only simulations of other materials or other settings are scaled down.
SUBSTITUTIONS = [
    ("--photons 1000000", "--photons 20000", "10^6 photons per channel: ~10 s"),
    ("ssskit simulate --material skin1,marble,ketchup --jobs 2",
     "ssskit simulate --material skin1,marble,ketchup --jobs 2 --photons 20000",
     "the default 10^7 photons are shipped; 20,000 runs the two processes for real"),
    ("ssskit simulate --material skin1,marble --scheduler tcp://host:8786",
     "ssskit simulate --material skin1,marble --photons 20000 --scheduler {scheduler}",
     "a LocalCluster stands for the cluster; 20,000 photons run there for real"),
    ("--material my_material.toml --model burley --out skin.csv",
     "--material my_material.toml --model burley --photons 20000 --out skin.csv",
     "a material of one's own is simulated: 10^7 photons take minutes"),
    ("--size 256x192 --out s.exr --reference", "--size 64x48 --out s.exr --reference", "path tracing 256x192"),
    ("--frames 8 --limit-spp 256", "--frames 2 --limit-spp 16", "converged references of 8 frames"),
]
#: commands the fast test leaves to the slow one (the demo: minutes)
SLOW = ("ssskit demo",)
#: the files whose shell blocks hold the commands (the README's, and the details page it links)
SOURCES = [README, README.parent / "docs" / "commands.md"]


def blocks(text: str, *languages: str) -> list[str]:
    """The bodies of the fenced code blocks of ``languages``."""
    pattern = r"^```(" + "|".join(languages) + r")[ \t]*\n(.*?)^```"
    return [m.group(2) for m in re.finditer(pattern, text, flags=re.M | re.S)]


def commands(text: str) -> list[str]:
    """Every ``ssskit ...`` command of the README's shell blocks, substituted, once each."""
    out: list[str] = []
    for block in blocks(text, "sh", "bash", "console"):
        for line in block.splitlines():
            line = line.split(" #")[0]
            for part in line.split("&&"):
                part = re.sub(r"\s*\[[^\]]*\]", "", part).strip()
                if not part.startswith("ssskit "):
                    continue
                for old, new, _why in SUBSTITUTIONS:
                    part = part.replace(old, new)
                if part not in out:
                    out.append(part)
    return out


def test_substitutions_match_the_readme():
    text = "".join(p.read_text(encoding="utf-8") for p in SOURCES)
    for old, _new, why in SUBSTITUTIONS:
        assert old in text, f"substitution {old!r} ({why}) no longer matches the README or docs/commands.md"


@pytest.fixture(scope="module")
def scheduler():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://",
                                  host="127.0.0.1", dashboard_address=":0") as cluster:
        yield cluster.scheduler_address


def _placeholders(tmp_path: Path, text: str, capsys) -> None:
    """The files the README refers to: its material file, its settings file, a small G-buffer."""
    toml = blocks(text, "toml")
    (tmp_path / "my_material.toml").write_text(next(b for b in toml if b.startswith("name = ")))
    (tmp_path / "frame.toml").write_text(next(b for b in toml if b.startswith("# frame.toml")))
    assert main(["render", "--scene", "slab", "--size", "48x36", "--spp", "2", "--no-exact", "--no-perceptual",
                 "--save-gbuffer", "my_gbuffer.exr", "--json"]) == 0
    capsys.readouterr()


def _run(cmd: str, scheduler: str, capsys) -> tuple[str, float]:
    argv = shlex.split(cmd.format(scheduler=scheduler))[1:]
    t0 = time.perf_counter()
    code = main(argv)
    seconds = time.perf_counter() - t0
    out, err = capsys.readouterr()
    assert code == 0, f"{cmd}\n{err}"
    return out, seconds


def test_readme_commands_and_python_run(tmp_path, monkeypatch, capsys, scheduler):
    """Every command of the README and of docs/commands.md but the demo (``test_readme_demo``), and every
    python block, in a fresh folder and cache."""
    text = "".join(p.read_text(encoding="utf-8") for p in SOURCES)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    _placeholders(tmp_path, text, capsys)
    cmds = [c for c in commands(text) if not c.startswith(SLOW)]
    assert len(cmds) >= 20
    seconds = {cmd: _run(cmd, scheduler, capsys)[1] for cmd in cmds}
    print("\n".join(f"{s:7.1f} s  {c}" for c, s in seconds.items()))
    for i, block in enumerate(blocks(text, "python")):
        exec(compile(block, f"python block {i + 1}", "exec"), {"__name__": f"readme_{i}"})


@pytest.mark.slow
def test_readme_demo(tmp_path, monkeypatch, capsys):
    """The README's ``ssskit demo``, as written, in a fresh folder and cache (the suite's one demo)."""
    text = README.read_text(encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    demos = [c for c in commands(text) if c.startswith(SLOW)]
    assert demos == ["ssskit demo"]
    out, _ = _run(demos[0], "", capsys)
    check_demo_report(tmp_path / "ssskit-out" / "demo", out)


def check_demo_report(folder: Path, stdout: str) -> None:
    """What ``ssskit demo`` writes: the report's index (its path on stdout), every section."""
    index = folder / "index.html"
    assert stdout.strip() == str(Path("ssskit-out/demo") / "index.html") or Path(stdout.strip()) == index
    page = index.read_text()
    for name in ("Apple", "Skin1", "Wholemilk"):
        assert f"profile_{name.lower()}.png" in page
        assert (folder / f"profile_{name.lower()}.png").stat().st_size > 10_000
    assert "2.5715" in page and "minimax" in page
    assert "MCML" in page and "montecarlo" in page
    assert "figures/screenspace.png" in page and (folder / "figures" / "screenspace.png").is_file()
