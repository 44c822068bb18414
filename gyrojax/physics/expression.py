"""Effects written as expressions: ``NAME=EXPR`` from the command line or an ``[effects]`` file, no Python needed.

EXPR is arithmetic in the instrument inputs of :mod:`gyrojax.physics.effects` (SDF, FOG, RLG: ``w_I, w_O, w_S`` in
deg/h, ``a_I, a_O, a_S`` in g, ``t_h`` in h, ``temperature_C`` in °C; TDF gyros: ``w_X, w_Y, w_Z, a_X, a_Y, a_Z`` and
the channel flags ``channel_is_X``, ``channel_is_Y``; accelerometers: ``w_I, w_P, w_O, a_I, a_P, a_O``), numbers,
``pi``, the operators ``+ - * / **`` and the functions ``sin, cos, abs, sqrt, exp, sign``. The effect contributes

    NAME · EXPR        (deg/h per unit of EXPR for gyros, g per unit of EXPR for accelerometers)

to the indicated output, with one coefficient called NAME; it is linear in that coefficient, so it is fitted in
one solve, tested by the diagnosis, simulated and designed for like a built-in effect.

Parsing is by an AST whitelist (Python's ``ast`` module parses the text; only the node types above are accepted and
turned into a tree of ``jax.numpy`` calls). Nothing is ever passed to ``eval``; anything else — attributes, indexing,
keywords, unknown names or functions — is refused with an :class:`ExpressionError` naming the token and its column.
The resulting function is pure ``jax.numpy``, so ``jit``, ``vmap`` and ``grad`` go through it as through the
built-ins (note that ``sqrt`` and ``abs`` have no finite slope at 0, which matters only when a set-up effect's
derivative passes through them).

A file of the effects a laboratory uses every day (TOML or JSON)::

    [effects]
    D_III = "a_I**3"
    D_Tsq = { expr = "t_h**2", max = 0.01 }     # max: plausible |coefficient| (diagnosis' plausibility check)

or ``{"effects": {"D_III": "a_I**3"}}`` in JSON.
"""

from __future__ import annotations

import ast
import json
import math
import re
from contextlib import contextmanager
from pathlib import Path

import jax.numpy as jnp

from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics import registry

FUNCTIONS = {"sin": jnp.sin, "cos": jnp.cos, "abs": jnp.abs, "sqrt": jnp.sqrt, "exp": jnp.exp, "sign": jnp.sign}
CONSTANTS = {"pi": math.pi}
_GYRO = ("w_I", "w_O", "w_S", "a_I", "a_O", "a_S", "t_h", "temperature_C")
INPUTS = {
    fx.SDF: _GYRO,
    fx.FOG: _GYRO,
    fx.RLG: _GYRO,
    fx.TDF: ("w_X", "w_Y", "w_Z", "a_X", "a_Y", "a_Z", "t_h", "temperature_C", "channel_is_X", "channel_is_Y"),
    fx.ACCEL: ("w_I", "w_P", "w_O", "a_I", "a_P", "a_O", "t_h", "temperature_C"),
}
"""Inputs an expression may use, per instrument kind (units in the module doc)."""
OUTPUT_UNIT = {fx.SDF: "deg/h", fx.FOG: "deg/h", fx.RLG: "deg/h", fx.TDF: "deg/h", fx.ACCEL: "g"}

_BINARY = {ast.Add: jnp.add, ast.Sub: jnp.subtract, ast.Mult: jnp.multiply, ast.Div: jnp.divide, ast.Pow: jnp.power}
_UNARY = {ast.USub: jnp.negative, ast.UAdd: lambda v: v}
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

_DEFINED: dict[str, tuple[str, str]] = {}
"""Every expression effect defined in this process: name -> (expression, kind). A name keeps its expression for the
life of the process, because compiled models are cached by effect name."""
PLAUSIBLE_MAX: dict[str, float] = {}
"""Plausible |coefficient| of expression effects that gave one (``max`` in an effects file), report units."""


class ExpressionError(ModelError):
    """An effect expression that cannot be accepted (bad token, unknown input or function, bad NAME=EXPR)."""


def _bad(node: ast.AST, text: str, why: str) -> ExpressionError:
    col = getattr(node, "col_offset", None)
    where = f" at column {col + 1}" if col is not None else ""
    token = ast.get_source_segment(text, node) or type(node).__name__
    return ExpressionError(f"effect expression {text!r}: {why} {token!r}{where}")


def compile_expression(text: str, kind: str = fx.SDF):
    """Parse ``text`` into a pure ``jax.numpy`` function of the inputs dict; returns ``(f, inputs_used)``.

    ``f(x)`` gives EXPR for every sample of the inputs dict ``x`` (:func:`gyrojax.physics.model.instrument_inputs`).
    Raises :class:`ExpressionError` naming the first token outside the whitelist (module doc).
    """
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError(f"effect expression must be a non-empty string, got {text!r}")
    if kind not in INPUTS:
        raise ExpressionError(f"unknown instrument kind {kind!r}; valid: {', '.join(INPUTS)}")
    allowed = INPUTS[kind]
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as e:
        col = f" at column {e.offset}" if e.offset else ""
        raise ExpressionError(f"effect expression {text!r} is not arithmetic: {e.msg}{col}") from None
    text = text.strip()
    used: set[str] = set()

    def build(node):
        if isinstance(node, ast.Expression):
            return build(node.body)
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise _bad(node, text, "only numbers are allowed as constants, not")
            v = float(node.value)
            return lambda x: v
        if isinstance(node, ast.Name):
            if node.id in CONSTANTS:
                v = CONSTANTS[node.id]
                return lambda x: v
            if node.id in FUNCTIONS:
                raise _bad(node, text, "a function needs an argument in parentheses:")
            if node.id not in allowed:
                raise ExpressionError(
                    f"effect expression {text!r}: unknown input {node.id!r} at column "
                    f"{node.col_offset + 1} (a {kind} has {', '.join(allowed)})"
                )
            used.add(node.id)
            key = node.id
            return lambda x: x[key]
        if isinstance(node, ast.BinOp):
            op = _BINARY.get(type(node.op))
            if op is None:
                raise _bad(node, text, "operator not allowed (use + - * / **) in")
            a, b = build(node.left), build(node.right)
            return lambda x: op(a(x), b(x))
        if isinstance(node, ast.UnaryOp):
            op = _UNARY.get(type(node.op))
            if op is None:
                raise _bad(node, text, "operator not allowed in")
            a = build(node.operand)
            return lambda x: op(a(x))
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                raise _bad(node.func, text, f"unknown function (allowed: {', '.join(FUNCTIONS)})")
            if node.keywords or len(node.args) != 1 or isinstance(node.args[0], ast.Starred):
                raise _bad(node, text, "a function takes exactly one plain argument:")
            f, a = FUNCTIONS[node.func.id], build(node.args[0])
            return lambda x: f(a(x))
        raise _bad(node, text, "token not allowed")

    f = build(tree)
    if not used:
        raise ExpressionError(
            f"effect expression {text!r} uses no instrument input: a constant is D_F's job "
            f"(inputs of a {kind}: {', '.join(allowed)})"
        )
    return f, tuple(sorted(used))


def split_definition(definition: str) -> tuple[str, str]:
    """``"NAME=EXPR"`` -> ``(NAME, EXPR)``; :class:`ExpressionError` when it does not look like that."""
    if not isinstance(definition, str) or "=" not in definition:
        raise ExpressionError(f"--effect {definition!r} must look like NAME=EXPR, e.g. D_III='a_I**3'")
    name, expr = definition.split("=", 1)
    return name.strip(), expr.strip()


def expression_effect(name: str, expr: str, kind: str = fx.SDF) -> fx.Effect:
    """The :class:`~gyrojax.effects.Effect` ``name · expr`` (module doc), not yet registered.

    It applies to every instrument kind whose inputs cover ``expr``; its one coefficient is called ``name`` and
    has the unit "deg/h per (expr)" (g per (expr) for accelerometers).
    """
    if not isinstance(name, str) or not _NAME.match(name):
        raise ExpressionError(f"effect name {name!r} must start with a letter and hold only letters, digits and _")
    if name in FUNCTIONS or name in CONSTANTS or any(name in v for v in INPUTS.values()):
        raise ExpressionError(f"effect name {name!r} is a function or input name; choose another")
    f, used = compile_expression(expr, kind)
    kinds = tuple(
        k
        for k, allowed in INPUTS.items()
        if set(used) <= set(allowed) and OUTPUT_UNIT[k] == OUTPUT_UNIT[kind] and (k == kind or k != fx.TDF)
    )
    unit = f"{OUTPUT_UNIT[kind]} per ({expr.strip()})"
    return fx.Effect(
        name=name,
        coefficients=(name,),
        units=(unit,),
        kinds=kinds,
        contribution=lambda x, c: c[0] * f(x),
        description=f"user effect: {name} · ({expr.strip()})",
        reference="user expression (gyrojax.physics.expression)",
        linear_in_rate=not any(u.startswith("w_") for u in used),  # (conservatively) the servo then solves for it
    )


def define(definition: str, kind: str = fx.SDF, plausible_max: float | None = None) -> str:
    """Register the effect of ``"NAME=EXPR"`` (or return its name if the same definition is registered already).

    Raises :class:`ExpressionError` for a bad expression or name, and when NAME is taken by a built-in effect or
    coefficient or was defined with another expression earlier in this process. ``plausible_max``: plausible
    |coefficient| in its report unit (used by the diagnosis' plausibility check). Returns NAME.
    """
    name, expr = split_definition(definition)
    eff = expression_effect(name, expr, kind)  # validates before anything is registered
    expr = expr.strip()
    if name in _DEFINED:
        old_expr, old_kind = _DEFINED[name]
        if old_expr != expr:
            raise ExpressionError(
                f"effect {name!r} was defined as {old_expr!r} earlier in this process; choose another name for {expr!r}"
            )
        if name not in fx.names():
            fx.register(eff)
    else:
        if name in fx.names() or name in fx.coefficient_index():
            raise ExpressionError(f"effect name {name!r} is already a built-in effect or coefficient name")
        fx.register(eff)
        _DEFINED[name] = (expr, kind)
    if plausible_max is not None:
        if not (isinstance(plausible_max, (int, float)) and plausible_max > 0):
            raise ExpressionError(f"effect {name!r}: 'max' must be a positive number, got {plausible_max!r}")
        PLAUSIBLE_MAX[name] = float(plausible_max)
    return name


def define_all(definitions, kind: str = fx.SDF) -> list[str]:
    """:func:`define` each ``"NAME=EXPR"`` of ``definitions`` (None: none); returns the names in order."""
    return [define(d, kind) for d in (definitions or [])]


def load_effects_file(path, kind: str = fx.SDF) -> list[str]:
    """Register the effects of the ``[effects]`` section of a TOML file or the ``"effects"`` object of a JSON file
    (module doc); returns their names. Errors name the file and the key."""
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as e:
        raise ExpressionError(f"{p}: cannot be read ({e.strerror or e})") from None
    try:
        if p.suffix.lower() == ".json":
            d = json.loads(raw.decode("utf-8"))
        else:
            import tomllib

            d = tomllib.loads(raw.decode("utf-8"))
    except (ValueError, UnicodeDecodeError) as e:
        raise ExpressionError(f"{p}: not valid {'JSON' if p.suffix.lower() == '.json' else 'TOML'}: {e}") from None
    if not isinstance(d, dict) or not isinstance(d.get("effects"), dict):
        raise ExpressionError(f"{p}: needs an 'effects' table of NAME = \"EXPR\" entries")
    names = []
    for k, v in d["effects"].items():
        mx = None
        if isinstance(v, dict):
            unknown = set(v) - {"expr", "max"}
            if unknown or "expr" not in v:
                raise ExpressionError(
                    f"{p}: key 'effects.{k}' must be a string or a table with 'expr' (and "
                    f"optionally 'max'); got keys {sorted(v)}"
                )
            v, mx = v["expr"], v.get("max")
        if not isinstance(v, str):
            raise ExpressionError(f"{p}: key 'effects.{k}' must be an expression string, got {v!r}")
        try:
            names.append(define(f"{k}={v}", kind, mx))
        except ExpressionError as e:
            raise ExpressionError(f"{p}: key 'effects.{k}': {e}") from None
    return names


def command_line_effects(definitions=None, files=None, kind: str = fx.SDF) -> list[str]:
    """Register the effects of ``--effects-file PATH`` (each ``files`` entry) and ``--effect NAME=EXPR`` (each
    ``definitions`` entry) for instruments of ``kind``; returns their names in order, once each."""
    names = []
    for f in files or []:
        names += load_effects_file(f, kind)
    names += define_all(definitions, kind)
    return list(dict.fromkeys(names))


@contextmanager
def defined(*definitions, kind: str = fx.SDF):
    """Context in which the effects ``"NAME=EXPR"`` are registered; those it registered are removed on exit (their
    names stay bound to their expressions for the process, see :func:`define`). Yields the names."""
    fresh = [split_definition(d)[0] not in fx.names() for d in definitions]
    names = [define(d, kind) for d in definitions]
    try:
        yield names
    finally:
        for n, new in zip(names, fresh):
            if new:
                registry.unregister(n)
