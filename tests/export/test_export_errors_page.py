"""docs/exports.md's error tables are docs/export_errors.py's output: two rows of each table (the
Monte Carlo source, read from the shipped profiles, and the dipole's) recomputed and found on the page
verbatim. The page had lost a column (Unreal clamps) and kept stale encoding losses."""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _script():
    spec = importlib.util.spec_from_file_location("export_errors_page", ROOT / "docs" / "export_errors.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("model, heading", [("montecarlo", "Source: Monte Carlo"), ("dipole", "Source: the dipole")])
def test_the_pages_tables_are_the_scripts_output(model, heading):
    ee = _script()
    page = (ROOT / "docs" / "exports.md").read_text(encoding="utf-8")
    section = page[page.index(heading):]
    table = section[section.index("| material |"):].split("\n\n")[0]
    printed = ee.summary(ee.table(model, ["skin1", "ketchup"])).splitlines()
    assert printed[:2] == table.splitlines()[:2]  # the header, every column
    for row in printed[2:]:
        assert row in table.splitlines(), row
