"""Every ``gyrojax.x.y`` path the documents name resolves (issue 23).

The paths are read from the documents themselves (README.md, docs/*.md, notebooks/README.md, notebooks/*.py), so
a module that moves breaks this test until the documents follow it. A path is a dotted name starting with
``gyrojax`` (``gyrojax.inference.identify.fit``, ``gyrojax.data.records.Record.load``); it resolves when its longest
importable prefix is a module and the rest are attributes of it. ``from gyrojax.x import a, b`` lines name
``gyrojax.x.a`` and ``gyrojax.x.b``.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = sorted(
    [ROOT / "README.md", ROOT / "notebooks" / "README.md"]
    + list((ROOT / "docs").glob("*.md"))
    + list((ROOT / "notebooks").glob("*.py"))
)
DOTTED = re.compile(r"(?<![\w.])gyrojax(?:\.[A-Za-z_]\w*)+")
FROM_IMPORT = re.compile(r"^\s*from\s+(gyrojax(?:\.\w+)*)\s+import\s+\(?([\w\s,]+)\)?", re.M)


def named_paths(text: str) -> set[str]:
    """The gyrojax paths a text names: dotted names, and the names of ``from gyrojax… import …`` lines."""
    paths = set(DOTTED.findall(text))
    for module, names in FROM_IMPORT.findall(text):
        paths.update(f"{module}.{n.split()[0]}" for n in names.split(",") if n.strip())
    return paths


def resolves(path: str) -> bool:
    """True when the path's longest importable prefix is a module holding the rest as attributes."""
    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError as e:
            if e.name is None or not ".".join(parts[:i]).startswith(e.name):
                raise  # the module exists but imports something missing: a real error, not a stale path
            continue
        for attr in parts[i:]:
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


@pytest.mark.parametrize("doc", DOCUMENTS, ids=[str(d.relative_to(ROOT)) for d in DOCUMENTS])
def test_every_gyrojax_path_in_the_document_resolves(doc):
    stale = sorted(p for p in named_paths(doc.read_text(encoding="utf-8")) if not resolves(p))
    assert stale == [], f"{doc.relative_to(ROOT)}: paths that do not import: {stale}"


def test_the_documents_name_paths():
    """The reader finds the paths (a reader that finds none would pass the test above vacuously)."""
    assert sum(len(named_paths(d.read_text(encoding="utf-8"))) for d in DOCUMENTS) > 20
    text = "see `gyrojax.noise.allan.adev`.\nfrom gyrojax.data import plans, records as r\n"
    assert named_paths(text) == {
        "gyrojax.noise.allan.adev",
        "gyrojax.data",
        "gyrojax.data.plans",
        "gyrojax.data.records",
    }
    assert resolves("gyrojax.data.records") and not resolves("gyrojax.data.no_such_module")
    assert not resolves("gyrojax.cli.app.no_such_function")
