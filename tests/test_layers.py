"""The import graph of gyrojax: no cycles, arrows that point down, modules of one job.

The layers, bottom first (a unit may import only from tiers below its own; units of one tier are independent)::

    errors                                  the exception types
    units, kinds, protocol,                 unit conversions; instrument-kind names; files and the result protocol;
    optimize, tails                         the searches and their status; the laws' tails and quantiles
    runtime                                 how compiled code runs: the cache folder, kept executables, threads
    (package root)                          x64, the compilation cache, the flat API's table
    physics, noise                          the measurement model; noise descriptions, estimators and processes
    data                                    records, truth files, plans (data reads physics names and noise specs)
    dynamics, seeds                         ZOH and the loops; the source books' closed forms
    simulation                              records from a plan and a truth (quasi-static or through the loops)
    inference                               fit, diagnosis, adequacy
    planning, montecarlo                    test-plan design; studies over many simulated gyros
    adaptive                                the campaign loop: the next test from the records so far (designs by
                                            the Fisher core, simulates, diagnoses)
    report                                  tables, text and figures (the only library package that draws)
    cli                                     the ``gyrojax`` command
    __main__                                ``python -m gyrojax``

``dynamics`` sits below ``simulation`` (the simulator runs the loops of :mod:`gyrojax.dynamics.loops`; the loops
import no simulation), not beside ``inference`` as first drawn.

Every import counts: top-level ones and those inside functions (a lazy import closes a cycle as surely as an eager
one), ``import gyrojax.x.y``, ``from gyrojax.x import y`` (an edge to the module ``gyrojax.x.y`` when ``y`` is one,
else to ``gyrojax.x``) and relative imports. ``from gyrojax import NAME`` is resolved through the flat API's table
(``gyrojax._FLAT``) to the module that defines ``NAME``. Imports by a computed name (``importlib.import_module`` of
an f-string, as the flat API and :mod:`gyrojax.report` do for their own lazy names) are not seen.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "gyrojax"

LAYERS = (
    ("errors",),
    ("units", "kinds", "protocol", "optimize", "tails"),
    ("runtime",),
    ("",),  # the package root (gyrojax/__init__.py): x64 and the compilation cache of runtime
    ("physics", "noise"),
    ("data",),
    ("dynamics", "seeds"),
    ("simulation",),
    ("inference",),
    ("planning", "montecarlo"),
    ("adaptive",),
    ("report",),
    ("cli",),
    ("__main__",),
)

ALLOWED = {
    # (importer, imported): why it is allowed for now. Each entry is temporary: the test below fails once the
    # import is gone, so that the entry is removed with it.
}


@dataclass(frozen=True)
class Edge:
    """One import: ``importer`` imports ``imported`` at ``file``:``line``."""

    importer: str
    imported: str
    file: str
    line: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}: {self.importer} imports {self.imported}"


def modules(root: Path, package: str) -> dict[str, Path]:
    """Dotted module name → file, for every ``.py`` file of ``package`` under ``root``."""
    out = {}
    for p in sorted((root / package).rglob("*.py")):
        parts = list(p.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def _flat_table(path: Path) -> dict[str, str]:
    """The flat API's ``_FLAT`` table of the package root (name → defining module), when it has one."""
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "_FLAT" for t in node.targets):
            table = ast.literal_eval(node.value)
            return {k: v.partition(":")[0] for k, v in table.items()}
    return {}


def _root_names(path: Path, package: str) -> dict[str, str]:
    """Names the package root binds by a static ``from gyrojax.x import name`` (name → ``gyrojax.x``)."""
    out = {}
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith(package + "."):
            out.update({a.asname or a.name: node.module for a in node.names})
    return out


def imports(root: Path, package: str) -> list[Edge]:
    """Every import between modules of ``package`` (module doc), self-imports dropped."""
    mods = modules(root, package)
    root_file = mods[package]
    flat = {**_flat_table(root_file), **_root_names(root_file, package)}
    edges = []
    for mod, path in mods.items():
        is_pkg = path.name == "__init__.py"
        rel = str(path.relative_to(root))
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=rel)):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names if a.name == package or a.name.startswith(package + ".")]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    here = mod.split(".") if is_pkg else mod.split(".")[:-1]
                    here = here[: len(here) - node.level + 1]
                    base = ".".join(here + ([base] if base else []))
                if base != package and not base.startswith(package + "."):
                    continue
                for a in node.names:
                    sub = f"{base}.{a.name}"
                    if sub in mods:
                        targets.append(sub)
                    elif base == package:
                        targets.append(flat.get(a.name, package))
                    else:
                        targets.append(base)
            for t in targets:
                if t != mod:
                    edges.append(Edge(mod, t, rel, node.lineno))
    return edges


def unit_of(module: str, package: str) -> str:
    """The top-level unit of a module: its subpackage or top-level module (``""`` for the package root)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _rank(layers) -> dict[str, int]:
    return {u: i for i, tier in enumerate(layers) for u in tier}


def layer_violations(edges, layers, package: str) -> list[str]:
    """Imports of a unit in the same or a higher tier, and units that no tier names."""
    rank = _rank(layers)
    out = []
    for e in edges:
        a, b = unit_of(e.importer, package), unit_of(e.imported, package)
        for u in (a, b):
            if u not in rank:
                out.append(f"{e}: unit {u!r} is in no layer; add it to LAYERS")
        if a == b or a not in rank or b not in rank:
            continue
        if rank[b] > rank[a]:
            out.append(f"{e}: {b!r} is above {a!r} in the layers")
        elif rank[b] == rank[a]:
            out.append(f"{e}: {b!r} and {a!r} share a tier and must not import each other")
    return out


def cycles(nodes, edges) -> list[list[Edge]]:
    """One cycle (as its edges) through each strongly connected group of ``nodes`` under ``edges`` (Tarjan)."""
    succ: dict[str, dict[str, Edge]] = {n: {} for n in nodes}
    for e in edges:
        succ.setdefault(e.importer, {}).setdefault(e.imported, e)
        succ.setdefault(e.imported, {})
    index, low, stack, on, groups = {}, {}, [], set(), []

    def visit(v):  # recursion depth is bounded by the number of modules (~120)
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in succ[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = set()
            while True:
                w = stack.pop()
                on.discard(w)
                group.add(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(group)

    for v in sorted(succ):
        if v not in index:
            visit(v)
    return [_cycle_in(group, succ) for group in groups]


def _cycle_in(group: set, succ) -> list[Edge]:
    """A shortest cycle through the first node of ``group`` (breadth first, inside the group)."""
    start = min(group)
    prev = {start: None}
    frontier = [start]
    while frontier:
        nxt = []
        for v in frontier:
            for w, e in sorted(succ[v].items()):
                if w == start:
                    path = [e]
                    while prev[v] is not None:
                        path.append(prev[v])
                        v = prev[v].importer
                    return path[::-1]
                if w in group and w not in prev:
                    prev[w] = e
                    nxt.append(w)
        frontier = nxt
    raise AssertionError(f"no cycle through {start} in {sorted(group)}")  # a strongly connected group has one


def _unit_edges(edges, package: str) -> list[Edge]:
    out = []
    for e in edges:
        a, b = unit_of(e.importer, package), unit_of(e.imported, package)
        if a != b:
            out.append(Edge(a or package, b or package, e.file, e.line))
    return out


def _explain(found) -> str:
    return "\n".join("  cycle:\n" + "\n".join(f"    {e}" for e in c) for c in found)


@pytest.fixture(scope="module")
def edges():
    found = imports(ROOT, PACKAGE)
    return [e for e in found if (e.importer, e.imported) not in ALLOWED]


def test_the_graph_is_seen():
    found = {(e.importer, e.imported) for e in imports(ROOT, PACKAGE)}
    # anchors: an eager import, a lazy one inside a function, `from gyrojax import module`
    assert ("gyrojax.data.records", "gyrojax.data.schema") in found
    assert ("gyrojax.cli.app", "gyrojax.cli.commands") in found  # lazy, inside _command
    assert ("gyrojax.data.planfile", "gyrojax.protocol") in found


def test_no_import_cycle_between_modules(edges):
    found = cycles(modules(ROOT, PACKAGE), edges)
    assert not found, "import cycles between modules:\n" + _explain(found)


def test_no_import_cycle_between_subpackages(edges):
    units = {unit_of(m, PACKAGE) or PACKAGE for m in modules(ROOT, PACKAGE)}
    found = cycles(units, _unit_edges(edges, PACKAGE))
    assert not found, "import cycles between subpackages:\n" + _explain(found)


def test_imports_point_down_the_layers(edges):
    bad = layer_violations(edges, LAYERS, PACKAGE)
    assert not bad, "imports against the layer order (tests/test_layers.py docstring):\n  " + "\n  ".join(bad)


def test_allowed_imports_still_exist():
    found = {(e.importer, e.imported) for e in imports(ROOT, PACKAGE)}
    stale = sorted(set(ALLOWED) - found)
    assert not stale, f"ALLOWED entries whose import is gone (remove them): {stale}"


def private_imports(root: Path, package: str) -> list[str]:
    """Private (underscore) names one module takes from another: ``from gyrojax.x import _name`` and
    ``module._name`` on a gyrojax module imported by name. A module's own private names stay its own; what another
    module needs is public where it is defined."""
    out = []
    for path in modules(root, package).values():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        rel = str(path.relative_to(root))
        bound = set()  # local names bound to gyrojax modules or their attributes
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").startswith(package)):
                for a in node.names:
                    if a.name.startswith("_") and not a.name.endswith("__"):
                        out.append(f"{rel}:{node.lineno}: imports {a.name} from {node.module or '.'}")
                    bound.add(a.asname or a.name)
            elif isinstance(node, ast.Import):
                bound.update((a.asname or a.name).split(".")[0] for a in node.names if a.name.startswith(package))
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound:
                if node.attr.startswith("_") and not node.attr.endswith("__"):
                    out.append(f"{rel}:{node.lineno}: uses {node.value.id}.{node.attr}")
    return out


def late_imports(root: Path, package: str) -> list[str]:
    """Module-level imports below the module's first function or class: a module imported at the bottom of another
    (to dodge a cycle, or to re-export it) hides a dependency the layers should show."""
    out = []
    for path in modules(root, package).values():
        seen_def = False
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                seen_def = True
            elif seen_def and isinstance(node, (ast.Import, ast.ImportFrom)):
                out.append(f"{path.relative_to(root)}:{node.lineno}: import after the module's definitions")
    return out


def reexports(root: Path, package: str) -> list[str]:
    """Imports kept only to hand a name on (``# noqa: F401`` on a gyrojax import): a shim, not a seam."""
    out = []
    for path in modules(root, package).values():
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if "noqa: F401" in line and f"from {package}" in line:
                out.append(f"{path.relative_to(root)}:{i}: {line.strip()}")
    return out


def test_no_private_name_is_imported_across_modules():
    found = private_imports(ROOT, PACKAGE)
    assert not found, "private names taken from other modules:\n  " + "\n  ".join(found)


def test_no_import_after_definitions():
    found = late_imports(ROOT, PACKAGE)
    assert not found, "imports after definitions:\n  " + "\n  ".join(found)


def test_no_reexport_shims():
    found = reexports(ROOT, PACKAGE)
    assert not found, "re-export shims:\n  " + "\n  ".join(found)


# ---- the checker itself, on a package made for the purpose ------------------------------------------------------


def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        p = root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text, encoding="utf-8")


def test_checker_finds_a_lazy_cycle_and_an_upward_import(tmp_path):
    _write(
        tmp_path,
        {
            "pkg/__init__.py": '_FLAT = {"fit": "pkg.top.fitting:fit"}\n',
            "pkg/low/__init__.py": "",
            "pkg/low/a.py": "from pkg.low import b\n",
            "pkg/low/b.py": "def f():\n    from . import a\n",  # lazy and relative: still a cycle
            "pkg/top/__init__.py": "",
            "pkg/top/fitting.py": "from pkg.low.a import something\ndef fit():\n    pass\n",
            "pkg/low/c.py": "\n\ndef g():\n    from pkg import fit\n",  # through the flat table: upward
        },
    )
    found = imports(tmp_path, "pkg")
    pairs = {(e.importer, e.imported) for e in found}
    assert pairs == {
        ("pkg.low.a", "pkg.low.b"),
        ("pkg.low.b", "pkg.low.a"),
        ("pkg.top.fitting", "pkg.low.a"),
        ("pkg.low.c", "pkg.top.fitting"),
    }
    (cycle,) = cycles(modules(tmp_path, "pkg"), found)
    assert {str(e) for e in cycle} == {
        "pkg/low/a.py:1: pkg.low.a imports pkg.low.b",
        "pkg/low/b.py:2: pkg.low.b imports pkg.low.a",
    }
    (unit_cycle,) = cycles({"low", "top"}, _unit_edges(found, "pkg"))
    assert {(e.importer, e.imported) for e in unit_cycle} == {("low", "top"), ("top", "low")}
    bad = layer_violations(found, (("",), ("low",), ("top",)), "pkg")
    assert bad == ["pkg/low/c.py:4: pkg.low.c imports pkg.top.fitting: 'top' is above 'low' in the layers"]
    same_tier = layer_violations(found, (("",), ("low", "top")), "pkg")
    assert len(same_tier) == 2 and all("share a tier" in s for s in same_tier)
    assert "unit 'top' is in no layer" in layer_violations(found, (("",), ("low",)), "pkg")[0]


def test_checker_finds_private_names_late_imports_and_shims(tmp_path):
    _write(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/a.py": "def _helper():\n    pass\n\n\ndef public():\n    pass\n",
            "pkg/b.py": "from pkg.a import _helper\nfrom pkg import a\n\n\ndef f():\n    return a._helper()\n",
            "pkg/c.py": "from pkg.a import public  # noqa: F401  (named here too)\n\n\ndef g():\n    pass\n\n\n"
            "from pkg import b\n",
        },
    )
    assert private_imports(tmp_path, "pkg") == [
        "pkg/b.py:1: imports _helper from pkg.a",
        "pkg/b.py:6: uses a._helper",
    ]
    assert late_imports(tmp_path, "pkg") == ["pkg/c.py:8: import after the module's definitions"]
    assert reexports(tmp_path, "pkg") == ["pkg/c.py:1: from pkg.a import public  # noqa: F401  (named here too)"]
