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


def test_table_of_contents_links_every_section():
    body, toc = report._with_contents(["<h2>One</h2>x", "<h2 id=two>Two <i>t</i></h2>y"])
    assert "<h2 id='section-0-0'>One</h2>" in body[0] and "<h2 id='two'>" in body[1]
    assert "href='#section-0-0'" in toc and "href='#two'>Two t<" in toc
