"""Citations of the project's conventions point at a document in the repository (issue 23).

The one cited document is docs/conventions.md; the one citation form is "conventions §n" (§n of that page; ranges
and lists such as "conventions §3–§4", "§4/§6", "§1 and §6" cite each number). The scan reads the package, the
tests, docs/, README.md, notebooks/ and benchmarks/, and fails on

- a citation of a document that is not in the repository: the upper-case names of the project's working papers
  (the contract, the design notes, the domain notes) and their "principle n";
- a cited § number with no such section heading (``## n.`` or ``### n.m``) in docs/conventions.md;
- inside docs/conventions.md, a bare §n (the page citing itself) with no such section.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONVENTIONS_MD = ROOT / "docs" / "conventions.md"
SCANNED = sorted(
    p
    for p in [
        *(ROOT / "gyrojax").rglob("*.py"),
        *(ROOT / "tests").rglob("*.py"),
        *(ROOT / "tests").rglob("*.md"),
        *(ROOT / "benchmarks").rglob("*.py"),
        *(ROOT / "docs").glob("*.md"),
        *(ROOT / "notebooks").glob("*"),
        ROOT / "README.md",
    ]
    if p.is_file() and p.suffix in (".py", ".md") and p != Path(__file__).resolve()
)

NUMBER = r"\d+(?:\.\d+)*"
SECTION_LIST = rf"§\s?{NUMBER}(?:\s*(?:–|-|/|,|and|or)\s*§?\s?{NUMBER})*"
CITATION = re.compile(rf"\bconventions(?:\.md)?(?:\]\([^)]*\))?\s*({SECTION_LIST})", re.I)
BARE = re.compile(rf"(?<![\w.])({SECTION_LIST})")
ABSENT_DOCUMENT = re.compile(r"\bCONVENTIONS\b|\bDESIGN\b(?:\.md)?(?:\s+principles?\s*\d*)?|\bDOMAIN\b")


def sections() -> set[str]:
    """Section numbers of docs/conventions.md: headings ``## 1. Units``, ``### 9.2 Optical gyros``."""
    text = CONVENTIONS_MD.read_text(encoding="utf-8")
    return set(re.findall(rf"^#{{2,6}}\s+({NUMBER})\.?\s", text, flags=re.M))


def cited_numbers(section_list: str) -> list[str]:
    """'§3–§4' → ['3', '4']; '§1 and §6' → ['1', '6']; '§9.2' → ['9.2']."""
    return re.findall(NUMBER, section_list)


def _rel(p: Path) -> str:
    return str(p.relative_to(ROOT))


def test_conventions_page_has_the_contract_sections():
    """docs/conventions.md holds the contract's sections 1–8, in order, and the repository's own after them."""
    text = CONVENTIONS_MD.read_text(encoding="utf-8")
    top = re.findall(r"^## (\d+)\. (.+)$", text, flags=re.M)
    assert [int(n) for n, _ in top] == list(range(1, len(top) + 1)) and len(top) >= 8
    assert [t for _, t in top[:8]] == [
        "Units",
        "Frames",
        "Turntable kinematics",
        "Instruments and their inputs",
        "Record files",
        "Named effects",
        "Command line JSON",
        "Truth files",
    ]
    assert "1 g = g0 = 9.80665 m/s²" in text and "`f = (0, 0, +g_site)`" in text  # units and the sign of §1–§2


@pytest.mark.parametrize("path", SCANNED, ids=[_rel(p) for p in SCANNED])
def test_citations_name_a_document_and_section_of_the_repository(path):
    text = path.read_text(encoding="utf-8")
    known = sections()
    problems = []
    for lineno, line in enumerate(text.splitlines(), 1):
        for m in ABSENT_DOCUMENT.finditer(line):
            problems.append(f"line {lineno}: {m.group(0)!r} cites a document not in the repository")
        cited = [m.group(1) for m in CITATION.finditer(line)]
        if path == CONVENTIONS_MD:
            cited += [m.group(1) for m in BARE.finditer(line)]
        for group in cited:
            for n in cited_numbers(group):
                if n not in known:
                    problems.append(f"line {lineno}: §{n} is not a section of docs/conventions.md")
    assert problems == [], f"{_rel(path)}: " + "; ".join(problems)


def test_the_scanner_sees_what_it_should():
    """The patterns on known lines (so a scanner that finds nothing cannot pass the tests above)."""
    assert [cited_numbers(m.group(1)) for m in CITATION.finditer("(conventions §3–§4; conventions §1 and §6)")] == [
        ["3", "4"],
        ["1", "6"],
    ]
    assert [m.group(1) for m in CITATION.finditer("see [conventions](conventions.md) §9.2.")] == ["§9.2"]
    for old in ("CONVENTIONS §5", "DESIGN principle 7", "(DOMAIN; Hu 2-45)", "CONVENTIONS.md"):
        assert ABSENT_DOCUMENT.search(old), old
    for fine in ("conventions §5", "DESIGN_FORMAT", "the design of a plan", "Hu ch. 3 §2", "Titterton §8.5.2"):
        assert not ABSENT_DOCUMENT.search(fine), fine
    for other in ("Hu ch. 3 §2", "Titterton §8.5.2", "the conventions' signs (Hu §3.4)"):
        assert not CITATION.search(other), other
    assert {"1", "8", "9", "9.2", "10"} <= sections() and "11" not in sections()
    assert len(SCANNED) > 100
