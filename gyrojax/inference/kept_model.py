"""The measurement model's compiled functions kept across processes: ``predict``, and ``predict_and_jacobian`` (the
prediction and the Jacobian in one pass: what ``linearize`` needs), of a :class:`~gyrojax.physics.model.Model` (a
static argument) called through their kept executables (:class:`gyrojax.runtime.kept.Kept`), so that the first
diagnosis of a fresh process neither traces nor compiles the model again.

A record is evaluated in pieces of a few fixed numbers of measurements (:func:`over_rows`: the chunks of
:mod:`gyrojax.runtime.rows`, each piece a record of its own, :func:`gyrojax.physics.model.measurement_rows`), so
that one executable per model and chunk size serves records of every length: a campaign of lengths never seen before
loads what an earlier one compiled.

A model is kept only when every term is a built-in effect (:data:`gyrojax.physics.registry.BUILTIN`): the code
of a built-in effect depends on the library source alone, which the key carries (with the model's kind and terms,
the record's static fields and shapes, and the JAX version); an effect the user registered (``--effect``, an
expression) is compiled in each process, so that an edited expression can never meet an old executable. The arguments'
tree carries the record's static fields (mode, servo and encoder axes), so records of other modes get other keys.

The triad fit's compiled passes (:mod:`gyrojax.inference.triad_rows`: segment means and their Jacobian, the moves'
rows, S of the channel model) are kept the same way, through :func:`kept_call`.
"""

from __future__ import annotations

import hashlib
from functools import lru_cache, partial

import jax

from gyrojax.physics import effects as fx
from gyrojax.physics import registry
from gyrojax.physics.model import (
    Model,
    RecordData,
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
    """``fn(model, theta, data)``, whose outputs are per measurement (TDF: both channels), compiled: through the kept
    executable named ``stem`` piece by piece (:func:`over_rows`: one executable per chunk size, whatever the length)
    when :func:`keepable`, else by ``jitted`` on the whole record."""
    if not keepable(model) or measurements(data) == 0:
        return jitted(model, theta, data)
    kept = _kept(stem, model, fn)
    tdf = data.kind == fx.TDF and data.mode != "servo"
    return over_rows(lambda piece: kept(theta, piece), data, 2 if tdf else 1)


def kept_predict(model: Model, theta, data):
    """:func:`gyrojax.physics.model.predict` of ``model`` (``predict_jit``), through a kept executable when
    :func:`keepable`."""
    return kept_rows("predict", predict, predict_jit, model, theta, data)


def kept_predict_and_jacobian(model: Model, theta, data):
    """:func:`gyrojax.physics.model.predict_and_jacobian` of ``model`` (one compiled pass: a fresh process loads one
    executable per model instead of two), through a kept executable when :func:`keepable`."""
    return kept_rows("predict_jacobian", predict_and_jacobian, predict_and_jacobian_jit, model, theta, data)
