"""API reference generator: writes docs/api.md from the docstrings of every public gyrojax module.

Public means: a module whose name does not start with ``_``; in it, the names listed in ``__all__`` where the module
defines one, otherwise every top-level name not starting with ``_``; names imported from another module (re-exports,
aliases of foreign functions or classes) are left to the module that defines them. Members appear in source order,
modules in alphabetical order, and memory addresses never reach the output, so the file is reproducible:
``python -m gyrojax.apidoc`` (or ``make docs``) rewrites it, ``--check`` only compares.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re
import sys
from pathlib import Path

PACKAGE = "gyrojax"
_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")
_MAX_SIGNATURE = 100  # characters; longer signatures get one parameter per line


def reference_path() -> Path:
    """Where the reference lives in a source checkout: ``docs/api.md`` beside the package."""
    return Path(__file__).resolve().parents[1] / "docs" / "api.md"


def module_names(package: str = PACKAGE) -> list[str]:
    """Dotted names of the package and its public modules (no ``_`` prefix, no ``__main__``), sorted."""
    pkg = importlib.import_module(package)
    subs = [m.name for m in pkgutil.iter_modules(pkg.__path__) if not m.name.startswith("_")]
    return [package] + [f"{package}.{s}" for s in sorted(subs)]


def _top_level(module) -> list[ast.stmt]:
    """The top-level statements of the module's source ([] when it has no source)."""
    try:
        return ast.parse(inspect.getsource(module)).body
    except (OSError, TypeError):
        return []


def _assigned(node: ast.stmt) -> list[str]:
    """Names a top-level assignment binds."""
    if isinstance(node, ast.Assign):
        return [t.id for t in node.targets if isinstance(t, ast.Name)]
    if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
        return [node.target.id]
    return []


def _top_level_names(module) -> list[str]:
    """Names bound at the top level of the module's source (def, class, assignment), in source order."""
    names: list[str] = []
    for node in _top_level(module):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(node.name)
        names += _assigned(node)
    return list(dict.fromkeys(names))


def _defined_here(obj, module) -> bool:
    """False for functions and classes that come from another module (re-exports and aliases)."""
    if inspect.ismodule(obj):
        return False
    if inspect.isclass(obj) or callable(obj):
        return getattr(obj, "__module__", None) == module.__name__
    return True


def public_members(module) -> list[tuple[str, object]]:
    """(name, object) of the module's public members that the module itself defines, in source order."""
    order = _top_level_names(module)
    exported = getattr(module, "__all__", None)
    if exported is None:
        names = [n for n in order if not n.startswith("_")]
    else:
        names = [n for n in order if n in set(exported)]
    out = []
    for n in names:
        if hasattr(module, n):
            obj = getattr(module, n)
            if _defined_here(obj, module):
                out.append((n, obj))
    return out


def kind(obj) -> str:
    """'class', 'function' or 'constant'."""
    if inspect.isclass(obj):
        return "class"
    if callable(obj):
        return "function"
    return "constant"


def public_methods(cls) -> list[tuple[str, object]]:
    """(name, attribute) of the public methods and properties defined in the class body itself, in source order."""
    out = []
    for n, attr in vars(cls).items():
        if n.startswith("_"):
            continue
        if isinstance(attr, (staticmethod, classmethod, property)) or inspect.isfunction(attr):
            out.append((n, attr))
    return out


def _autodoc(cls, doc: str) -> bool:
    """True for the docstring that dataclasses and NamedTuple invent when a class has none (``Name(a, b)``)."""
    return doc.startswith(f"{cls.__name__}(") and doc.rstrip().endswith(")") and "\n" not in doc.strip()


def own_doc(obj) -> str:
    """The object's own docstring, cleaned; '' when it has none (inherited and auto-generated ones do not count)."""
    if isinstance(obj, (staticmethod, classmethod)):
        obj = obj.__func__
    if isinstance(obj, property):
        doc = obj.__doc__ or (obj.fget.__doc__ if obj.fget else None)
    elif inspect.isclass(obj):
        doc = vars(obj).get("__doc__")
        if doc and _autodoc(obj, doc):
            doc = None
    else:
        doc = getattr(obj, "__doc__", None)
    return inspect.cleandoc(doc) if isinstance(doc, str) else ""


def _annotation(ann) -> str:
    return ann if isinstance(ann, str) else inspect.formatannotation(ann)


def signature(name: str, obj) -> str:
    """``name(params) -> return`` as source-like text, memory addresses removed; long ones one parameter a line.

    Classes read ``class Name(constructor parameters)``, exceptions ``class Name(bases)``.
    """
    if isinstance(obj, (staticmethod, classmethod)):
        obj = obj.__func__
    if isinstance(obj, property):
        ann = inspect.signature(obj.fget).return_annotation if obj.fget else inspect.Signature.empty
        typ = "" if ann is inspect.Signature.empty else f": {_annotation(ann)}"
        return f"{name}{typ}  # property"
    if inspect.isclass(obj) and issubclass(obj, BaseException):
        bases = ", ".join(b.__name__ for b in obj.__bases__)
        return f"class {name}({bases})"
    if inspect.isclass(obj):
        name = f"class {name}"
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return f"{name}(...)"
    params = [_ADDRESS.sub("", str(p)) for p in sig.parameters.values()]
    ret = ""
    if sig.return_annotation is not inspect.Signature.empty and not inspect.isclass(obj):
        ret = " -> " + _annotation(sig.return_annotation)
    one = f"{name}({', '.join(params)}){ret}"
    if len(one) <= _MAX_SIGNATURE or not params:
        return one
    return f"{name}(\n" + "".join(f"    {p},\n" for p in params) + f"){ret}"


def _constant_docs(module) -> dict[str, str]:
    """Attribute docstrings: a string literal right after a top-level assignment documents that name."""
    body = _top_level(module)
    out = {}
    for node, nxt in zip(body, body[1:]):
        if isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant) and isinstance(nxt.value.value, str):
            for name in _assigned(node):
                out[name] = inspect.cleandoc(nxt.value.value)
    return out


def _constant_value(obj) -> str:
    """Short repr of a constant, or ``<type, N items>`` when it would not fit on a table row."""
    text = _ADDRESS.sub("", repr(obj))
    if len(text) <= 80 and "\n" not in text and "`" not in text:
        return f"`{text}`".replace("|", "\\|")
    n = f", {len(obj)} items" if hasattr(obj, "__len__") else ""
    return f"<{type(obj).__name__}{n}>"


def _summary(doc: str) -> str:
    """First paragraph of a docstring, on one line."""
    para = doc.strip().split("\n\n", 1)[0] if doc.strip() else ""
    return " ".join(line.strip() for line in para.splitlines())


def _anchor(text: str) -> str:
    """GitHub's heading anchor for ``text`` (lower case, punctuation dropped, spaces to dashes)."""
    return re.sub(r"[^\w\- ]", "", text.lower()).replace(" ", "-")


def _fence(text: str, lang: str = "text") -> list[str]:
    return [f"```{lang}", text.rstrip(), "```", ""]


def render_module(name: str) -> list[str]:
    """Markdown lines of one module's section."""
    module = importlib.import_module(name)
    doc = own_doc(module)
    lines = [f"## {name}", ""]
    if doc:
        lines += _fence(doc)
    exported = getattr(module, "__all__", None)
    members = public_members(module)
    if name == PACKAGE and exported:
        lines += ["Re-exports: " + ", ".join(f"`{n}`" for n in sorted(exported, key=str.lower)) + ".", ""]
    consts = [(n, o) for n, o in members if kind(o) == "constant"]
    if consts:
        cdocs = _constant_docs(module)
        lines += ["| constant | value | meaning |", "|---|---|---|"]
        for n, o in consts:
            meaning = _summary(cdocs.get(n, "")).replace("|", "\\|")
            lines.append(f"| `{n}` | {_constant_value(o)} | {meaning} |")
        lines.append("")
    for n, o in members:
        k = kind(o)
        if k == "constant":
            continue
        lines += [f"### {name}.{n}", ""]
        lines += _fence(signature(n, o), "python")
        d = own_doc(o)
        lines += _fence(d) if d else ["*(no docstring)*", ""]
        if k == "class":
            for mn, mo in public_methods(o):
                lines += [f"#### {name}.{n}.{mn}", ""]
                lines += _fence(signature(mn, mo), "python")
                md = own_doc(mo)
                lines += _fence(md) if md else ["*(no docstring)*", ""]
    return lines


def render(package: str = PACKAGE) -> str:
    """The whole API reference as Markdown text."""
    names = module_names(package)
    lines = [
        "# gyrojax API reference",
        "",
        "<!-- Generated from the docstrings by `make docs` (python -m gyrojax.apidoc). Do not edit by hand. -->",
        "",
        "Units follow CONVENTIONS §1 ([summary](concepts.md#units)): deg/h, deg/h/g, ppm, g, mA, deg and s at the "
        "surface, SI inside. Every public module, function, class and method is listed with its signature and "
        "docstring; `tests/test_api_docs.py` checks that each has one and that those handling physical quantities "
        "name their units.",
        "",
        "| module | summary |",
        "|---|---|",
    ]
    for n in names:
        summary = _summary(own_doc(importlib.import_module(n))).replace("|", "\\|")
        lines.append(f"| [{n}](#{_anchor(n)}) | {summary} |")
    lines.append("")
    for n in names:
        lines += render_module(n)
    return "\n".join(lines).rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    """Write docs/api.md (or the path given); ``--check`` exits 1 if the file is out of date instead."""
    args = list(sys.argv[1:] if argv is None else argv)
    check = "--check" in args
    paths = [a for a in args if a != "--check"]
    out = Path(paths[0]) if paths else reference_path()
    text = render()
    if check:
        current = out.read_text(encoding="utf-8") if out.exists() else ""
        if current != text:
            print(f"{out} is out of date: run make docs", file=sys.stderr)
            return 1
        return 0
    from .io import atomic_write_text

    atomic_write_text(out, text)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
