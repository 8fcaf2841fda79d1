"""The package type-checks and its public API is annotated (issue 22, item 7).

- mypy runs clean on ``src/ssskit`` under the ``[tool.mypy]`` configuration of ``pyproject.toml``: the
  pinned mypy and stub packages of the ``dev`` extra, third-party modules without stubs listed one by one.
- Every public function and method is fully annotated: each parameter (``self``/``cls`` aside, ``*args``
  and ``**kwargs`` included) and the return. Public means reachable without a leading underscore: a
  module whose dotted path has no ``_name`` part (``__init__``/``__main__`` count as the package's own),
  a function or class at its top level, and a method of such a class, all without a leading underscore.
  Functions defined inside functions are not API. Run this file as a script for the coverage figures:
  ``python tests/test_typing.py``.
"""

from __future__ import annotations

import ast
import importlib.metadata
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "ssskit"
#: what the dev extra installs for the mypy run (the stubs change what mypy reports, so they are required)
TYPING_DISTRIBUTIONS = ("mypy", "scipy-stubs", "types-tqdm", "types-PyYAML")


def public_modules(package: Path = PACKAGE) -> Iterator[Path]:
    """The package's modules reachable without a leading underscore (``__init__``/``__main__`` included)."""
    for path in sorted(package.rglob("*.py")):
        parts = path.relative_to(package.parent).with_suffix("").parts
        if not any(p.startswith("_") and p not in ("__init__", "__main__") for p in parts):
            yield path


def _defs(body: list[ast.stmt]) -> Iterator[ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef]:
    """The definitions of a module or class body, looking into ``if``/``try`` blocks (not into functions)."""
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            yield node
        elif isinstance(node, ast.If):
            yield from _defs(node.body + node.orelse)
        elif isinstance(node, ast.Try):
            yield from _defs(node.body + node.orelse + node.finalbody + [s for h in node.handlers for s in h.body])


def _missing(fn: ast.FunctionDef | ast.AsyncFunctionDef, method: bool) -> list[str]:
    """What ``fn`` lacks: the unannotated parameter names, and ``return``."""
    decorators = {d.id if isinstance(d, ast.Name) else getattr(d, "attr", "") for d in fn.decorator_list}
    a = fn.args
    positional = a.posonlyargs + a.args
    if method and "staticmethod" not in decorators and positional:
        positional = positional[1:]  # self / cls
    params = positional + a.kwonlyargs + [p for p in (a.vararg, a.kwarg) if p is not None]
    missing = [p.arg for p in params if p.annotation is None]
    if fn.returns is None:
        missing.append("return")
    return missing


def unannotated(source: str, module: str = "<source>") -> tuple[int, list[str]]:
    """(number of public functions and methods in ``source``, the offenders as ``module:line name (missing)``)."""
    count, offenders = 0, []

    def visit(body: list[ast.stmt], prefix: str, method: bool) -> None:
        nonlocal count
        for node in _defs(body):
            if node.name.startswith("_"):
                continue
            if isinstance(node, ast.ClassDef):
                visit(node.body, f"{prefix}{node.name}.", True)
                continue
            count += 1
            if missing := _missing(node, method):
                offenders.append(f"{module}:{node.lineno} {prefix}{node.name} ({', '.join(missing)})")

    visit(ast.parse(source).body, "", False)
    return count, offenders


def package_annotations(package: Path = PACKAGE) -> tuple[int, list[str]]:
    """(public functions and methods in the package, the offenders) over every public module."""
    count, offenders = 0, []
    for path in public_modules(package):
        n, bad = unannotated(path.read_text(encoding="utf-8"), str(path.relative_to(package.parent.parent)))
        count += n
        offenders += bad
    return count, offenders


def test_the_public_api_is_annotated():
    count, offenders = package_annotations()
    assert count > 300, count  # the walk found the package
    assert not offenders, f"{len(offenders)} of {count} public functions lack annotations:\n" + "\n".join(offenders)


def test_the_annotation_check_finds_what_is_missing():
    source = '''
def ok(a: int, *args: str, b: float = 1.0, **kw: object) -> None: ...
def no_return(a: int): ...
def bare(a, b: int) -> int: ...
def star(*args, **kwargs) -> None: ...
def _private(a): ...
if True:
    def in_if(a) -> None: ...
class Public:
    def method(self, x: int) -> int: ...
    def loose(self, x): ...
    @staticmethod
    def static(x) -> None: ...
    @classmethod
    def make(cls) -> "Public": ...
    def _hidden(self, x): ...
    class Inner:
        def deep(self): ...
    def outer(self) -> None:
        def nested(y): ...
class _Private:
    def method(self, x): ...
'''
    count, offenders = unannotated(source, "m")
    assert count == 11
    assert offenders == [
        "m:3 no_return (return)",
        "m:4 bare (a)",
        "m:5 star (args, kwargs)",
        "m:8 in_if (a)",
        "m:11 Public.loose (x, return)",
        "m:13 Public.static (x)",
        "m:18 Public.Inner.deep (return)",
    ]


def test_private_modules_are_not_api(tmp_path):
    for rel in ("pkg/__init__.py", "pkg/api.py", "pkg/_impl.py", "pkg/_sub/mod.py", "pkg/sub/__main__.py"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("def f(x): ...\n")
    names = [str(p.relative_to(tmp_path)) for p in public_modules(tmp_path / "pkg")]
    assert names == ["pkg/__init__.py", "pkg/api.py", "pkg/sub/__main__.py"]
    assert package_annotations(tmp_path / "pkg")[0] == 3


@pytest.mark.slow  # 30-70 s on 2 cores: CI runs it after the README's command (.ci/run)
def test_mypy_is_clean_on_the_package():
    missing = []
    for dist in TYPING_DISTRIBUTIONS:
        try:
            importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            missing.append(dist)
    if missing:
        pytest.fail(f"{', '.join(missing)} not installed: pip install \".[dev]\"")
    # the pyproject configuration (files, overrides); the incremental cache in the git-ignored .mypy_cache
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"),
         "--cache-dir", str(ROOT / ".mypy_cache"), "--no-color-output"],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
        env={**os.environ, "MYPY_FORCE_COLOR": "0"},
    )
    assert result.returncode == 0, f"mypy found errors (exit {result.returncode}):\n{result.stdout}{result.stderr}"


if __name__ == "__main__":
    total, bad = package_annotations()
    print("\n".join(bad))
    print(f"{total - len(bad)} of {total} public functions and methods fully annotated ({len(bad)} not)")
