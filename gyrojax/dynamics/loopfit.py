"""Loop-aware identification: the rebalance loop's parameters from oscillating-table records, and where the
quasi-static fit becomes biased (Titterton §8.5.4, frequency response; Hu 2-50 to 2-56).

An oscillating table drives the input axis with ω_I(t) = ω_0 + A·sin(2π f t). At each frequency the record's
indicated rate, fitted by a sine and cosine at f, divided by the input's, is the measured closed-loop response
H(j2πf) (gain and phase). The loop model (:func:`gyrojax.dynamics.loops.rebalance_closed_loop_tf`) is fitted to the
measured
response by least squares on the complex residual over the chosen parameters (log scale, so they stay positive).

The quasi-static balance equation reads the response as 1 at every frequency; fitting it to an oscillating record
turns the loop's gain roll-off into a spurious scale-factor error E_SF ≈ (Re H − 1)·10⁶ ppm: :func:`quasi_static_bias`
shows where that starts to matter.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrojax import units
from gyrojax.data import plans
from gyrojax.data.arrays import record_data
from gyrojax.dynamics.loops import RebalanceParams, rebalance_closed_loop_tf
from gyrojax.errors import ConvergenceWarning
from gyrojax.physics.model import Model, instrument_inputs, setup_values


def oscillation_plan(
    frequencies_hz,
    amplitude_deg: float = 0.05,
    cycles: float = 8.0,
    dt_s: float = 1e-3,
    latitude_deg=plans.DEFAULT_LATITUDE,
) -> plans.Plan:
    """A single-axis table about Up, IA up, oscillating at each frequency in turn (one segment per frequency).

    ``frequencies_hz`` in Hz, ``amplitude_deg`` in deg, ``cycles`` per frequency, ``dt_s`` in s; S_nom = 3600
    deg/h/mA.
    """
    segs = tuple(
        plans.Segment((0.0,), cycles / f, dt_s, amplitude_deg=(amplitude_deg,), frequency_hz=float(f), label=i)
        for i, f in enumerate(frequencies_hz)
    )
    run = plans.Run(
        "oscillation", (("rate", plans.U),), plans.sdf_mount(plans.U, plans.N), segs, scale_factor=3600.0, gap_s=1.0
    )
    return plans.Plan(
        "oscillation",
        (run,),
        latitude_deg,
        description="oscillating-table frequency response",
        reference="Titterton §8.5.4",
    )


def _sine_fit(t, y, f):
    a = np.column_stack([np.ones_like(t), np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
    c, *_ = np.linalg.lstsq(a, y, rcond=None)
    return c[1] + 1j * c[2]  # complex amplitude of sin (real part) and cos (imaginary part)


def measured_response(record, frequencies_hz, settle_cycles: float = 2.0) -> np.ndarray:
    """Complex response (indicated / input-axis rate) at each segment's frequency, skipping the first cycles.

    Dimensionless (both rates in deg/h); ``frequencies_hz`` in Hz, ``settle_cycles`` cycles skipped per segment.
    """
    d = record_data(record)
    x = instrument_inputs(d, setup_values(Model(()), np.zeros(0)))
    w_in = np.asarray(x["w_I"])
    ind = record.indicated
    seg = record.segment_id
    out = []
    for sid, f in zip(np.unique(seg), frequencies_hz):
        idx = np.flatnonzero(seg == sid)
        t = record.time_s[idx] - record.time_s[idx[0]]
        keep = t >= settle_cycles / f
        out.append(_sine_fit(t[keep], ind[idx][keep], f) / _sine_fit(t[keep], w_in[idx][keep], f))
    return np.array(out)


def model_response(params: RebalanceParams, frequencies_hz, dt_s: float) -> np.ndarray:
    """Closed-loop response as a sampled record sees it: T(s) with the hold over each sample and the reading at
    the end of the hold, T(s)·(e^{sT} − 1)/(sT)."""
    s = 2j * np.pi * np.asarray(frequencies_hz, dtype=float)
    hold = (np.exp(s * dt_s) - 1.0) / (s * dt_s)
    return rebalance_closed_loop_tf(params, s) * hold


def fit_loop(
    frequencies_hz,
    measured,
    params0: RebalanceParams,
    names=("K_amp", "C_damp"),
    dt_s: float = 1e-3,
    max_nfev: int | None = None,
):
    """Loop parameters ``names`` that best explain the measured response (least squares on the complex residual).

    Returns ``(params, result)`` with ``result`` the scipy ``OptimizeResult`` (``result.x`` are log-parameters;
    ``result.success``/``status``/``message`` say whether and why it stopped). A search that stopped without
    converging raises :class:`~gyrojax.errors.ConvergenceWarning` with scipy's reason.
    """
    import warnings

    from scipy.optimize import least_squares

    f = np.asarray(frequencies_hz, dtype=float)
    m = np.asarray(measured)

    def with_(u):
        return dataclasses.replace(params0, **{n: float(np.exp(v)) for n, v in zip(names, u)})

    def resid(u):
        r = model_response(with_(u), f, dt_s) - m
        return np.concatenate([r.real, r.imag])

    u0 = np.log([getattr(params0, n) for n in names])
    res = least_squares(resid, u0, x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=max_nfev)
    if not res.success:
        warnings.warn(
            f"fit_loop of {', '.join(names)} did not converge: {res.message}", ConvergenceWarning, stacklevel=2
        )
    return with_(res.x), res


def quasi_static_bias(params: RebalanceParams, frequencies_hz, dt_s: float = 1e-3) -> np.ndarray:
    """Spurious scale-factor error (ppm) a quasi-static fit reads from a sinusoid at each frequency: (Re H − 1)·10⁶."""
    return (model_response(params, frequencies_hz, dt_s).real - 1.0) / units.PPM
