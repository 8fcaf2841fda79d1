"""benchmarks/validation_count.py counts what issue 34 defines (an AST scan for ``raise``, ``if ...: raise`` and
``check*``/``validate*`` definitions and calls), and the package keeps one phrasing per finiteness and range rule
(issue 34, Must show: "Distinct finiteness and range phrasings: at most one template each")."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

spec = importlib.util.spec_from_file_location("validation_count", ROOT / "benchmarks" / "validation_count.py")
vc = importlib.util.module_from_spec(spec)
spec.loader.exec_module(vc)

SAMPLE = '''\
def check_a(x):          # 1  a check definition: lines 1-3
    if x < 0:            # 2
        raise ValueError(f"x must lie in [0, 1], got {x}")
def f(x):                # 4
    check_a(             # 5  a call over two lines
        x)               # 6
    try:                 # 7
        pass             # 8
    except KeyError:     # 9
        raise            # 10 a bare re-raise: not validation
    if (x > 1 and        # 11 an if whose body is one raise: its test lines
            x < 5):      # 12
        raise ValueError(f"x must be finite, got {x}")    # 13
    if x == 7:           # 14 not one raise: not counted
        x += 1
        raise KeyError("the slab is finite slab-wise, a finite slab")
'''


def test_the_count_follows_the_issues_definition():
    out = vc.scan({"src/sample.py": SAMPLE})
    # 1-3 (definition), 5-6 (call), 11-13 (if test + raise), 16 (a raise); not 10 (bare raise), not 14
    assert out["validation_lines"] == 9
    assert out["statements"] == {"check_def": 1, "if_raise": 2, "raise": 3, "check_call": 1}
    assert out["finiteness"]["list"] == ["must be finite"]  # "a finite slab" is a kind of slab, not finiteness
    assert out["range"]["list"] == ["must lie in [#, #]"]


def test_the_strict_reading_also_counts_refusing_helpers_and_guarded_checks():
    src = ('def refuse_x(names):\n'      # 1-3: a refusing helper's definition
           '    if names:\n'
           '        raise ValueError("x applies to y")\n'
           'def f(a, b):\n'              # 4
           '    refuse_x([a] if b else [])\n'   # 5: its call
           '    if a > b:\n'              # 6: an if whose body is one validator call: its test line
           '        check_y(a)\n'         # 7: a check call (both readings)
           '    return a\n')
    out = vc.scan({"src/s.py": src})
    assert out["validation_lines"] == 3  # 2-3 (if test + raise), 7 (the check call); refuse_x is no check* name
    assert out["validation_lines_strict"] == 6  # and the helper's definition (1-3), its call (5), the if's test (6)


def test_version_specifiers_and_places_are_not_ranges():
    src = ('def f():\n    raise ImportError("it needs pkg: pip install \\"pkg>=1.39,<1.40\\"")\n'
           'def g():\n    raise ValueError("no pixel: the object is outside the frame")\n'
           'def h(v):\n    raise ValueError(f"v must be >= 0, got {v}")\n')
    assert vc.scan({"src/s.py": src})["range"]["list"] == ["must be >= #"]


def test_the_package_has_one_phrasing_per_finiteness_and_range_rule():
    out = vc.scan(vc._files(ROOT, None))
    assert out["finiteness"]["list"] == ["must be finite"], out["finiteness"]["list"]
    assert out["range"]["list"] == ["must lie in ##"], out["range"]["list"]
