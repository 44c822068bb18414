"""What the docstring audit (tests/test_api_docs.py) reads of the package: its public modules (every subpackage,
walked), their public members in source order, and each object's own docstring.

Public means: a module whose dotted name has no part starting with ``_``; in it, the names listed in ``__all__``
where the module defines one, otherwise every top-level name not starting with ``_``; names imported from another
module (re-exports, aliases of foreign functions or classes) are left to the module that defines them. The HTML
reference itself is built by pdoc (``make docs``).
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil

PACKAGE = "gyrojax"


def module_names(package: str = PACKAGE) -> list[str]:
    """Dotted names of the package and its public modules (no ``_`` prefix, no ``__main__``), sorted."""
    pkg = importlib.import_module(package)
    subs = [
        m.name
        for m in pkgutil.walk_packages(pkg.__path__, prefix=f"{package}.")
        if not any(part.startswith("_") for part in m.name.split("."))
    ]
    return [package] + sorted(subs)


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
