"""Every citation in the package resolves in docs/references.md: each bracketed key (``[JMLH01]``) names an
entry, and each author-year citation (``Xie 2020``, ``Wang, Jacques, Zheng 1995``) has an entry naming that
author and that year."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REFERENCES = ROOT / "docs" / "references.md"
#: a bracketed citation key: letters, then a two-digit year, maybe a letter ([JMLH01], [dLE07], [Kar14])
KEY = re.compile(r"\[([A-Za-z][A-Za-z+]*\d\d[a-z]?)\]")
#: an author-year citation: the last author's surname (maybe "et al."), then a year 1900-2029
AUTHOR_YEAR = re.compile(r"([A-Z][a-zA-Z'\-]+)(?: et al\.?)?,? ((?:19|20)[0-2]\d)\b")
ENTRY = re.compile(r"^- \*\*\[([^\]]+)\]\*\*(.*?)(?=^- \*\*\[|^#|\Z)", re.M | re.S)


def entries(text: str) -> dict[str, str]:
    """key -> the entry's text (joined lines)."""
    return {m.group(1): " ".join(m.group(2).split()) for m in ENTRY.finditer(text)}


def unresolved(source: str, refs: dict[str, str]) -> list[str]:
    """The citations of ``source`` that no entry of ``refs`` resolves."""
    missing = [f"[{k}]" for k in KEY.findall(source) if k not in refs]
    for surname, year in AUTHOR_YEAR.findall(source):
        if not any(surname in text and year in text for text in refs.values()):
            missing.append(f"{surname} {year}")
    return missing


def _sources() -> dict[Path, str]:
    return {p: p.read_text(encoding="utf-8") for p in sorted((ROOT / "src").rglob("*.py"))}


def test_every_citation_in_the_package_resolves():
    refs = entries(REFERENCES.read_text(encoding="utf-8"))
    assert len(refs) >= 20
    bad = {str(p.relative_to(ROOT)): sorted(set(m)) for p, text in _sources().items() if (m := unresolved(text, refs))}
    assert not bad, f"citations without an entry in docs/references.md: {bad}"


def test_the_check_finds_what_does_not_resolve():
    refs = entries("- **[AB01]** Ann Bee. *A title*. 2001.\n- **[Cee02]** Cee Dee. *Other*. 2002.\n")
    assert set(refs) == {"AB01", "Cee02"}
    assert unresolved("as [AB01] shows (Bee 2001) and [Cee02]", refs) == []
    assert unresolved("as [ZZ99] shows", refs) == ["[ZZ99]"]
    assert unresolved("as Bee 2003 and Dee et al. 2002 show", refs) == ["Bee 2003"]


def test_the_key_citations_of_the_papers_are_there():
    refs = entries(REFERENCES.read_text(encoding="utf-8"))
    for key, words in {"JMLH01": ("Jensen", "2001"), "dLE07": ("d'Eon", "2007"), "WJZ95": ("Wang", "1995"),
                       "XOKN20": ("Xie", "2020"), "JZJ15": ("Jimenez", "2015")}.items():
        assert all(w in refs[key] for w in words), (key, refs.get(key))
