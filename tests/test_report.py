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


def test_two_processes_build_the_same_report(tmp_path, monkeypatch):
    """``ssskit demo`` builds the sections on two worker processes: the page and every file are those of the
    one-process build (but the build time the page states), the sections in report order."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(report, "SECTIONS", [("sampling", report._sampling_section),
                                             ("materials", report._materials_section)])
    said = []
    pages = {}
    for jobs in (1, 2):
        monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / f"cache{jobs}"))  # each builds its sections
        index = report.build_report(tmp_path / f"demo{jobs}", said.append, backend="numpy", jobs=jobs)
        pages[jobs] = {str(p.relative_to(index.parent)): p.read_bytes() for p in index.parent.rglob("*")}
    import re

    for page in pages.values():
        page["index.html"] = re.sub(rb"built in [0-9.]+ s", b"", page["index.html"])
    assert sorted(pages[2]) == ["index.html", "xie_c.png"] and pages[2] == pages[1]
    assert pages[2]["index.html"].index(b">Burley sampling (Xie") < pages[2]["index.html"].index(b">Materials<")
    assert "2 sections on 2 processes (starting them takes a few seconds)" in said
    assert "Burley sampling: refitting c" in said[said.index("2 sections on 2 processes (starting them takes a few "
                                                              "seconds)"):]  # a worker's line, passed on
    assert not list(tmp_path.glob(".demo*"))  # no staging folder left


def test_an_error_in_a_worker_leaves_no_partial_folder(tmp_path, monkeypatch):
    from ssskit.errors import MaterialError

    import pytest

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(report, "SECTIONS", [("materials", report._materials_section),
                                             ("kernels", report._kernels_section)])
    with pytest.raises(MaterialError, match="NoSuchMaterial"):
        report.build_report(tmp_path / "demo", backend="numpy", materials=["NoSuchMaterial"], jobs=2)
    assert [p.name for p in tmp_path.iterdir() if p.name != "cache"] == []  # (the other section may have cached)


def test_jobs_must_be_a_positive_integer(tmp_path):
    import pytest

    from ssskit.errors import SsskitError

    with pytest.raises(SsskitError, match=r"jobs must lie in \[1, inf\), got 0"):
        report.build_report(tmp_path / "demo", backend="numpy", jobs=0)
    assert not (tmp_path / "demo").exists()


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


def test_the_workers_compile_each_kernel_once_before_the_sections_that_run_it():
    """The demo's jobs on two processes: first the screen-space section's kernels, beside the kernel ranking
    (which runs no pass); every other pass compiled by one job just before the first section that runs it;
    every section waits for the jobs that compile its passes; a backend that compiles nothing: sections only."""
    names = [name for name, _ in report.SECTIONS]
    jobs, after = report.section_jobs(names, compiles=True)
    assert jobs[:3] == [("compile", list(report.SECTION_PASSES["screenspace"])), ("section", names.index("kernels")),
                        ("section", names.index("screenspace"))]
    compiled = [p for kind, what in jobs if kind == "compile" for p in what]
    assert len(compiled) == len(set(compiled))  # each pass once
    assert set(compiled) == {p for n in names for p in report.SECTION_PASSES.get(n, ())}
    assert sorted(what for kind, what in jobs if kind == "section") == list(range(len(names)))
    for j, (kind, what) in enumerate(jobs):
        if kind == "section":
            needed = set(report.SECTION_PASSES.get(names[what], ()))
            assert needed <= {p for d in after[j] for p in jobs[d][1]} and all(d < j for d in after[j])
    assert report.section_jobs(names, compiles=False) == ([("section", names.index(n)) for n in report.SECTION_ORDER
                                                          if n in names], {k: set() for k in range(len(names))})


def _kernel_columns(text: str) -> dict[str, list[list[str]]]:
    """The screen-space table's kernel rows per scene, as lists of cells (the scene's noise-floor row left out)."""
    import re

    table = text[text.index("<th>kernel / taps</th>"):]
    table = table[:table.index("</table>")]
    scenes: dict[str, list[list[str]]] = {}
    for attrs, row in re.findall(r"<tr([^>]*)>(.*?)</tr>", table):
        cells = [re.sub(r"<[^>]+>", "", c) for c in re.findall(r"<td[^>]*>(.*?)</td>", row)]
        if cells and "scene" not in attrs:
            scenes.setdefault(cells[0], []).append(cells[1:])
    return scenes


@__import__("pytest").mark.slow
def test_no_column_of_the_kernel_table_is_the_same_for_every_kernel(tmp_path, monkeypatch):
    """The screen-space table on a small slab with a short path trace: the per-pixel PSNR against the path trace
    was the same for every kernel of a scene (sphere 30.7 dB for all four: the reference's noise, relative RMSE
    ~0.68); every column of the kernels' rows now differs between at least two kernels of the scene, the noise
    floor (the reference level's relative SE, the same for all) stated once in the scene's own row."""
    from ssskit.figures.screenspace import screen_space_comparison

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "cache"))
    png, rows, regions = screen_space_comparison(tmp_path, scenes=["slab"], width=64, height=48, spp=4,
                                                 reference_spp=8, reference_max_spp=8)
    text = report._kernel_rows(rows, regions)
    per_scene = _kernel_columns(text)
    assert list(per_scene) == ["slab"] and len(per_scene["slab"]) == len(rows) >= 3
    kernels = per_scene["slab"]
    columns = [c for c in zip(*kernels) if set(c) != {"-"}]  # ('-': the scene has no such region)
    assert len(columns) >= 3  # kernel, vs exact 2D, the shadow edge at least
    for column in columns:
        assert len(set(column)) > 1, column
    assert "<tr class=scene><td class=name>slab</td><td class=name>noise floor" in text
    assert png.is_file()


def test_the_shipped_head_numbers_are_the_docs_numbers():
    """The demo's head figure reads the package's copy of docs/head_numbers.json's ``separable`` part (an installed
    ssskit has no docs/): the two agree (after ``python docs/head_numbers.py``, run
    ``ssskit.figures.screenspace.ship_head_numbers()``), and the copy has a row with region levels and standard
    errors for each of the head's three views."""
    import json
    from pathlib import Path

    from ssskit.figures.screenspace import HEAD_NUMBERS

    docs = json.loads((Path(__file__).parents[1] / "docs" / "head_numbers.json").read_text())["separable"]
    shipped = json.loads(HEAD_NUMBERS.read_text())
    assert shipped == docs
    views = {r["view"] for r in shipped["rows"] if r.get("regions")}
    assert views == {"front", "ear", "close"}
    for r in shipped["rows"]:
        for region in r["regions"].values():
            assert all(se > 0 for se in region["path_traced_se"])


def test_the_demo_opens_with_the_head_and_ranks_every_material():
    """The report's first section is the head; the kernels are ranked for all 11 measured materials by default."""
    from ssskit.materials import MATERIALS

    assert report.SECTIONS[0][0] == "head"
    assert list(report.RANK_MATERIALS) == MATERIALS.names() and len(report.RANK_MATERIALS) == 11


@__import__("pytest").mark.slow
def test_the_head_section_shows_the_recommended_kernel_against_the_path_trace(tmp_path):
    """The head section renders the head with the kernel ranked first for Skin1 and tabulates, for each of the
    three views, that kernel's region levels beside the path trace's ± SE, from the shipped numbers; the
    ratio column is level / path traced and the SE column the shipped one (an independent recomputation)."""
    import json
    import re

    from ssskit.figures.screenspace import HEAD_NUMBERS
    from ssskit.profiles import profile_for_material

    best = report.kernel_ranking(profile_for_material("Skin1", "montecarlo"), size=report.RANK_SIZE)[0][0]
    text = report._head_section(tmp_path, lambda msg: None, {"backend": "numba"})
    assert f"recommended kernel ({best})" in text
    assert (tmp_path / "figures" / "head.png").stat().st_size > 10_000
    rows = re.findall(r"<tr><td class=name>(\w+)</td><td class=name>([\w ]+)</td><td>(\d+)</td><td>([^<]*)</td>"
                      r"<td>([^<]*)</td><td>([^<]*)</td>", text)
    assert {r[0] for r in rows} == {"front", "ear", "close"}
    shipped = {(r["view"], k.replace("_", " ")): v for r in json.loads(HEAD_NUMBERS.read_text())["rows"]
               if r["kernel"] == best for k, v in r["regions"].items()}
    assert len(rows) == len(shipped)
    for view, region, pixels, level, ref, ratio in rows:
        want = shipped[(view, region)]
        assert int(pixels) == want["pixels"]
        got = [float(v) for v in ratio.split(",")]
        assert got == [float(f"{a / b:.3g}") for a, b in zip(want["screen_space"], want["path_traced"])]


def test_a_noisy_path_trace_is_shown_as_block_means_and_left_untouched():
    """A flat image of level 1 with independent per-pixel noise of SE 0.5 (relative noise 50%): its display copy is
    the mean of the smallest blocks that bring the noise to 10% (6x6: 0.5 / 6 = 8.3%; 4x4 gives 12.5%), the
    blocks' actual scatter about 1 is that SE (within 15%), and the image given, the numbers' reference, is not
    changed; a converged image is shown as it is."""
    import numpy as np

    from ssskit.figures.screenspace import display_copy

    rng = np.random.default_rng(7)
    img = 1.0 + 0.5 * rng.standard_normal((120, 160, 3))
    before = img.copy()
    se = np.full_like(img, 0.5)
    mask = np.ones((120, 160), bool)
    shown, block, rel = display_copy(img, se, mask)
    assert block == 6 and abs(rel / (0.5 / 6) - 1) < 0.01  # (over the noisy image's own mean level)
    assert np.array_equal(img, before)
    blocks = shown[:120 // 6 * 6:6, :160 // 6 * 6:6]  # (the last 4 columns, no whole block, shown as they are)
    assert abs(float(np.std(blocks)) / (0.5 / 6) - 1) < 0.15
    quiet, block, rel = display_copy(np.ones((120, 160, 3)), np.full((120, 160, 3), 0.01), mask)
    assert block == 1 and np.array_equal(quiet, np.ones((120, 160, 3))) and abs(rel - 0.01) < 1e-12


def test_the_demo_embeds_the_live_viewer_of_the_head_with_skin1(tmp_path):
    """The viewer section writes the static folder of ``ssskit view --out`` (the head, Skin1 alone) into the report
    and frames it; opened from file:// in headless Chromium (where it runs; else the files are checked), the framed
    page draws a non-blank, finite frame of the head with Skin1 and logs no console error."""
    import json
    import re

    from ssskit.view.browser import browser_available, headless_page
    from ssskit.view.site import PAGE_FILES

    text = report._viewer_section(tmp_path, lambda msg: None, {})
    assert "viewer" in dict(report.SECTIONS)
    folder = tmp_path / "viewer"
    assert sorted(p.name for p in folder.iterdir()) == sorted([*PAGE_FILES, "data.js"])
    data = json.loads(re.fullmatch(r"window\.SSSKIT_DATA = (.*);\n", (folder / "data.js").read_text(), re.S)[1])
    assert list(data["materials"]) == ["skin1"] and data["default_material"] == "skin1" and not data["served"]
    assert data["scene"]["name"] == "head" and data["scene"]["triangles"] > 10_000
    src = re.search(r"<iframe src='([^']+)'", text)[1]
    assert src.startswith("viewer/index.html")
    ok, why = browser_available()
    if not ok:
        return  # no browser here (why): the files above are what a browser would open
    (tmp_path / "index.html").write_text(f"<!doctype html><html><body>{text}</body></html>")
    with headless_page(width=1100, height=500) as (page, log):
        page.goto((tmp_path / "index.html").as_uri())
        frame = next(f for f in page.frames if f.url.startswith((folder / "index.html").as_uri()))
        frame.wait_for_function("() => window.ssskit && window.ssskit.frames() > 0", timeout=60_000)
        assert frame.evaluate("() => document.getElementById('status').textContent") == ""
        pixels = frame.evaluate("() => Array.from(atob(window.ssskit.readDisplay()), (c) => c.charCodeAt(0))")
        import numpy as np

        img = np.asarray(pixels, float).reshape(-1, 4)[:, :3]
        assert np.isfinite(img).all() and img.std() > 5.0      # the head against the background, not blank
        assert "ms" in frame.evaluate("() => document.getElementById('stats').textContent")
        log.check()
