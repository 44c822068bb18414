"""The one entry of test design (the flat API's ``gj.design``): the instrument's plug-in gives the Fisher information
of a plan's parameters, a criterion of :mod:`gyrojax.planning.criteria` is its loss, and the one search of
:mod:`gyrojax.planning.search` minimises it.

* ``instrument="turntable"`` (default): static positions and dwells on a table
  (:func:`gyrojax.planning.optimal.design`);
* ``instrument="imu-triad"``: a hand calibration protocol of rests, moves and known-angle turns for a MEMS gyro triad
  (:func:`gyrojax.planning.triad_protocol.design_protocol`).
"""

from __future__ import annotations

from gyrojax.errors import ModelError
from gyrojax.noise.spec import NoiseSpec

INSTRUMENTS = ("turntable", "imu-triad")


def design(
    terms,
    n_positions: int = 24,
    hours: float = 4.0,
    criterion="D",
    *,
    instrument: str = "turntable",
    minutes: float | None = None,
    noise=None,
    starts: int = 8,
    seed: int = 0,
    adam_steps: int | None = None,
    lbfgs_steps: int | None = None,
    learning_rate: float = 0.05,
    **turntable,
):
    """Design a test of ``instrument`` minimising ``criterion`` (``D``, ``A``, ``E``, ``c:COEF=w,...`` and, on a
    turntable, ``detect:NAME``) from ``starts`` random starts by ``adam_steps`` Adam and ``lbfgs_steps`` L-BFGS
    iterations.

    Turntable: ``n_positions`` static positions sharing ``hours`` h of dwell; ``noise`` a
    :class:`~gyrojax.noise.spec.NoiseSpec`; the other keywords (``table``, ``dt_s``, ``min_fraction``,
    ``free_dwell``, ``prior_thetas``, ``kind``) as :func:`gyrojax.planning.optimal.design`, which returns the
    :class:`~gyrojax.planning.optimal.DesignResult`.

    IMU triad: ``n_positions`` rests in ``minutes`` min (default ``hours`` × 60) of rests and turns; ``noise`` a
    :class:`~gyrojax.planning.triad_fisher.TriadNoise`, or a gyro :class:`~gyrojax.noise.spec.NoiseSpec` (white,
    Gauss–Markov as its long-run white equivalent) for a session at an unknown site; returns the
    :class:`~gyrojax.planning.triad_protocol.TriadProtocol`."""
    search = {"starts": starts, "seed": seed, "learning_rate": learning_rate}
    if instrument == "turntable":
        search["lbfgs_steps"] = 40 if lbfgs_steps is None else lbfgs_steps
        from gyrojax.planning.optimal import design as design_plan

        return design_plan(
            terms,
            n_positions,
            hours,
            criterion,
            noise=noise,
            adam_steps=600 if adam_steps is None else adam_steps,
            **search,
            **turntable,
        )
    if instrument != "imu-triad":
        raise ModelError(f"unknown instrument {instrument!r}; valid: {', '.join(INSTRUMENTS)}")
    if turntable:
        raise ModelError(f"design: {next(iter(turntable))!r} is not a keyword of an imu-triad protocol design")
    from gyrojax.planning.triad_fisher import TriadNoise
    from gyrojax.planning.triad_protocol import design_protocol

    if isinstance(noise, NoiseSpec):
        noise = TriadNoise.from_spec(noise, "design: noise")
    minutes = hours * 60.0 if minutes is None else minutes
    if adam_steps is not None:
        search["steps"] = adam_steps
    if lbfgs_steps is not None:
        search["lbfgs_steps"] = lbfgs_steps
    return design_protocol(terms, n_positions, minutes, criterion, noise, **search)
