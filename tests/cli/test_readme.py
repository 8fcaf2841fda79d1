"""The README runs: every ``ssskit ...`` command of its shell blocks exits with status 0, and every
```python block executes. This is also the suite's one run of ``ssskit demo``.

How the commands are found: in each ```sh block, every line is cut at its comment (`` #``) and at
``&&``; each part that starts with ``ssskit `` is a command. Optional parts written ``[--json]`` /
``[--out DIR]`` are left out. Duplicates run once (``ssskit demo`` appears twice).

What runs instead of what the README says (SUBSTITUTIONS, applied in order; each entry must still
match the README, so the table cannot rot):

* slow Monte Carlo settings are scaled down: the demo and every command with a Monte Carlo profile
  (200,000 photons per channel by default) run at 5,000 photons (the demo runs first and fills the
  cache the others read), ``simulate`` at 20,000 instead of 10^6 / 10^7; the path-traced render is
  made small (256x192 -> 64x48);
* ``--scheduler tcp://host:8786`` points at a ``distributed.LocalCluster`` the test starts.

Placeholder files the README refers to are made first: ``my_material.toml`` is the README's material
file block (``name = "my skin"``), ``frame.toml`` its ``# frame.toml`` block, ``my_gbuffer.exr`` a small slab G-buffer
(``ssskit render --save-gbuffer``). Everything runs in a temporary folder with ``SSSKIT_CACHE_DIR``
inside it (a cold cache: every Monte Carlo profile is simulated here).
"""

import re
import shlex
import time
from pathlib import Path

import pytest

from ssskit.cli import main

README = Path(__file__).resolve().parents[2] / "README.md"

#: (README text, what runs instead, why). Monte Carlo profiles run at the demo's 5,000 photons per
#: channel, so every later command finds them in the cache the demo filled.
MC = "--photons 5000"
SUBSTITUTIONS = [
    ("ssskit demo", f"ssskit demo {MC}", "200,000 photons per channel for 11 materials: minutes"),
    ("--photons 1000000", "--photons 20000", "10^6 photons per channel: ~10 s"),
    ("ssskit simulate --material skin1,marble,ketchup --jobs 2",
     "ssskit simulate --material skin1,marble,ketchup --jobs 2 --photons 20000", "the default 10^7 photons: minutes"),
    ("ssskit simulate --material skin1,marble --scheduler tcp://host:8786",
     "ssskit simulate --material skin1,marble --photons 20000 --scheduler {scheduler}",
     "a LocalCluster stands for the cluster; 10^7 photons: minutes"),
    ("--model montecarlo --plot m.png", f"--model montecarlo {MC} --plot m.png", "Monte Carlo, 200,000 photons"),
    ("--method preintegrated --out k.npz", f"--method preintegrated {MC} --out k.npz", "Monte Carlo, 200,000 photons"),
    ("--method svd --rank 3 --json", f"--method svd --rank 3 {MC} --json", "Monte Carlo, 200,000 photons"),
    ("--methods svd:1,svd:3,preintegrated,guided:0 --json", f"--methods svd:1,svd:3,preintegrated,guided:0 {MC} --json",
     "Monte Carlo, 200,000 photons"),
    ("ssskit figures fig7 figS5 --material skin1", f"ssskit figures fig7 figS5 --material skin1 {MC}",
     "Monte Carlo, 200,000 photons"),
    ("--size 256x192 --out s.exr --reference", "--size 64x48 --out s.exr --reference", "path tracing 256x192"),
]


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
    text = README.read_text(encoding="utf-8")
    for old, _new, why in SUBSTITUTIONS:
        assert old in text, f"substitution {old!r} ({why}) no longer matches the README"


@pytest.fixture(scope="module")
def scheduler():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://",
                                  host="127.0.0.1", dashboard_address=":0") as cluster:
        yield cluster.scheduler_address


@pytest.mark.slow
def test_readme_commands_and_python_run(tmp_path, monkeypatch, capsys, scheduler):
    text = README.read_text(encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    # placeholder files the README refers to
    toml = blocks(text, "toml")
    (tmp_path / "my_material.toml").write_text(next(b for b in toml if b.startswith("name = ")))
    (tmp_path / "frame.toml").write_text(next(b for b in toml if b.startswith("# frame.toml")))
    assert main(["render", "--scene", "slab", "--size", "48x36", "--spp", "2", "--no-exact", "--no-perceptual",
                 "--save-gbuffer", "my_gbuffer.exr", "--json"]) == 0
    capsys.readouterr()

    cmds = commands(text)
    assert len(cmds) >= 20 and "ssskit demo --photons 5000" in cmds
    seconds = {}
    for cmd in cmds:
        argv = shlex.split(cmd.format(scheduler=scheduler))[1:]
        t0 = time.perf_counter()
        code = main(argv)
        seconds[cmd] = time.perf_counter() - t0
        out, err = capsys.readouterr()
        assert code == 0, f"{cmd}\n{err}"
        if argv[0] == "demo":
            demo_out = out
    print("\n".join(f"{s:7.1f} s  {c}" for c, s in seconds.items()))
    check_demo_report(tmp_path / "ssskit-out" / "demo", demo_out)

    for i, block in enumerate(blocks(text, "python")):
        exec(compile(block, f"README.md python block {i + 1}", "exec"), {"__name__": f"readme_{i}"})


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
