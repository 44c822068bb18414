"""``gyrojax noise``: the Allan deviation, noise model, headline IEEE 952 figures and glitches of static records —
SDF records pooled, imu-triad records per channel — and Kalibr's imu.yaml (``--kalibr``)."""

from __future__ import annotations

import json
from pathlib import Path

from gyrojax.cli.args import UsageError

MAX_TAU_WORK = 4e9
"""Largest (number of τ) × (samples) evaluated for ``noise --taus all`` (each τ costs one pass over the data)."""


def parse_taus(spec: str | None, n: int, tau0: float):
    """Averaging factors m for ``--taus``: ``octave`` (m = 2^k), ``decade`` (1, 2, 4 × 10^k), ``all`` (every m),
    or a comma-separated list of τ in s (each a multiple of τ0 within 1 % of τ0, and 2m ≤ n − 1); None: default.
    Returns an integer array, or None."""
    if spec is None:
        return None
    import math

    import numpy as np

    m_max = (n - 1) // 2
    if m_max < 1:
        raise UsageError(f"--taus: {n} samples leave no averaging time")
    key = spec.strip().lower()
    if key == "octave":
        return 2 ** np.arange(int(math.floor(math.log2(m_max))) + 1)
    if key == "decade":
        out = [d * 10**k for k in range(int(math.log10(m_max)) + 1) for d in (1, 2, 4)]
        return np.array([m for m in out if m <= m_max])
    if key == "all":
        if m_max * n > MAX_TAU_WORK:
            raise UsageError(
                f"--taus all: {m_max} taus over {n} samples is too much work; use octave, decade or a list"
            )
        return np.arange(1, m_max + 1)
    try:
        taus = [float(x) for x in spec.split(",") if x.strip()]
    except ValueError:
        msg = f"--taus {spec!r}: expected octave, decade, all or a comma-separated list of seconds"
        raise UsageError(msg) from None
    if not taus:
        raise UsageError("--taus: empty list")
    ms = []
    for t in taus:
        if not (math.isfinite(t) and t > 0):
            raise UsageError(f"--taus: {t!r} is not a positive time in s")
        m = round(t / tau0)
        if m < 1 or abs(m * tau0 - t) > 0.01 * tau0:
            raise UsageError(f"--taus: {t:g} s is not a multiple of the sample interval {tau0:.9g} s")
        if m > m_max:
            raise UsageError(f"--taus: {t:g} s is longer than half the longest segment ({m_max * tau0:g} s)")
        ms.append(m)
    if len(set(ms)) != len(ms):
        raise UsageError("--taus: two of the taus fall on the same multiple of the sample interval")
    return np.array(sorted(ms))


def cmd_noise(args) -> int:
    """``gyrojax noise``: Allan deviation (deg/h against τ in s), noise model and adequacy of static records."""
    from gyrojax.data.records import load_records
    from gyrojax.data.static import static_rate_segments
    from gyrojax.data.stream import long_records
    from gyrojax.noise.readoff import noise_report

    long = long_records(args.records)
    if long is not None:  # hours at a high rate: never held, analysed in chunks
        return _noise_streamed(args, long)
    recs = load_records(args.records)
    triad = any(r.meta["instrument"]["kind"] == "imu-triad" for r in recs)
    _check_options(args, triad, _has_accelerometer(recs))
    if triad:
        return _noise_triad(args, recs)
    notes: list[str] = []
    segs, tau0 = static_rate_segments(recs, notes=notes)
    accel = _kalibr_accel(args, has_accelerometer=False)
    m_list = parse_taus(args.taus, max(len(s) for s in segs), tau0)
    out, res, ieee, nm = noise_report(
        segs,
        tau0,
        m_list,
        method=args.method,
        model=args.model,
        notes=notes,
        gauss_markov=args.gauss_markov,
        robust=args.robust,
    )
    return _sdf_output(args, out, res, ieee, nm, tau0, accel, ", ".join(r.name for r in recs), notes)


def _check_options(args, triad: bool, accelerometer: bool) -> None:
    """The option checks of ``gyrojax noise`` made before any work: ``--kalibr-accel`` only with ``--kalibr``, no
    empty file names, no output over an existing file without ``--force``, ``--robust`` not with ieee952."""
    if getattr(args, "kalibr_accel", None) and not args.kalibr:
        raise UsageError("--kalibr-accel: only with --kalibr (it gives the Kalibr file's accelerometer pair)")
    for name, option in (("--plot", args.plot), ("--kalibr", args.kalibr)):
        if option is not None and not option.strip():
            raise UsageError(f"{name}: empty file name")
    plots = triad_plot_paths(args.plot, accelerometer) if triad and args.plot else [args.plot]
    for option in (*plots, args.kalibr):
        if option and Path(option).exists() and not args.force:
            raise UsageError(f"{option}: exists; pass --force to overwrite")
    if args.robust and args.method == "ieee952":
        raise UsageError("noise --robust: the robust estimate is a GMWM or AVLR fit; not with --method ieee952")


def _sdf_output(args, out: dict, res, ieee, nm, tau0: float, accel, source: str, notes: list) -> int:
    """Write the Kalibr file and plot of an SDF noise report and print it (JSON, or ``notes`` and the table); exit
    code."""
    from gyrojax.noise.spec import UNITS

    out["warnings"] = arw_warnings({"gyro": out}, mems=False)
    kalibr_file = _kalibr_file(args, {"gyro": out}, accel, tau0, source) if args.kalibr else None
    if args.plot:  # matplotlib is imported only when a plot is asked for
        from gyrojax.report.figures import noise_model_figure, save

        save(noise_model_figure(out, title=source), args.plot)
    if kalibr_file:
        out["kalibr"] = _write(args.kalibr, *kalibr_file)
    _say(out["warnings"])
    if args.json:
        print(json.dumps(out))
        return 0
    for note in notes:
        print(f"note: {note}")
    print(f"{'tau_s':>12s} {'adev_deg_per_h':>15s} {'low':>11s} {'high':>11s} {'model':>11s}  in 95% band")
    for i, t in enumerate(res.taus_s):
        print(
            f"{t:12.4g} {res.adev[i]:15.6g} {res.low[i]:11.5g} {res.high[i]:11.5g} "
            f"{out['adev_model_deg_per_h'][i]:11.5g}  {'yes' if out['adequacy']['inside'][i] else 'NO'}"
        )
    if nm is not None:
        p_value = float("nan") if nm.info["p_value"] is None else nm.info["p_value"]
        print(f"model {nm.info['model']} ({nm.method}), J-test p = {p_value:.3g}")
        for k, v in nm.parameters().items():
            std = "pinned at a bound" if v["std"] is None else f"± {v['std']:.2g}"
            print(f"  {k}: {v['value']:.6g} {std} {v['unit']}")
        for k, v in out["derived"].items():
            if v["value"] is None:
                print(f"  {k}: not read ({v['reason']})")
            else:
                print(f"  {k}: {v['value']:.4g} ± {v['std']:.2g} {v['unit']} (read at tau = {v['tau_s']:.3g} s)")
    else:
        for k in ieee.names:
            if k == "gm1_sigma":
                sigma, tau = ieee.gauss_markov[0]
                print(f"gauss_markov: sigma {sigma:.6g} deg/h, tau {tau:.6g} s")
            elif not k.startswith("gm"):
                print(f"{k}: {ieee.value(k):.6g} {UNITS[k]}")
    _print_headline(out["headline"])
    print(out["adequacy"]["verdict"])
    return 0


def triad_plot_paths(plot: str, accelerometer: bool) -> list[str]:
    """The files ``--plot PNG`` writes for imu-triad records: one figure per sensor, ``STEM_gyro.SUFFIX`` and (with
    accelerometer channels) ``STEM_accel.SUFFIX`` beside ``PNG``."""
    p = Path(plot)
    if not p.name or p.is_dir():
        raise UsageError(f"--plot {plot!r}: needs a file name (imu-triad figures go to STEM_gyro.png, STEM_accel.png)")
    suffix = p.suffix or ".png"
    names = ["gyro"] + (["accel"] if accelerometer else [])
    return [str(p.with_name(f"{p.stem}_{n}{suffix}")) for n in names]


def _has_accelerometer(recs) -> bool:
    """Whether the imu-triad records carry accelerometer channels (the three columns of conventions §9.3 in any of
    them: the channels are then analysed from the rests of those that have them)."""
    from gyrojax.data.triad import CHANNELS

    return any(all(f"acc_{c}_g" in r.columns for c in CHANNELS) for r in recs)


def _kalibr_accel(args, has_accelerometer: bool):
    """The accelerometer figures of ``--kalibr`` for records without accelerometer channels: the pair the user
    gives (``--kalibr-accel``), or a refusal, before any work: Kalibr's reader (kalibr_common/ConfigReader.py,
    ImuParameters, read for every IMU by IccImu) fails on a file without ``accelerometer_*`` and no figure is
    invented. None when not needed."""
    from gyrojax.noise import kalibr

    given = getattr(args, "kalibr_accel", None)
    if not args.kalibr:
        return None
    if has_accelerometer:
        if given:
            raise UsageError("--kalibr-accel: the records have accelerometer channels; their figures are written")
        return None
    if not given:
        raise UsageError(
            "--kalibr: the records have no accelerometer channels and Kalibr's reader needs "
            "accelerometer_noise_density and accelerometer_random_walk; give them with --kalibr-accel ND,RW "
            "(m/s^2/sqrt(Hz), m/s^3/sqrt(Hz))"
        )
    return kalibr.given_accelerometer(given)


def _kalibr_file(args, gyro: dict, accel, tau0: float, source: str) -> tuple[dict, str]:
    """Kalibr's figures and imu.yaml text from per-channel noise reports (gyro deg/h, accelerometer m/s² units)
    and, for a gyro-only record, the user's accelerometer pair (``accel`` from :func:`_kalibr_accel`); made before
    anything is written, so that a figure Kalibr cannot take stops the command with no file half done."""
    from gyrojax.noise import kalibr

    g = {k: kalibr.densities(v) for k, v in gyro.items()}
    a = accel if isinstance(accel.get("from"), str) else {k: kalibr.densities(v) for k, v in accel.items()}
    fig = kalibr.kalibr_figures(g, a, 1.0 / tau0, args.rostopic)
    return fig, kalibr.imu_yaml(fig, source)


def _write(path: str, fig: dict, text: str) -> dict:
    """Write the Kalibr file atomically; its figures for the JSON."""
    from gyrojax.protocol import atomic_write_text

    atomic_write_text(path, text)
    return fig


def _noise_triad(args, recs) -> int:
    """``gyrojax noise`` on imu-triad records: every gyro and accelerometer channel analysed on its own (never
    pooled), from the records' static poses (each pose a segment); per channel the report of an SDF record."""
    import numpy as np

    from gyrojax.data.timebase import uniform_interval
    from gyrojax.data.triad import CHANNELS, acc_g, gyro_dph
    from gyrojax.noise.readoff import noise_report
    from gyrojax.noise.sensor_units import accelerometer_report
    from gyrojax.units import G0

    if not all(r.meta["instrument"]["kind"] == "imu-triad" for r in recs):
        raise UsageError("noise: imu-triad records and SDF records cannot be analysed together")
    _kalibr_accel(args, has_accelerometer=_has_accelerometer(recs))  # a refusal before any work
    series: dict = {}
    tau0 = None
    for r in recs:
        seg = np.asarray(r.columns["segment"]).astype(int)
        gyro, acc = gyro_dph(r), acc_g(r)
        for spec in r.meta["segments"]:
            sel = np.flatnonzero(seg == spec["label"])
            if spec["type"] != "static" or len(sel) < 16:
                continue
            d, _ = uniform_interval(np.asarray(r.time_s, float)[sel])
            if tau0 is None:
                tau0 = d
            elif abs(d - tau0) > 1e-3 * tau0:
                raise UsageError(f"{r.name}: sample interval {d:g} s differs from {tau0:g} s of the other rests")
            for i, c in enumerate(CHANNELS):
                series.setdefault(f"gyro_{c}", []).append(gyro[sel, i])
                if acc is not None:
                    series.setdefault(f"acc_{c}", []).append(acc[sel, i] * G0)
    if tau0 is None:
        raise UsageError("noise: the imu-triad records hold no static pose of 16 samples or more")
    reports = {}
    for name, segs in series.items():
        m_list = parse_taus(args.taus, max(len(s) for s in segs), tau0)
        out, *_ = noise_report(
            segs, tau0, m_list, method=args.method, model=args.model, gauss_markov=args.gauss_markov, robust=args.robust
        )
        reports[name] = accelerometer_report(out) if name.startswith("acc_") else out
    return _triad_output(args, reports, tau0, ", ".join(r.name for r in recs))


def _triad_output(args, reports: dict, tau0: float, source: str) -> int:
    """Write the Kalibr file and plots of imu-triad noise reports (per channel) and print them; exit code."""
    accel_given = _kalibr_accel(args, has_accelerometer=any(k.startswith("acc_") for k in reports))
    result = {"instrument": "imu-triad", "tau0_s": tau0, "channels": reports}
    result["warnings"] = arw_warnings({k: v for k, v in reports.items() if k.startswith("gyro_")}, mems=True)
    _say(result["warnings"])
    gyro = {k: v for k, v in reports.items() if k.startswith("gyro_")}
    accel = {k: v for k, v in reports.items() if k.startswith("acc_")}
    kalibr_file = _kalibr_file(args, gyro, accel_given or accel, tau0, source) if args.kalibr else None
    if args.plot:  # one figure per sensor, a panel per channel; matplotlib only when a plot is asked for
        from gyrojax.report.figures import noise_channels_figure, save

        paths = triad_plot_paths(args.plot, bool(accel))
        for path, (sensor, chans) in zip(paths, (("gyroscope", gyro), ("accelerometer", accel))):
            save(noise_channels_figure(chans, title=f"{sensor} of {source}: Allan deviation per channel"), path)
        result["plots"] = paths
    if kalibr_file:
        result["kalibr"] = _write(args.kalibr, *kalibr_file)
    if args.json:
        print(json.dumps(result))
        return 0
    for name, out in reports.items():
        print(f"{name}: model {out['model']['info']['model'] if 'model' in out else args.method}")
        for note in out["notes"]:
            print(f"  note: {note}")
        _print_headline(out["headline"])
        print(f"  {out['adequacy']['verdict']}")
    for path in result.get("plots", []):
        print(f"plot -> {path}")
    if args.kalibr:
        print(f"Kalibr imu.yaml -> {args.kalibr}")
    return 0


def arw_warnings(reports: dict, mems: bool) -> list[str]:
    """The ARW of each gyro report (the model's read-off, else the curve's) checked by
    :func:`gyrojax.noise.plausible.arw_warning`; the sentences of those that fail."""
    from gyrojax.noise.plausible import arw_warning

    out = []
    for name, rep in reports.items():
        arw = rep.get("headline", {}).get("arw", {})
        value = (arw.get("model") or {}).get("value") or (arw.get("curve") or {}).get("value")
        said = arw_warning(name, value, mems=mems)
        if said:
            out.append(said)
    return out


def _say(warnings: list[str]) -> None:
    """Each warning as one line on stderr (also in the JSON's ``warnings``), whatever the output format."""
    import sys

    for w in warnings:
        print(f"gyrojax: warning: {w}", file=sys.stderr)


def _print_headline(head: dict) -> None:
    """The headline IEEE 952 read-offs of ``gyrojax noise``: the curve's and the model's, side by side."""

    def one(v):
        if v["value"] is None:
            return "not read"
        where = f" at tau = {v['tau_s']:.3g} s" if v.get("tau_s") else ""
        if v.get("kind") == "upper bound":  # one-sided: a ± beside it would read as an estimate
            return f"<= {v['value']:.4g} (one-sided {100 * v.get('bound_level', 0.97725):.4g} %){where}"
        return f"{v['value']:.4g} ± {v['std']:.2g}{where}"

    print("headline (IEEE 952 read-offs): curve | model")
    for k, v in head.items():
        if v["curve"]["value"] is None and v["model"]["value"] is None:
            continue
        unit = v["curve"].get("unit") or v["model"].get("unit", "")
        flag = "" if v["agree"] in (None, True) else "  DISAGREE"
        print(f"  {k}: {one(v['curve'])} | {one(v['model'])} {unit}{flag}")


def _noise_streamed(args, long: list) -> int:
    """``gyrojax noise`` on records too long to hold (:data:`gyrojax.data.stream.STREAM_SAMPLES`): each read in
    chunks (:func:`gyrojax.data.stream.static_pieces`, a progress bar on a terminal), the Allan variance at the
    octave τ accumulated over them (:mod:`gyrojax.noise.chunked`), the noise model fitted on the variances; the same
    report as a record held whole, less the glitch and spectral-line searches (which need the samples)."""
    from gyrojax.data.stream import STREAM_SAMPLES, Progress, static_pieces
    from gyrojax.data.triad import is_triad
    from gyrojax.noise import allan as allan_mod
    from gyrojax.noise.chunked import pooled
    from gyrojax.noise.gmwm import fit_wv
    from gyrojax.noise.readoff import variance_report
    from gyrojax.noise.sensor_units import accelerometer_report

    kinds = {is_triad(meta) for _, meta, _ in long}
    if len(kinds) > 1:
        raise UsageError("noise: imu-triad records and SDF records cannot be analysed together")
    triad = kinds.pop()
    total = sum(n for *_, n in long)
    why = f"a record of more than {STREAM_SAMPLES} samples is analysed in chunks"
    if args.robust:
        raise UsageError(f"noise --robust: {why}, and the robust wavelet variance needs every sample at once")
    if args.taus is not None and args.taus.strip().lower() != "octave":
        raise UsageError(f"--taus {args.taus}: {why}, at the octave taus (--taus octave)")
    acc_cols = triad and any(all(f"acc_{c}_g" in h for c in "xyz") for h in (_header(p) for p, _, _ in long))
    _check_options(args, triad, acc_cols)
    accel = _kalibr_accel(args, has_accelerometer=acc_cols)
    progress = Progress("noise", total)
    pieces = {}
    for path, meta, _ in long:
        pieces.update(static_pieces(path, meta, progress))
    progress.close()
    pieces = {k: p for k, p in pieces.items() if p.n >= 16}
    if not pieces:
        raise UsageError("noise: the records hold no static piece of 16 samples or more")
    tau0 = None
    for p in pieces.values():
        d = p.interval()
        if tau0 is None:
            tau0 = d
        elif abs(d - tau0) > 1e-3 * tau0:
            raise UsageError(f"{p.name}: sample interval {d:g} s differs from {tau0:g} s of the other pieces")
    channels = next(iter(pieces.values())).channels
    notes = [
        f"{total} samples: {why} (the Allan variance at the octave taus from running sums, summed at every offset "
        "up to m = 16384 and at a step of m/16384 beyond; the noise model fitted on the variances); glitches and "
        "spectral lines are not searched"
    ]
    extra = {
        "glitches": {"searched": False, "masked": False},
        "spectral_lines": [],
        "spectral_line_search": {"searched": False},
    }
    reports = {}
    for j, ch in enumerate(channels):
        results = []
        for p in pieces.values():
            m, avar, counts, n = p.allan.result()
            results.append((m, avar[:, j], counts, n))
        res, est = pooled(results, tau0)
        res, ieee = allan_mod.refine(res, gauss_markov=args.gauss_markov)
        nm = fit_wv(est, args.model, args.method) if args.method in ("gmwm", "avlr") else None
        out = variance_report(res, ieee, nm, est, notes, method=args.method, extra=extra)
        reports[ch] = accelerometer_report(out) if ch.startswith("acc_") else out
    source = ", ".join(meta["name"] for _, meta, _ in long)
    if triad:
        return _triad_output(args, reports, tau0, source)
    return _sdf_output(args, reports["gyro"], res, ieee, nm, tau0, accel, source, notes)


def _header(path) -> list[str]:
    with open(path, encoding="utf-8", errors="replace") as fh:
        return [h.strip() for h in fh.readline().split(",")]
