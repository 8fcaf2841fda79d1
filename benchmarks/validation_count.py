"""Count validation lines in ``src/`` the way issue 34 does, and the distinct phrasings of finiteness and range
messages; print JSON.

Validation lines: an AST scan of every ``.py`` under ``src/`` for

* ``raise X(...)`` statements (a bare ``raise`` that re-raises is not validation), every line they span;
* ``if ...: raise``: the test lines of an ``if`` whose body is one ``raise``;
* definitions of functions named ``check*`` / ``validate*`` (leading underscores allowed), every line;
* calls of such functions, every line they span;

counted once per (file, line). On 2b209c2 this gives 2,558 (the issue says 2,555).

``validation_lines_strict``: the same scan read more strictly, so that a rule moved into a helper of another name
still counts: functions named ``refuse*`` (``quantities.refuse_unused``, ``refuse_twice``, ...) count as
definitions and calls like ``check*``, and an ``if`` whose body is one call of such a function counts its test
lines like ``if ...: raise``. On 2b209c2: 2,562.

Phrasings: the message of every ``raise`` (a string, an f-string with ``{}`` for its fields, or a sum of them) that
speaks of finiteness (``finite``, ``NaN``, ``inf``) or of a range (``must lie in``, ``>=``, ``in [``, ``positive``,
...), reduced to its predicate: from the first verb (``must``, ``holds``, ``has``, ``is``, ``needs``...) up to
``got``, with fields and numbers replaced by ``#``. The templates of :mod:`ssskit.quantities` count as one
phrasing each, wherever they are used.

    python benchmarks/validation_count.py                # the working tree's src/
    python benchmarks/validation_count.py --rev 2b209c2  # a commit's src/ (git archive)
"""

from __future__ import annotations

import argparse
import ast
import json
import re
import subprocess
import sys
import tarfile
import io
from collections import Counter
from pathlib import Path

VALIDATOR = re.compile(r"^_*(check|validate)", re.IGNORECASE)
#: the strict reading's validators: also the refusing helpers
STRICT = re.compile(r"^_*(check|validate|refuse)", re.IGNORECASE)
# "finite" as a property of a value, not of a thing ("a finite slab", "a finite medium": a slab's kind)
FINITE = re.compile(r"\bfinite\b(?! (slab|medium|thickness|layer))|\bnan\b|\binf\b", re.IGNORECASE)
# a comparison with a number, not a version specifier ("materialx>=1.39": the operator follows a name); "outside"
# an interval, not "outside the frame" (a place)
RANGE = re.compile(r"must (lie|be) (in|between|within)|must be (>|<|at least|at most|positive|non-negative)|"
                   r"(?<![\w\],])[<>]=? ?[-0-9{]|\bin [\[(][-0-9{]|out of range|"
                   r"outside (the |its |a )?(range|interval|domain|bounds|[\[(])", re.IGNORECASE)
VERB = re.compile(r"\b(must|holds?|has|have|is|are|needs?|takes?)\b", re.IGNORECASE)


def _callee(func: ast.expr) -> str:
    return func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""


def _template(node: ast.expr) -> str | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr):
        return "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in node.values)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        a, b = _template(node.left), _template(node.right)
        return None if a is None or b is None else a + b
    if isinstance(node, ast.Call) and _callee(node.func) == "format" and isinstance(node.func, ast.Attribute):
        return _template(node.func.value)
    return None


def _phrasing(message: str) -> str:
    m = VERB.search(message)
    text = message[m.start():] if m else message
    text = re.split(r",? got\b|;", text)[0]
    text = re.sub(r"\{[^}]*\}|[-+]?\d[\d.e+\-_^]*", "#", text)
    return re.sub(r"\s+", " ", text).strip().lower()


def scan(files: dict[str, str]) -> dict:
    lines: set[tuple[str, int]] = set()
    strict: set[tuple[str, int]] = set()
    kinds = Counter()
    finite: list[str] = []
    ranges: list[str] = []
    for path, text in sorted(files.items()):
        tree = ast.parse(text)
        src = text.splitlines()

        def add(a: int, b: int, kind: str) -> None:
            kinds[kind] += 1
            lines.update((path, n) for n in range(a, b + 1))
            strict.update((path, n) for n in range(a, b + 1))

        def add_strict(a: int, b: int) -> None:
            strict.update((path, n) for n in range(a, b + 1))

        for node in ast.walk(tree):
            if isinstance(node, ast.Raise) and node.exc is not None:
                add(node.lineno, node.end_lineno or node.lineno, "raise")
                exc = node.exc
                if isinstance(exc, ast.Call) and _callee(exc.func) == "fail":
                    continue  # a quantities template, counted once below
                msg = _template(exc.args[0]) if isinstance(exc, ast.Call) and exc.args else None
                if msg:
                    if FINITE.search(msg):
                        finite.append(f"{path}:{node.lineno}: {msg}")
                    elif RANGE.search(msg):
                        ranges.append(f"{path}:{node.lineno}: {msg}")
            elif isinstance(node, ast.If) and len(node.body) == 1 and isinstance(node.body[0], ast.Raise):
                add(node.lineno, node.test.end_lineno or node.lineno, "if_raise")
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and VALIDATOR.match(node.name):
                add(node.lineno, node.end_lineno or node.lineno, "check_def")
            elif isinstance(node, ast.Call) and VALIDATOR.match(_callee(node.func)):
                add(node.lineno, node.end_lineno or node.lineno, "check_call")
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and STRICT.match(node.name):
                add_strict(node.lineno, node.end_lineno or node.lineno)
            elif isinstance(node, ast.Call) and STRICT.match(_callee(node.func)):
                add_strict(node.lineno, node.end_lineno or node.lineno)
            if (isinstance(node, ast.If) and len(node.body) == 1 and isinstance(node.body[0], ast.Expr)
                    and isinstance(node.body[0].value, ast.Call) and STRICT.match(_callee(node.body[0].value.func))):
                add_strict(node.lineno, node.test.end_lineno or node.lineno)
        del src
    templates = {"finite": [], "range": []}
    q = files.get("src/ssskit/quantities.py")
    if q is not None:  # the vocabulary's own templates: one phrasing each
        for node in ast.walk(ast.parse(q)):
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
                name = node.targets[0].id if isinstance(node.targets[0], ast.Name) else ""
                if name == "FINITE":
                    templates["finite"].append(node.value.value)
                if name == "RANGE":
                    templates["range"].append(node.value.value)
    fin = sorted({_phrasing(m.split(": ", 1)[1]) for m in finite} | {_phrasing(t) for t in templates["finite"]})
    rng = sorted({_phrasing(m.split(": ", 1)[1]) for m in ranges} | {_phrasing(t) for t in templates["range"]})
    per_file = Counter(path for path, _ in lines)
    return {
        "validation_lines": len(lines),
        "validation_lines_strict": len(strict),
        "by_file": dict(per_file.most_common()),
        "by_file_strict": dict(Counter(path for path, _ in strict).most_common()),
        "statements": dict(kinds),
        "src_lines": sum(t.count("\n") for t in files.values()),
        "finiteness": {"messages": len(finite), "phrasings": len(fin), "list": fin},
        "range": {"messages": len(ranges), "phrasings": len(rng), "list": rng},
    }


def _files(root: Path, rev: str | None) -> dict[str, str]:
    if rev is None:
        return {str(p.relative_to(root)): p.read_text(encoding="utf-8") for p in sorted((root / "src").rglob("*.py"))}
    data = subprocess.run(["git", "-C", str(root), "archive", rev, "src"], check=True, capture_output=True).stdout
    out = {}
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        for m in tar.getmembers():
            if m.isfile() and m.name.endswith(".py"):
                out[m.name] = tar.extractfile(m).read().decode("utf-8")  # type: ignore[union-attr]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rev", help="a git revision to scan instead of the working tree")
    ap.add_argument("--list", action="store_true", help="also list the phrasings and the lines per file")
    args = ap.parse_args(argv)
    root = Path(__file__).resolve().parents[1]
    result = {"rev": args.rev or "working tree", **scan(_files(root, args.rev))}
    if not args.list:
        for k in ("finiteness", "range"):
            result[k].pop("list")
        result.pop("by_file")
        result.pop("by_file_strict")
    json.dump(result, sys.stdout, indent=2)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
