"""The fast cross-section of benchmarks/hostile_inputs.py's catalogue (every command; crashing meshes, deep
documents, wrong types, outputs equal to inputs, ...): each case, run as a user runs it (a subprocess in a folder
of its own), exits 2 with one line ``ssskit: error: ...``, nothing on stdout, nothing written. The whole catalogue
is ``python benchmarks/hostile_inputs.py`` (its JSON also gives the wall time per case)."""

import importlib.util
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "hostile_inputs.py"
_spec = importlib.util.spec_from_file_location("hostile_inputs", _PATH)
hostile = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(hostile)


@pytest.fixture(scope="module")
def fast_results():
    cases = [(n, a) for n, a in hostile.CASES if n in hostile.FAST]
    with ThreadPoolExecutor(max_workers=2) as pool:
        return {r["name"]: r for r in pool.map(lambda c: hostile.run_case(*c, timeout_s=120), cases)}


@pytest.mark.parametrize("name", hostile.FAST)
def test_a_hostile_input_is_one_error_line_and_nothing_written(fast_results, name):
    r = fast_results[name]
    # heartbeat lines come only from a machine so loaded that a refusal takes over 8 s: not counted here
    assert r["exit"] == 2 and r["stderr_lines"] - r["heartbeat_lines"] == 1 and r["stdout_bytes"] == 0, r
    assert r["stderr"].splitlines()[-1].startswith("ssskit: error: ") and "Traceback" not in r["stderr"], r
    assert r["written"] == [], r


def test_the_catalogue_holds_150_distinct_cases_across_every_command():
    names = [n for n, _ in hostile.CASES]
    assert len(names) >= 150 and len(set(names)) == len(names)
    commands = {a[0] for _, a in hostile.CASES}
    assert {"profile", "simulate", "xie-c", "kernel", "evaluate", "render", "export", "figures", "demo",
            "materials", "backends"} <= commands
    assert set(hostile.FAST) <= set(names)
