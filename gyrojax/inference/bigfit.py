"""Fitting records too big for memory: stream the CSV in chunks and accumulate the normal equations.

For a model linear in its coefficients (every effect but the set-up ones), the measurement is
y = f₀ + J θ + e, where f₀ = predict(model, 0, data) is the instrument's ideal output (ω_I for a gyro) and the
regressors J do not depend on θ. White-noise least squares then needs only

    JᵀJ = Σ_chunks J_cᵀ J_c,   Jᵀr = Σ J_cᵀ r_c,   rᵀr = Σ r_cᵀ r_c,   r = y − f₀ − J θ₀,

so memory is one chunk. θ = θ₀ + (JᵀJ)⁻¹ Jᵀr, and σ² = (rᵀr − δᵀ Jᵀr)/(n − p) (δ = θ − θ₀) is the pooled residual
variance; cov θ = σ² (JᵀJ)⁻¹. This is exactly ``identify.fit(record, terms, noise="white")`` for one record. θ₀ is
the least-squares solution of the first chunk, so the accumulated r is already residual-sized and the subtraction in
σ² loses no precision. The normal equations are solved in unit-norm columns; identifiability is judged on the p × p
factor R = Λ^½ Vᵀ of JᵀJ = V Λ Vᵀ, which has the same singular values and right singular vectors as J.

Each chunk is validated like a whole record (conventions §5): a bad cell or a non-increasing time is reported with
its row number in the file. Supported: rebalance records of an SDF gyro or an accelerometer whose table rates are
columns of the CSV or zero (static tables); rates derived from moving angles need neighbouring rows across chunk
edges and are left to :func:`gyrojax.inference.identify.fit`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from gyrojax.data.arrays import record_data
from gyrojax.data.csvfile import diagnose_csv, parse_csv_header, read_csv_bytes
from gyrojax.data.record import Record
from gyrojax.data.records import read_meta, record_paths
from gyrojax.data.schema import must_be_numeric, validate_columns, validate_meta
from gyrojax.errors import GyrojaxError, ModelError, RecordError
from gyrojax.inference.identifiability import ALIAS_TOL, IdentifiabilityError, alias_message, identifiability
from gyrojax.inference.identify import DEFAULT_TERMS
from gyrojax.inference.lstsq import lstsq_normal
from gyrojax.inference.result import Estimates
from gyrojax.inference.solver import solve
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, jacobian_jit, predict_jit


@dataclass
class ChunkedFit(Estimates):
    """Estimates (report units), standard errors and fit statistics of :func:`fit_chunked`."""

    model: Model
    theta: np.ndarray
    cov: np.ndarray
    n_samples: int
    residual_rms: float
    identifiability: dict
    chunks: int

    @property
    def coefficient_names(self):
        """Coefficient names in θ order (the keys of :attr:`values`, :attr:`stds`)."""
        return self.model.coefficient_names


def _check_chunk(meta, cols, csv_path, offset: int, prev_t: float | None):
    """Validate one chunk; ``offset`` = samples before it, so row numbers are those of the file (header = 1)."""
    for h, c in cols.items():
        if must_be_numeric(h) and not np.all(np.isfinite(c)):
            i = int(np.flatnonzero(~np.isfinite(c))[0])
            raise RecordError(
                f"{csv_path}: row {offset + i + 2}, column {h!r} holds {float(c[i])}; values must be finite numbers"
            )
    t = cols["time_s"]
    if prev_t is not None and t[0] <= prev_t:
        raise RecordError(
            f"{csv_path}: row {offset + 2}, column 'time_s': time {float(t[0])} does not exceed the previous row's "
            f"{float(prev_t)}; times must be strictly increasing"
        )
    try:
        validate_columns(meta, cols, csv_path)
    except Exception as e:  # re-number the rows of a chunk-local message
        import re

        msg = re.sub(r"row (\d+)", lambda m: f"row {int(m.group(1)) + offset}", str(e))
        raise type(e)(msg) from None


def _chunks(csv_path: Path, header, chunk_rows: int):
    import pandas as pd

    reader = pd.read_csv(
        csv_path,
        dtype=np.float64,
        na_filter=False,
        skipinitialspace=True,
        names=header,
        header=0,
        chunksize=chunk_rows,
        encoding="utf-8-sig",
    )
    yield from reader


def fit_chunked(path, terms=None, chunk_rows: int = 200_000, allow_aliases: bool = False) -> ChunkedFit:
    """White-noise least-squares fit of a linear model to one record, streaming its CSV (module doc).

    Args:
      path: the record (``NAME.csv`` or ``NAME.json``).
      terms: effect names (conventions §6); default as :func:`gyrojax.inference.identify.fit`. Every effect must be
      linear.
      chunk_rows: rows per chunk (memory ∝ chunk_rows × number of coefficients).

    Returns: a :class:`ChunkedFit` with ``values``, ``stds``, ``cov``, ``residual_rms``.

    Raises: :class:`~gyrojax.errors.RecordError` naming the file and the row/column of a bad cell;
      :class:`~gyrojax.errors.ModelError` for a nonlinear model or an unsupported record;
      :class:`~gyrojax.inference.identifiability.IdentifiabilityError` naming the effects the record cannot separate.
    """
    csv_path, json_path = record_paths(path)
    for p in (json_path, csv_path):
        if not p.exists():
            raise RecordError(f"{p}: no such file (a record is NAME.csv + NAME.json side by side)")
    meta = validate_meta(read_meta(json_path), json_path)
    kind = meta["instrument"]["kind"]
    if meta["mode"] != "rebalance" or kind == fx.TDF:
        raise ModelError(
            f"{json_path}: fit_chunked handles rebalance records of an sdf-gyro or pendulous-accel "
            f"(this one is {meta['mode']}, {kind}); use gyrojax.inference.identify.fit"
        )
    model = Model.of(terms if terms is not None else DEFAULT_TERMS[kind], kind)
    if not model.is_linear:
        raise ModelError(
            f"fit_chunked needs effects linear in their coefficients; {model.terms} are not all linear "
            "(table_tilt, table_azimuth, encoder_harmonic): use gyrojax.inference.identify.fit"
        )
    with open(csv_path, "rb") as fh:
        head = fh.read(1 << 16)
    header = parse_csv_header(csv_path, head if b"\n" in head else read_csv_bytes(csv_path))
    if "bias_temperature" in model.terms and "temperature_C" not in header:
        raise ModelError(f"{csv_path}: effect 'bias_temperature' needs column 'temperature_C', which is absent")
    axes = [a["name"] for a in meta["table"]["axes"]]
    moving_derived = [a for a in axes if f"rate_{a}_dps" not in header]

    p = model.size
    zeros = jnp.zeros(p)
    jtj, jtr, rtr, n, chunks = np.zeros((p, p)), np.zeros(p), 0.0, 0, 0
    theta0 = None
    prev_t = None
    temp_lo, temp_hi = np.inf, -np.inf
    last_angles: dict = {}
    last_seg = None
    import pandas as pd

    try:
        for df in _chunks(csv_path, header, chunk_rows):
            cols = {h: df[h].to_numpy() for h in header}
            _check_chunk(meta, cols, csv_path, n, prev_t)
            seg = cols.get("segment")
            for a in moving_derived:  # derived rates are zero only where the angle holds still inside a segment
                ang = cols[f"angle_{a}_deg"]
                same = np.ones(len(ang) - 1, bool) if seg is None else np.diff(seg) == 0
                edge = a in last_angles and (seg is None or seg[0] == last_seg) and ang[0] != last_angles[a]
                if np.any(np.diff(ang)[same] != 0) or edge:
                    raise ModelError(
                        f"{csv_path}: table axis {a!r} moves inside a segment but has no 'rate_{a}_dps' column; "
                        "fit_chunked needs table rates as columns (or use gyrojax.inference.identify.fit)"
                    )
            last_seg = None if seg is None else seg[-1]
            last_angles = {a: cols[f"angle_{a}_deg"][-1] for a in moving_derived}
            if "temperature_C" in cols:
                temp_lo, temp_hi = min(temp_lo, cols["temperature_C"].min()), max(temp_hi, cols["temperature_C"].max())
            data = record_data(Record(meta, cols, str(csv_path)))
            y = np.asarray(data.y)
            jac = np.asarray(jacobian_jit(model, zeros, data)) if p else np.zeros((len(y), 0))
            r = y - np.asarray(predict_jit(model, zeros, data))
            if theta0 is None:
                theta0 = solve(jac, r)[0] if p else np.zeros(0)
            r = r - jac @ theta0
            jtj += jac.T @ jac
            jtr += jac.T @ r
            rtr += float(r @ r)
            n += len(y)
            chunks += 1
            prev_t = float(cols["time_s"][-1])
    except GyrojaxError:
        raise
    except (ValueError, pd.errors.ParserError) as e:
        raw = read_csv_bytes(csv_path)  # name the first bad row and column of the whole file
        diagnose_csv(csv_path, raw, header, strict=False)
        raise RecordError(f"{csv_path}: is not a valid comma-separated table: {str(e).strip()}") from None
    if n == 0:
        raise RecordError(f"{csv_path}: has a header but no samples; at least one sample row is required")
    if "bias_temperature" in model.terms and temp_hi - temp_lo < 1e-6:
        raise ModelError(
            f"{csv_path}: effect 'bias_temperature' cannot be fitted: column 'temperature_C' is "
            f"constant ({temp_lo} °C), so it aliases D_F"
        )

    # solve in unit-norm columns; identifiability from R with RᵀR = JᵀJ
    norms = np.sqrt(np.clip(np.diag(jtj), 0.0, None))
    sc = np.where(norms > 0, norms, 1.0)
    a = jtj / np.outer(sc, sc)
    lam, v = np.linalg.eigh(a)
    lam = np.clip(lam, 0.0, None)
    r_factor = (np.sqrt(lam)[:, None] * v.T) * sc[None, :]
    report = identifiability(r_factor, model)
    if (report["aliases"] or report["unexcited"]) and not allow_aliases:
        raise IdentifiabilityError(f"{csv_path}: " + alias_message(report), report)
    delta, inv = lstsq_normal(jtj, jtr, "eigh", ALIAS_TOL)  # the rank cut of identify.fit
    theta = (theta0 if theta0 is not None else np.zeros(p)) + delta
    rank = report["rank"]
    rss = max(rtr - float(delta @ jtr), 0.0)
    dof = max(n - rank, 1)
    cov = inv * (rss / dof)
    return ChunkedFit(model, theta, cov, n, float(np.sqrt(rss / n)), report, chunks)


__all__ = ["ChunkedFit", "fit_chunked"]
