"""``gyrojax design --instrument imu-triad``: a hand calibration protocol for a MEMS IMU
(:mod:`gyrojax.planning.triad_protocol`), its table and figure, and its predicted σ beside Ferraris' and imu_tk's."""

from __future__ import annotations

import json
import math
from pathlib import Path

from gyrojax.cli.args import UsageError, parse_gm, parse_terms

TURNTABLE_DEFAULTS = {"positions": 24, "hours": 4.0, "dt": 1.0, "table": "two-axis"}
"""Options of the turntable design with their defaults: given otherwise with imu-triad, they are refused."""
DEFAULT_TERMS = ("D_F", "D_I", "D_O", "D_S", "sf_error", "ia_misalignment")


def triad_noise_from_args(args):
    """(TriadNoise, note) from ``--arw``/``--gm``/``--noise-model``/``--placement-deg``: a Gauss–Markov drift is
    taken as its long-run white equivalent (:meth:`~gyrojax.planning.triad_fisher.TriadNoise.from_spec`)."""
    from gyrojax.noise.spec import NoiseSpec
    from gyrojax.planning.triad_fisher import TriadNoise

    if args.noise_model:
        from gyrojax.noise.gmwm_model import load_noise_model

        if args.gm:
            raise UsageError("--noise-model and --gm both give the noise; pass one")
        spec, where = load_noise_model(args.noise_model), args.noise_model
    else:
        gm = parse_gm(args.gm) if args.gm else None
        spec, where = NoiseSpec(white=args.arw, gauss_markov=() if gm is None else (gm,)), "--arw/--gm"
    place = 0.0 if args.placement_deg is None else args.placement_deg
    if not 0 <= place < 90:
        raise UsageError(f"--placement-deg must be >= 0 (deg), got {place}")
    noise = TriadNoise.from_spec(spec, where, placement_deg=place)
    note = ""
    if spec.gauss_markov:
        note = (
            f"Gauss-Markov drift taken as its long-run white equivalent: ARW {spec.white:g} -> {noise.arw:.4g} "
            "deg/sqrt(h) (valid for tau much shorter than the rests)"
        )
    return noise, note


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
    if args.starts < 1 or (args.adam_steps is not None and args.adam_steps < 1) or (args.lbfgs_steps or 0) < 0:
        raise UsageError("--starts and --adam-steps must be >= 1, --lbfgs-steps >= 0")
    terms = parse_terms(args.terms) if args.terms else list(DEFAULT_TERMS)
    noise, note = triad_noise_from_args(args)
    from gyrojax.planning import triad_protocol as tpr
    from gyrojax.planning.design import design

    tpr.parse_criterion(args.criterion, tpr.triad_model(terms))  # refuse bad terms and criteria before any work
    proto = design(
        terms,
        poses,
        criterion=args.criterion,
        instrument="imu-triad",
        minutes=minutes,
        noise=noise,
        starts=args.starts,
        seed=args.seed,
        adam_steps=args.adam_steps,
        lbfgs_steps=args.lbfgs_steps,
    )
    rows = tpr.comparison(proto)
    payload = tpr.protocol_payload(proto, rows)
    figure = out.with_suffix(".png")
    from gyrojax.report.protocol_figure import protocol_figure
    from gyrojax.report.protocol_text import comparison_text, table_text

    protocol_figure(proto, figure)
    payload["figure"] = figure.name
    tpr.save_protocol(out, payload, force=True)
    if args.json:
        print(json.dumps({"protocol": str(out), "figure": str(figure), **payload}, indent=1, default=float))
        return 0
    print(
        f"designed {poses}-pose hand protocol, criterion {proto.criterion_name}, {minutes:g} min in all -> {out} "
        f"(figure {figure})"
    )
    print(
        f"noise: ARW {noise.arw:.4g} deg/sqrt(h), accelerometer {noise.acc_noise_g:g} g at {noise.rate_hz:g} Hz, "
        f"placement {noise.placement_deg:g} deg, latitude unknown, |g| {noise.g:.5g} g"
    )
    if note:
        print(f"note: {note}")
    print(table_text(payload["table"]))
    print()
    print(comparison_text(rows, proto.criterion, proto.criterion_name))
    return 0
