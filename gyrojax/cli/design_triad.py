"""``gyrojax design --instrument imu-triad``: a hand calibration protocol for a MEMS IMU
(:mod:`gyrojax.planning.triad_protocol`), its table and figure, and its predicted σ beside Ferraris' and imu_tk's."""

from __future__ import annotations

import json
import math
from pathlib import Path

from gyrojax.cli.args import UsageError, parse_gm, parse_terms

TURNTABLE_DEFAULTS = {"positions": 24, "hours": 4.0, "dt": 1.0, "lbfgs_steps": 40, "table": "two-axis"}
"""Options of the turntable design with their defaults: given otherwise with imu-triad, they are refused."""
DEFAULT_TERMS = ("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment")


def triad_noise_from_args(args):
    """(TriadNoise, note) from ``--arw``/``--gm``/``--noise-model``/``--placement-deg``: a Gauss–Markov drift is
    taken as its long-run white equivalent, N² + 2σ²τ (τ ≪ the rests: the fit's pose means see its integral);
    other slow terms are refused (a hand session's minutes cannot tell them from the bias)."""
    from gyrojax.planning.triad_fisher import TriadNoise

    arw, gms, note = args.arw, [], ""
    if args.noise_model:
        from gyrojax.noise.gmwm_model import load_noise_model

        if args.gm:
            raise UsageError("--noise-model and --gm both give the noise; pass one")
        nm = load_noise_model(args.noise_model)
        slow = [k for k in ("random_walk", "rate_ramp", "bias_instability") if getattr(nm, k)]
        if slow:
            raise UsageError(
                f"{args.noise_model}: the imu-triad design takes white noise and Gauss-Markov drift; {slow[0]} "
                "is not modelled by the triad fit"
            )
        arw, gms = nm.white, list(nm.gauss_markov)
    elif args.gm:
        gms = [parse_gm(args.gm)]
    if not 0 < arw < math.inf:
        raise UsageError(f"the imu-triad design needs a white noise (ARW) > 0 deg/sqrt(h); got {arw}")
    eff = arw**2 + sum(2.0 * s**2 * t / 3600.0 for s, t in gms)
    if gms:
        note = (
            f"Gauss-Markov drift taken as its long-run white equivalent: ARW {arw:g} -> {math.sqrt(eff):.4g} "
            "deg/sqrt(h) (valid for tau much shorter than the rests)"
        )
    place = 0.0 if args.placement_deg is None else args.placement_deg
    if not 0 <= place < 90:
        raise UsageError(f"--placement-deg must be >= 0 (deg), got {place}")
    return TriadNoise(arw=math.sqrt(eff), placement_deg=place), note


def design_triad(args) -> int:
    """The imu-triad branch of ``gyrojax design`` (module doc); exit code."""
    if args.instrument != "imu-triad":
        raise UsageError("--poses, --minutes and --placement-deg go with --instrument imu-triad")
    for k, v in TURNTABLE_DEFAULTS.items():
        if getattr(args, k) != v:
            raise UsageError(f"--{k.replace('_', '-')} is an option of the turntable design, not of imu-triad")
    if args.effect or args.effects_file:
        raise UsageError("--effect/--effects-file: the imu-triad design takes named linear effects only")
    out = Path(args.out)
    if out.exists() and not args.force:
        raise UsageError(f"{out}: exists; pass --force to overwrite")
    poses = 12 if args.poses is None else args.poses
    minutes = 10.0 if args.minutes is None else args.minutes
    if not 0 < minutes < math.inf:
        raise UsageError(f"--minutes must be finite and positive, got {minutes}")
    if args.starts < 1 or args.adam_steps < 1:
        raise UsageError("--starts and --adam-steps must be >= 1")
    terms = parse_terms(args.terms) if args.terms else list(DEFAULT_TERMS)
    noise, note = triad_noise_from_args(args)
    from gyrojax.planning import triad_protocol as tpr
    from gyrojax.planning.triad_protocol_text import comparison_text, table_text

    tpr.triad_model(terms)  # refuse bad terms before any work
    proto = tpr.design_protocol(
        terms, poses, minutes, args.criterion, noise, starts=args.starts, steps=args.adam_steps, seed=args.seed
    )
    rows = tpr.comparison(proto)
    payload = tpr.protocol_payload(proto, rows)
    figure = out.with_suffix(".png")
    from gyrojax.report.protocol_figure import protocol_figure

    protocol_figure(proto, figure)
    payload["figure"] = figure.name
    tpr.save_protocol(out, payload, force=True)
    if args.json:
        print(json.dumps({"protocol": str(out), "figure": str(figure), **payload}, indent=1, default=float))
        return 0
    print(
        f"designed {poses}-pose hand protocol, criterion {proto.criterion.text}, {minutes:g} min in all -> {out} "
        f"(figure {figure})"
    )
    print(
        f"noise: ARW {noise.arw:.4g} deg/sqrt(h), accelerometer {noise.acc_noise_g:g} g at {noise.rate_hz:g} Hz, "
        f"placement {noise.placement_deg:g} deg, latitude unknown"
    )
    if note:
        print(f"note: {note}")
    print(table_text(payload["table"]))
    print()
    print(comparison_text(rows, proto.criterion))
    return 0
