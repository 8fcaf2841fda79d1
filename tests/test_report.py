"""The demo report's plumbing: a section is cached with the files it wrote (a second demo copies them),
keyed by the package's source; the table of contents links every section."""

from ssskit import report


def test_a_section_is_built_once_and_copied_after(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    calls = []

    def section(out, progress, ctx):
        calls.append(out)
        (out / "figures").mkdir(exist_ok=True)
        (out / "figures" / "a.png").write_bytes(b"png bytes")
        return "<h2>A section</h2><img src='figures/a.png'>"

    first, second = tmp_path / "one", tmp_path / "two"
    first.mkdir()
    second.mkdir()
    said = []
    html1 = report._cached_section("fake", section, first, said.append, {"photons": 5000})
    html2 = report._cached_section("fake", section, second, said.append, {"photons": 5000})
    assert html1 == html2 and len(calls) == 1 and said == ["fake: from the cache"]
    assert (second / "figures" / "a.png").read_bytes() == b"png bytes"
    report._cached_section("fake", section, second, said.append, {"photons": 6000})  # other settings: built
    assert len(calls) == 2


def test_the_backend_is_part_of_a_sections_cache_key(tmp_path, monkeypatch):
    """A section made on one backend is not served for another (``ssskit demo --backend``)."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    seen = []

    def section(out, progress, ctx):
        seen.append(ctx["backend"])
        return f"<h2>ran on {ctx['backend']}</h2>"

    for backend in ("numba", "numpy", "numba"):
        report._cached_section("fake", section, tmp_path, lambda msg: None, {"photons": 5000, "backend": backend})
    assert seen == ["numba", "numpy"]


def test_a_backend_that_cannot_run_stops_the_report_before_any_work(tmp_path, monkeypatch):
    import pytest

    from ssskit.errors import BackendError

    out = tmp_path / "report"
    with pytest.raises(BackendError, match="unknown backend 'vulkan'"):
        report.build_report(out, backend="vulkan")
    assert not out.exists()


def test_table_of_contents_links_every_section():
    body, toc = report._with_contents(["<h2>One</h2>x", "<h2 id=two>Two <i>t</i></h2>y"])
    assert "<h2 id='section-0-0'>One</h2>" in body[0] and "<h2 id='two'>" in body[1]
    assert "href='#section-0-0'" in toc and "href='#two'>Two t<" in toc


def test_an_interrupted_report_leaves_no_partial_folder(tmp_path, monkeypatch):
    """Ctrl-C in the middle of ``ssskit demo`` (a trial left 23-26 PNGs and no index.html): the sections
    are built in a staging folder, so neither the report folder nor the staging folder remains."""
    import pytest

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))

    def first(out, progress, ctx):
        (out / "a.png").write_bytes(b"png")
        return "<h2>A</h2>"

    def second(out, progress, ctx):
        (out / "b.png").write_bytes(b"png")
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "SECTIONS", [("first", first), ("second", second)])
    out = tmp_path / "demo"
    with pytest.raises(KeyboardInterrupt):
        report.build_report(out, backend="numpy")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache"]
    # a finished report moves into place whole, beside what the folder held before
    out.mkdir()
    (out / "mine.txt").write_text("kept")
    monkeypatch.setattr(report, "SECTIONS", [("first", first)])
    index = report.build_report(out, backend="numpy")
    assert index == out / "index.html" and index.is_file()
    assert sorted(p.name for p in out.iterdir()) == ["a.png", "index.html", "mine.txt"]


def test_no_template_text_reaches_the_page():
    """A string without its f prefix printed "on the {html.escape(backend)} backend" in the report: no
    plain string (or plain segment of a joined string) of the report's modules holds an interpolation of
    code (a call or an attribute inside braces), which only an f-string would fill."""
    import ast
    import re
    from pathlib import Path

    import ssskit

    root = Path(ssskit.__file__).parent
    pattern = re.compile(r"\{[A-Za-z_][\w.]*\([^{}]*\)[^{}]*\}|\{[A-Za-z_]\w*\.\w+[^{}]*\}")
    found = []
    for path in [root / "report.py", *sorted((root / "figures").glob("*.py"))]:
        # (a plain segment joined to f-strings shows up as a constant part of the joined string: checked too)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and pattern.search(node.value):
                found.append(f"{path.name}:{node.lineno}: {node.value[:60]!r}")
    assert found == []


@__import__("pytest").mark.slow
def test_transmission_section_shows_the_light_each_model_adds(tmp_path):
    """The demo's transmission section on the back-lit ear: a row per model (mcml, unreal, jimenez2010) whose
    added light is >= 0, so the brightness ratio with / without is >= 1 in every channel (adding light never
    darkens), the mcml model visibly brighter than the reflectance pass alone; the figure written; a link to
    docs/transmission.md."""
    import re

    text = report._transmission_section(tmp_path, lambda msg: None, {"backend": "numba"})
    assert (tmp_path / "figures" / "transmission_ear.png").stat().st_size > 1000
    assert "transmission.md" in text and "<h2 id=transmission>" in text
    rows = dict(re.findall(r"<td class=name>(\w+)</td><td>[^<]*</td><td>([^<]*)</td>", text))
    assert set(rows) == {"mcml", "unreal", "jimenez2010"}
    ratios = {m: [float(v) for v in r.split(",")] for m, r in rows.items()}
    assert all(v >= 1.0 for r in ratios.values() for v in r)
    assert min(ratios["mcml"]) > 1.5
