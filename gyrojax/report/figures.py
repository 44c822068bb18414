"""Readable reports: residual views and study figures (the text summaries are in :mod:`gyrojax.report.text`).

Every number carries its unit. Figures are plain ``matplotlib.figure.Figure`` objects, made without pyplot, so the
library never switches the caller's backend: they display as PNG in a notebook (``_repr_png_``) and save headless
through Agg. Nothing here changes a result.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter, ScalarFormatter

from gyrojax.inference.result import FitResult


class _Figure(Figure):
    """A pyplot-free figure that shows itself as PNG in IPython/Jupyter whatever the backend."""

    def _repr_png_(self) -> bytes:
        import io

        buf = io.BytesIO()
        FigureCanvasAgg(self).print_png(buf)
        return buf.getvalue()


def _figure(nrows: int = 1, ncols: int = 1, figsize=(6.4, 3.2), **kw):
    """A new figure and its axes (like ``pyplot.subplots``, without pyplot's global state or backend)."""
    fig = _Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, **kw)


def measurement_inputs(record) -> dict:
    """Per-measurement views of a record for plotting: time (h), table angles (deg), a_I/a_O/a_S (g), ω_I (deg/h),
    temperature, segment. Servo intervals are placed at their first sample."""
    import jax.numpy as jnp

    from gyrojax.data.arrays import record_data
    from gyrojax.physics.model import Model, instrument_inputs, setup_values

    d = record_data(record)
    x = instrument_inputs(d, setup_values(Model((), d.kind), jnp.zeros(0)))
    n = record.n
    view = {"time_h": record.time_s / 3600.0, "segment": record.segment_id}
    for i, a in enumerate(record.axis_names):
        view[f"angle {a} (deg)"] = record.angles_deg[:, i]
    keys = ("a_I", "a_O", "a_S", "w_I") if record.kind != "tdf-gyro" else ("a_X", "a_Y", "a_Z", "w_X")
    for k in keys:
        if k in x:
            view[k] = np.asarray(x[k])[:n]
    if record.temperature_C is not None:
        view["temperature (°C)"] = record.temperature_C
    if record.mode == "servo":
        view = {k: v[:-1] for k, v in view.items()}
        view["segment"] = view["segment"].copy()
    if record.kind == "tdf-gyro":
        view = {k: np.concatenate([v, v]) for k, v in view.items()}
    return view


def _band(ax, x, r, sigma, bins=48, color="C1"):
    """Binned mean of r against x with its ±3σ band (σ of a bin mean from the white-noise floor)."""
    if len(x) < 2 or np.ptp(x) == 0:
        return
    edges = np.linspace(np.min(x), np.max(x), bins + 1)
    idx = np.clip(np.digitize(x, edges) - 1, 0, bins - 1)
    cnt = np.bincount(idx, minlength=bins)
    mean = np.bincount(idx, weights=r, minlength=bins) / np.maximum(cnt, 1)
    mid = 0.5 * (edges[1:] + edges[:-1])
    ok = cnt > 0
    half = 3 * sigma / np.sqrt(np.maximum(cnt, 1))
    ax.plot(mid[ok], mean[ok], color=color, lw=1.6, label="binned mean")
    ax.fill_between(mid[ok], -half[ok], half[ok], color="0.6", alpha=0.35, label="±3σ of a bin mean")


def residual_figure(res: FitResult, records, against: str = "auto", title: str | None = None):
    """Residuals of every record against one view (``"time"``, a table angle, ``"a_I"`` …) with ±3σ bands.

    ``against="auto"`` picks the angle of the moving axis for tumbles and servo runs, else time. Residuals in
    deg/h (g for accelerometers), angles in deg modulo 360, time in h.
    """
    n = len(res.residuals)
    cols = min(n, 4)
    rows = int(np.ceil(n / cols))
    fig, axes = _figure(rows, cols, figsize=(3.6 * cols + 0.6, 2.8 * rows + 0.6), squeeze=False, sharey=True)
    sigma = res.noise_floor
    for k, (rec, r) in enumerate(zip(records, res.residuals)):
        ax = axes[k // cols][k % cols]
        view = measurement_inputs(rec)
        key = against
        if against == "auto":
            moving = [a for i, a in enumerate(rec.axis_names) if np.ptp(rec.angles_deg[:, i]) > 90]
            key = f"angle {moving[-1]} (deg)" if moving else "time_h"
        elif against == "time":
            key = "time_h"
        x = np.asarray(view.get(key, view["time_h"]))[: len(r)]
        if key.startswith("angle"):
            x = np.mod(x, 360.0)
        ax.plot(x, r, ".", ms=1.2, alpha=0.35, color="C0", rasterized=True, label="residual")
        _band(ax, x, r, sigma)
        ax.axhline(0, color="k", lw=0.6)
        ax.set_title(rec.name, fontsize=9)
        ax.set_xlabel(key.replace("time_h", "time (h)"), fontsize=8)
        if k % cols == 0:
            ax.set_ylabel("residual (deg/h)", fontsize=8)
        ax.tick_params(labelsize=7)
    for k in range(n, rows * cols):
        axes[k // cols][k % cols].axis("off")
    axes[0][0].legend(fontsize=7, loc="upper right", markerscale=6)
    lim = max(6 * sigma, np.percentile(np.abs(np.concatenate(res.residuals)), 99.5))
    axes[0][0].set_ylim(-lim, lim)
    fig.suptitle(title or f"residuals of {', '.join(res.model.terms)}", fontsize=10)
    fig.tight_layout()
    return fig


def harmonic_spectrum(res: FitResult, records, order: int = 4):
    """Amplitude of the residual's harmonics in the moving table angle (tumble and servo runs), per record,
    with the 3σ detection level of a harmonic amplitude for white noise at the floor. Amplitudes in the residual's
    units (deg/h for gyros); harmonics of order 1 … ``order`` per revolution."""
    fig, ax = _figure(figsize=(6.4, 3.2))
    ks = np.arange(1, order + 1)
    width = 0.8 / max(len(records), 1)
    floor = res.noise_floor
    for j, (rec, r) in enumerate(zip(records, res.residuals)):
        moving = [i for i in range(len(rec.axis_names)) if np.ptp(rec.angles_deg[:, i]) > 90]
        if not moving:
            continue
        th = np.deg2rad(rec.angles_deg[: len(r), moving[-1]])
        cols = [np.ones_like(th)] + [f(k * th) for k in ks for f in (np.cos, np.sin)]
        a = np.column_stack(cols)
        coef, *_ = np.linalg.lstsq(a, r, rcond=None)
        amp = np.hypot(coef[1::2], coef[2::2])
        ax.bar(ks + (j - len(records) / 2) * width, amp, width, label=rec.name)
        level = 3 * floor * np.sqrt(2.0 / len(r))
        ax.axhline(level, color="0.4", ls="--", lw=0.8)
    ax.set_xticks(ks, [f"{k}θ" for k in ks])
    ax.set_xlabel("harmonic of the moving table angle θ (cycles per revolution)")
    ax.set_ylabel("residual amplitude (deg/h)")
    ax.set_ylim(bottom=0)
    ax.set_title("harmonics of the residual in table angle (dashed: 3σ for white noise)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def error_falling_figure(steps, title="the error falls as the missing effects are added"):
    """Residual RMS of each model in the loop against the white-noise floor (the demo's headline figure).

    ``steps``: list of (label, residual_rms, noise_floor).
    """
    fig, ax = _figure(figsize=(7.2, 3.6))
    labels = [s[0] for s in steps]
    rms = np.array([s[1] for s in steps])
    floor = np.array([s[2] for s in steps])
    x = np.arange(len(steps))
    ax.plot(x, rms, "o-", color="C3", lw=2, label="residual RMS")
    ax.plot(x, floor, "s--", color="0.3", lw=1, label="white-noise floor")
    ax.fill_between(x, floor, floor * 1.1, color="C2", alpha=0.25, label="within 10 % of the floor")
    lo, hi = float(np.min(np.r_[rms, floor])), float(np.max(np.r_[rms, floor]))
    if lo > 0 and hi / lo >= 10:  # a log axis only when the range spans a decade; plain numbers on its ticks
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
    else:
        ax.set_ylim(0, 1.08 * hi)
    ax.set_xticks(x, labels, rotation=12, fontsize=8, ha="right")
    ax.set_xlabel("model (each step adds the effect the diagnosis asks for)")
    ax.set_ylabel("residual RMS (deg/h)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def candidates_figure(d, top: int = 10):
    """Evidence for each candidate: −log10 of the Holm-adjusted p-value, with the α line."""
    cands = [c for c in d.candidates if c.df > 0][:top]
    fig, ax = _figure(figsize=(6.4, 0.32 * len(cands) + 1.2))
    m = max(len([c for c in d.candidates if c.df > 0]), 1)
    vals = [float(np.clip(-(c.log10_p + np.log10(m)), 0, 300)) for c in cands]
    colors = ["C3" if v > -np.log10(d.alpha) else "0.6" for v in vals]
    ax.barh([c.name for c in cands][::-1], vals[::-1], color=colors[::-1])
    ax.axvline(-np.log10(d.alpha), color="k", ls="--", lw=0.8, label=f"α = {d.alpha}")
    ax.set_xscale("symlog", linthresh=10)
    ax.set_xlim(0, max(max(vals, default=1.0), -np.log10(d.alpha)) * 1.5)  # evidence ≥ 0: no empty negative side
    ax.set_xlabel("evidence: −log10 p (Holm-adjusted)")
    ax.set_ylabel("candidate effect")
    ax.set_title(f"candidates for the missing effect (model: {', '.join(d.fit.model.terms)})", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def save(fig, path) -> None:
    """Save a figure to PNG atomically (110 dpi); works headless, never touches pyplot."""
    import io

    from gyrojax.protocol import atomic_write_bytes

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    atomic_write_bytes(path, buf.getvalue())


# ---- figures of the noise, design and Monte Carlo studies ---------------------------------------------------------


READOFF_SLOPES = {"arw": -0.5, "bias_instability": 0.0, "rrw": 0.5, "quantization": -1.0, "rate_ramp": 1.0}
"""Slope of σ(τ) of each IEEE 952 read-off line (:mod:`gyrojax.noise.headline`)."""

READOFF_SYMBOLS = {"arw": "N", "bias_instability": "B", "rrw": "K", "quantization": "Q", "rate_ramp": "R"}


def _adev_key(out: dict) -> tuple[str, str]:
    """The ADEV arrays' key prefix and unit of a noise report: ``adev_deg_per_h`` (a gyro, deg/h) or ``adev_mps2``
    (an accelerometer, m/s², :mod:`gyrojax.noise.sensor_units`)."""
    return ("mps2", "m/s²") if "adev_mps2" in out else ("deg_per_h", "deg/h")


def noise_panel(ax, out: dict, title: str = "") -> None:
    """One channel's noise on ``ax``: the empirical ADEV (the report's unit, deg/h or m/s², against τ in s) with its
    95 % band, the model ADEV, its processes drawn separately, the τ where the model leaves the band and the IEEE 952
    read-offs of the curve (:mod:`gyrojax.noise.headline`) as lines of their slope through the point where each was
    read, labelled with value ± std in the report's units; ``out`` one report of ``gyrojax noise --json``."""
    from gyrojax.noise.spec import NoiseSpec

    key, unit = _adev_key(out)
    taus = np.asarray(out["taus_s"])
    adev = np.asarray(out[f"adev_{key}"])
    model = np.asarray(out[f"adev_model_{key}"])
    adq = out["adequacy"]
    ax.fill_between(taus, adq["low"], adq["high"], color="0.8", label=f"empirical {100 * adq['ci']:.0f} % band")
    ax.plot(taus, adev, "o", ms=3, color="k", label="overlapping ADEV")
    ax.plot(taus, model, "-", color="C3", lw=1.6, label=f"model ({out['method']})")
    tt = np.geomspace(taus.min(), taus.max(), 200)
    if "model" in out:  # the model's fields are in the series' unit, so its processes' ADEV is in the panel's
        for name, curve in NoiseSpec.from_json(out["model"]).term_adev(tt).items():
            ax.plot(tt, curve, "--", lw=0.9, label=name)
    bad = ~np.asarray(adq["inside"])
    if bad.any():
        ax.plot(taus[bad], model[bad], "x", color="C3", label="model outside band")
    for k, (name, h) in enumerate(out["headline"].items()):
        c = h["curve"]
        if c.get("value") is None or c.get("tau_s") is None or name not in READOFF_SLOPES:
            continue
        i = int(np.argmin(np.abs(taus - c["tau_s"])))
        bound = c.get("kind") == "upper bound"
        # a bound is drawn where it lies on the curve: σ̂ times the bound's ratio (older files: the ±1σ high end)
        level = float(adev[i]) * float(c.get("bound_ratio", out["adev_high"][i] / adev[i])) if bound else float(adev[i])
        line = level * (tt / taus[i]) ** READOFF_SLOPES[name]
        figure = f"≤ {c['value']:.3g}" if bound else f"= {c['value']:.3g} ± {c['std']:.2g}"
        label = f"{READOFF_SYMBOLS[name]} {figure} {c['unit']} (τ = {c['tau_s']:.3g} s)"
        ax.plot(tt, line, ":", lw=1.0, color=f"C{4 + k}", label=label)
        ax.plot([taus[i]], [level], "v" if bound else "s", ms=5, color=f"C{4 + k}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(0.5 * min(np.min(adq["low"]), np.min(model)), 2.0 * max(np.max(adq["high"]), np.max(model)))
    ax.set_xlabel("τ (s)")
    ax.set_ylabel(f"Allan deviation ({unit})")
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6)


def noise_model_figure(out: dict, title: str = "Allan deviation"):
    """``gyrojax noise --plot``: the empirical ADEV (deg/h against τ in s) with its 95 % band, the model ADEV, its
    processes drawn separately, the τ where the model leaves the band and the IEEE 952 read-offs (:func:`noise_panel`);
    ``out`` the dict of :func:`gyrojax.noise.readoff.noise_report`. Returns the figure."""
    fig, ax = _figure(figsize=(7, 5))
    noise_panel(ax, out, title)
    ax.title.set_fontsize(12)
    return fig


def noise_channels_figure(reports: dict, title: str = "Allan deviation"):
    """``gyrojax noise --plot`` of one sensor of an imu-triad record: one :func:`noise_panel` per channel
    (``reports``: channel name → its report, gyro channels in deg/h, accelerometer channels in m/s²; each
    analysed from its own rests, never pooled), side by side. Returns the figure."""
    n = len(reports)
    fig, axes = _figure(1, n, figsize=(5.2 * n, 4.6), squeeze=False)
    for ax, (name, out) in zip(axes[0], reports.items()):
        noise_panel(ax, out, name)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def allan_figure(res, fit, title: str = "Allan deviation"):
    """Log-log Allan deviation (deg/h against τ in s) with its ±1σ interval, the fitted total and each fitted
    term drawn separately (IEEE 952 annex C); ``res`` an :class:`gyrojax.noise.allan.AllanResult`, ``fit`` its
    :class:`gyrojax.noise.spec.NoiseSpec`. Returns the figure."""
    fig, ax = _figure(figsize=(7, 5))
    yerr = np.stack([res.adev - res.low, res.high - res.adev])
    ax.errorbar(res.taus_s, res.adev, yerr=yerr, fmt="o", ms=3, color="k", label="overlapping ADEV (±1σ)")
    tt = np.geomspace(res.taus_s.min(), res.taus_s.max(), 200)
    for name, curve in fit.term_adev(tt).items():
        ax.loglog(tt, curve, "--", label=name)
    ax.loglog(tt, fit.adev(tt), "-", color="C3", lw=1.5, label="fitted total")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("averaging time τ (s)")
    ax.set_ylabel("Allan deviation (deg/h)")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def design_figure(rows: list[dict]):
    """Bar chart of the Cramér–Rao standard deviations (report units, log scale) of each coefficient per plan;
    ``rows`` as from :func:`gyrojax.planning.baselines.compare`. Returns the figure."""
    names = list(rows[0]["std"])
    fig, ax = _figure(figsize=(10, 4))
    w = 0.8 / len(rows)
    for i, r in enumerate(rows):
        v = np.array([r["std"][c] for c in names])
        v = np.where(np.isfinite(v), v, np.nan)
        ax.bar(np.arange(len(names)) + i * w, v, w, label=r["plan"])
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(names)) + 0.4, names)
    ax.set_ylabel("Cramér–Rao std (report units)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def montecarlo_figure(res, summary):
    """Histogram of the normalised errors (θ̂−θ)/σ̂ (dimensionless) against N(0,1), and ±1σ/±2σ coverage per
    coefficient; ``res`` a :class:`gyrojax.montecarlo.results.StudyResult`, ``summary`` its summary table. Returns
    the figure."""
    z = (res.estimate - res.truth_of_fit()) / res.std
    s = summary
    fig, (a1, a2) = _figure(1, 2, figsize=(11, 4))
    grid = np.linspace(-4, 4, 200)
    a1.hist(np.clip(z.ravel(), -4.5, 4.5), bins=60, range=(-4.5, 4.5), density=True, alpha=0.6, label="all coeffs")
    a1.plot(grid, np.exp(-0.5 * grid**2) / np.sqrt(2 * np.pi), "k-", label="N(0,1)")
    a1.set_xlabel("(estimate − truth) / std")
    a1.legend()
    x = np.arange(len(s))
    a2.bar(x - 0.2, s["cover_1sigma"], 0.4, label="±1σ")
    a2.bar(x + 0.2, s["cover_2sigma"], 0.4, label="±2σ")
    a2.axhline(0.6827, color="C0", ls="--", lw=0.8)
    a2.axhline(0.9545, color="C1", ls="--", lw=0.8)
    a2.set_xticks(x, s["coefficient"], rotation=60)
    a2.set_ylim(0, 1.05)
    a2.set_ylabel("coverage")
    a2.legend(loc="lower right")
    fig.suptitle(f"{res.study.plan}: {len(res.draw)} draws")
    fig.tight_layout()
    return fig


def campaign_figure(result, title: str | None = None):
    """Two panels against cumulative table hours (h): left, the fitted σ of every coefficient of the final model
    (report units, log scale) after each test of the loop (solid, markers) and of the classical sequence (dashed), the
    target σ as a dotted line; right, the residual the noise does not explain, √(RMS² − floor²) (output units; the
    floor from successive differences, so it does not depend on the sample interval), of the loop's model after each
    test (the effects it added marked) and of the final model fitted to the classical sequence."""
    from gyrojax.physics.triad import effect_of

    fig, (ax, ar) = _figure(1, 2, figsize=(11.0, 4.0))
    names = list(result.last.terms)
    hours = [s.cumulative_hours for s in result.steps]
    what = "session" if result.lab.to_json().get("kind") == "hand" else "table"
    colours = {}
    for eff in names:
        fit = result.last.fit
        coeffs = [c for c in fit.coefficient_names if effect_of(c) == eff] if fit else [eff]
        for c in coeffs:
            ys = [_state_sigma(s.state, c) for s in result.steps]
            line = ax.plot(hours, ys, "o-", lw=1.4, ms=4, label=c)[0]
            colours[c] = line.get_color()
    cl = result.classical
    if cl is not None and cl.path:
        ch = [0.0] + [p["hours"] for p in cl.path]
        for c, col in colours.items():
            ys = [math.nan] + [_finite(p["sigma"].get(c)) for p in cl.path]
            ax.plot(ch, ys, "--", color=col, lw=1.0, alpha=0.8)
        ax.plot([], [], "k--", lw=1.0, label=f"classical ({cl.hours:.3g} h)")
    for c in colours:
        t = result.goal.target(c)
        if t is not None:
            ax.axhline(t, color="0.4", ls=":", lw=1.0)
            break
    for x in hours:
        ax.axvline(x, color="0.85", lw=0.6, zorder=0)
    ax.set_yscale("log")
    ax.set_xlabel(f"{what} hours (h)")
    ax.set_ylabel("fitted σ (report units: deg/h, deg/h/g, deg/h/g²)")
    ax.set_title(
        f"σ against {what} hours: loop {result.table_hours:.3g} h"
        + (f", classical {cl.hours:.3g} h" if cl and cl.hours else ""),
        fontsize=9,
    )
    ax.legend(fontsize=7, ncol=2)
    excess = [_excess(s.state.get("residual_rms"), s.state.get("noise_floor")) for s in result.steps]
    ar.plot(hours, excess, "o-", color="C3", label="loop")
    for x, y, s in zip(hours, excess, result.steps):
        added = s.state.get("added") or []
        if added:
            ar.annotate("+" + ",".join(added), (x, y), fontsize=7, xytext=(4, 4), textcoords="offset points")
    if cl is not None and cl.path:
        ys = [_excess(p["residual_rms"], p.get("noise_floor")) for p in cl.path]
        ar.plot([p["hours"] for p in cl.path], ys, "^--", color="C0", label="classical")
    ar.set_xlabel(f"{what} hours (h)")
    ar.set_ylabel("residual beyond the noise (deg/h)")
    verdict = result.last.diagnosis.verdict if result.last.diagnosis else "—"
    ar.set_title(title or f"√(RMS² − floor²) of the model after each test; final verdict: {verdict}", fontsize=9)
    ar.legend(fontsize=7)
    fig.tight_layout()
    return fig


def _state_sigma(state: dict, coefficient: str) -> float:
    """σ of ``coefficient`` in a campaign step's state (report unit), NaN when that step's model lacks it."""
    c = (state.get("coefficients") or {}).get(coefficient)
    return _finite(c["std"]) if c else math.nan


def _excess(rms, floor) -> float:
    """√(rms² − floor²), 0 when the residual is at the floor, NaN when either is unknown."""
    r, f = _finite(rms), _finite(floor)
    return math.sqrt(max(r * r - f * f, 0.0)) if math.isfinite(r) and math.isfinite(f) else math.nan


def _finite(x) -> float:
    """``x`` as a float, NaN when it is None, not a number or not finite (a gap in a plotted line)."""
    try:
        x = float(x)
    except (TypeError, ValueError):
        return math.nan
    return x if np.isfinite(x) else math.nan
