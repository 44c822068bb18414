"""The measurement model's compiled functions kept across processes: ``predict``, and ``predict_and_jacobian`` (the
prediction and the Jacobian in one pass: what ``linearize`` needs), called through their kept executables
(:class:`gyrojax.runtime.kept.Kept`), so that the first diagnosis of a fresh process neither traces nor compiles the
model again.

The model is data, not code: it is evaluated as a :class:`~gyrojax.physics.model.Selected` of its kind's
:func:`library` (every built-in effect of the kind), its θ padded to a few lengths (:func:`padded`), so that one
executable per library, θ length and piece size serves every model, and a diagnosis that adds an effect, or a model
never fitted before, loads what an earlier one compiled.

A record is evaluated in pieces of a few fixed numbers of measurements (:func:`over_rows`: the chunks of
:mod:`gyrojax.runtime.rows`, each piece a record of its own, :func:`gyrojax.physics.model.measurement_rows`), so
that records of every length share the executables.

A model is kept only when every term is a built-in effect (:data:`gyrojax.physics.registry.BUILTIN`): the code
of a built-in effect depends on the library source alone, which the key carries (with the library's kind and terms,
the record's static fields and shapes, and the JAX version); an effect the user registered (``--effect``, an
expression) is compiled in each process, so that an edited expression can never meet an old executable. The arguments'
tree carries the record's static fields (mode, servo and encoder axes), so records of other modes get other keys.

The triad fit's compiled passes (:mod:`gyrojax.inference.triad_rows`: segment means and their Jacobian, the moves'
rows, S of the channel model) are kept the same way, through :func:`kept_call`; a function that closes over a model
and a few constants (the campaign loop's design search and the information of a test) through :func:`kept_jit`.
"""

from __future__ import annotations

import hashlib
from functools import lru_cache, partial

import jax
import numpy as np

from gyrojax.physics import effects as fx
from gyrojax.physics import registry
from gyrojax.physics.model import (
    Model,
    RecordData,
    Selected,
    measurement_rows,
    measurements,
    predict,
    predict_and_jacobian,
    predict_and_jacobian_jit,
    predict_jit,
)
from gyrojax.runtime.kept import Kept
from gyrojax.runtime.rows import chunks, joined


def keepable(model: Model) -> bool:
    """Whether executables of ``model`` may be kept on disk: all of its terms are built-in effects."""
    return set(model.terms) <= registry.BUILTIN


def model_name(stem: str, model: Model) -> str:
    """A file-name-safe name of ``stem`` for ``model``: its kind and a digest of its ordered terms."""
    digest = hashlib.sha256(repr((model.kind, tuple(model.terms))).encode()).hexdigest()[:12]
    return f"{stem}_{model.kind.replace('-', '')}_{digest}"


@lru_cache(maxsize=64)
def _kept(stem: str, model: Model, fn) -> Kept:
    """The kept executable of ``fn(model, ...)`` under the name ``stem`` (one name per function: it keys the files)."""
    return Kept(model_name(stem, model), jax.jit(partial(fn, model)))


def kept_call(stem: str, fn, jitted, model: Model, *args):
    """``fn(model, *args)`` compiled: through the kept executable named ``stem`` when :func:`keepable`, else by
    ``jitted`` (``fn`` jitted with ``model`` static), which a user effect is traced by in each process."""
    if not keepable(model):
        return jitted(model, *args)
    return _kept(stem, model, fn)(*args)


def kept_jit(stem: str, model: Model, fn, *statics):
    """``fn`` jitted, its executables kept across processes under a name of ``stem``, ``model`` and ``statics`` when
    :func:`keepable` (else jitted in each process). ``fn`` is a function of arrays closing over ``model`` and
    ``statics``, which must be everything it closes over: together with the library's source (in every key) they
    determine its code."""
    return Kept.of(model_name(stem, model), fn, *statics) if keepable(model) else jax.jit(fn)


def library(model: Model) -> Model:
    """The built-in effects of ``model``'s kind, in the registry's order, that compiled code of ``model`` carries: the
    set-up effects only when the model holds one (else the kinematics carry no derivative), the effects not linear in
    the input rate (deg/h) only when it holds one (else a servo record takes one Newton step,
    :func:`~gyrojax.physics.model.servo_rate`)."""
    setup = any(e.setup for e in model.effects)
    in_rate = all(e.linear_in_rate for e in model.effects)
    terms = []
    for name in registry.names(model.kind):
        e = registry.get(name)
        if name in registry.BUILTIN and (setup or not e.setup) and (e.linear_in_rate or not in_rate):
            terms.append(name)
    return Model(tuple(terms), model.kind)


def padded(p: int) -> int:
    """The length θ of p coefficients is padded to: a power of two, at least 4 (a handful of executables per
    library)."""
    return max(4, 1 << max(p - 1, 0).bit_length())


def selected(model: Model) -> Selected:
    """``model`` over its :func:`library`, θ padded to :func:`padded`."""
    return Selected.of(model, library(model), padded(model.size))


@lru_cache(maxsize=64)
def _kept_library(stem: str, lib: Model, fn) -> Kept:
    """The kept executable named ``stem`` of ``fn(selected, …)`` for the selections of ``lib``."""
    return Kept(model_name(stem, lib), jax.jit(fn))


def kept_selected(stem: str, fn, jitted, model: Model, *args):
    """``fn(model, *args)`` compiled: when :func:`keepable`, as ``fn`` of the model's :func:`selected` through the
    kept executable of its library named ``stem`` (outputs over θ then have the padded θ's length), else by ``jitted``
    (``fn`` jitted with ``model`` static)."""
    if not keepable(model):
        return jitted(model, *args)
    sel = selected(model)
    return _kept_library(stem, sel.library, fn)(sel, *args)


def over_rows(call, data: RecordData, blocks: int = 1):
    """``call(piece)`` of every piece of a record (:func:`gyrojax.physics.model.measurement_rows` at the chunks of
    :func:`gyrojax.runtime.rows.chunks`), its outputs (any tree of arrays whose leading axis holds ``blocks`` blocks of
    the piece's rows: the two channels of a TDF gyro's measurements) put together as those of the whole record
    (numpy arrays)."""
    m = measurements(data)
    pieces = chunks(m)
    parts = [call(measurement_rows(data, first, rows)) for first, rows in pieces]
    sizes = [rows for _, rows in pieces]
    return jax.tree_util.tree_map(lambda *xs: joined(xs, sizes, m, blocks), *parts)


def kept_rows(stem: str, fn, jitted, model: Model, theta, data: RecordData):
    """``fn(model, theta, data)``, whose outputs are per measurement (TDF: both channels), compiled: when
    :func:`keepable`, as ``fn`` of the model's :func:`selected` through the kept executable named ``stem``, piece by
    piece (:func:`over_rows`: one executable per library, θ length and chunk size, whatever the model and the length;
    a Jacobian then has the padded θ's columns), else by ``jitted`` on the whole record."""
    if not keepable(model) or measurements(data) == 0:
        return jitted(model, theta, data)
    sel = selected(model)
    th = sel.pad(theta)
    kept = _kept_library(stem, sel.library, fn)
    tdf = data.kind == fx.TDF and data.mode != "servo"
    return over_rows(lambda piece: kept(sel, th, piece), data, 2 if tdf else 1)


def kept_predict(model: Model, theta, data):
    """:func:`gyrojax.physics.model.predict` of ``model`` (``predict_jit``), through a kept executable when
    :func:`keepable`."""
    return kept_rows("predict", predict, predict_jit, model, theta, data)


def kept_predict_and_jacobian(model: Model, theta, data):
    """:func:`gyrojax.physics.model.predict_and_jacobian` of ``model`` (one compiled pass: a fresh process loads one
    executable per library instead of two), through a kept executable when :func:`keepable`."""
    y, jac = kept_rows("predict_jacobian", predict_and_jacobian, predict_and_jacobian_jit, model, theta, data)
    return y, np.asarray(jac)[:, : model.size]
