"""The next session of a hand-held IMU triad: the poses and turns that bring every goal σ of the triad's channel
coefficients to its target, in the fewest minutes, given what the sessions so far know.

**The lab** (:class:`HandLab`) is a person turning a box: the number of rests of a session, the longest session a
person runs (minutes), the hand's placement error, and the accelerometer noise (else read from the records' rests).

**What the records know.** The information of the sessions so far is the inverse of the current fit's covariance
(:func:`prior_information`), not the Fisher information of the protocols they followed: records imported from a
hand session carry segments, not the attitudes a protocol aimed at, and the fit's covariance is the one the joint
refit carries on (the model is linear in θ and the sessions' noises independent, so information adds), at the noise
the fit estimated from those very records (each channel's long-run variance, the REML components between segments)
rather than at a noise assumed before the data.

**The session's noise** (:func:`session_noise`) is the fit's: each channel's long-run variance q per sample
(deg/h)² at rate r is an ARW of √(q / (3600 r)) deg/√h (IEEE 952: a mean over T h has variance ARW²/T); the design
takes the largest channel's, so that its σ after are an upper bound for the quieter channels; and the variance
components the fit estimated between segments (a bias level of each pose, an angle error of each move) weigh the
new session's rests and moves as the joint refit will.

**The design** (:func:`design_session`): at a session length T,
:func:`gyrojax.planning.triad_protocol.design_protocol` minimises the criterion ``ratio`` (a smooth maximum of
σ_i² / (m S_i)² over the goal's coefficients, :mod:`gyrojax.planning.criteria`, m the goal's margin) of the prior
information plus the session's. The shortest T at which the designed session meets every target is found by
bisection (:func:`gyrojax.optimize.bisect`) between the shortest session the poses allow and the lab's longest, on
a grid of :data:`RESOLUTION_S`. When the longest does not meet it, the minutes that would are estimated per
coefficient from the two points known on its curve σ⁻² = f₀ + a T (the records' alone, and after the longest
session): T = ((m S)⁻² − f₀) / a, the largest over the coefficients.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from gyrojax.data.triad import acc_g
from gyrojax.errors import ConvergenceWarning, ModelError
from gyrojax.inference.triad import components_tau2
from gyrojax.noise.spec import SessionNoise
from gyrojax.optimize import bisect
from gyrojax.physics import triad as tp
from gyrojax.planning import triad_protocol as tpr
from gyrojax.planning.criteria import Criterion
from gyrojax.planning.triad_fisher import TriadNoise

POSES = 12
"""Rests of a designed session (as ``gyrojax design --instrument imu-triad``)."""
MAX_MINUTES = 30.0
"""The longest session a person runs, min (default)."""
RESOLUTION_S = 15.0
"""A designed session's length is a whole number of these from the shortest (s): a person's session is not timed
finer, and the bisection evaluates a design search at each length it tries."""
PLACEMENT_DEG = 1.0
"""σ of a person's placement about each body axis, deg (default)."""


@dataclass(frozen=True)
class HandLab:
    """A person turning a box (module doc): ``poses`` rests a session, at most ``max_minutes`` min a session, the
    hand's ``placement_deg`` (deg), the accelerometer's white noise ``acc_noise_g`` (g per sample; None: from the
    records' rests), the known-angle turn structures searched (``turn_pairs``), and the minutes the campaign's
    sessions may take in all (``budget_minutes``; None: one session, so that a goal beyond the longest session is
    refused with the minutes that would reach it)."""

    poses: int = POSES
    max_minutes: float = MAX_MINUTES
    placement_deg: float = PLACEMENT_DEG
    acc_noise_g: float | None = None
    turn_pairs: tuple = tpr.TURN_PAIRS
    budget_minutes: float | None = None

    def __post_init__(self):
        if not (isinstance(self.poses, int) and self.poses >= 2):
            raise ModelError(f"hand lab: 'poses' must be an integer >= 2, got {self.poses!r}")
        if not (math.isfinite(self.max_minutes) and self.max_minutes > 0):
            raise ModelError(f"hand lab: 'max_minutes' must be a finite number > 0, got {self.max_minutes!r}")
        if not 0 <= self.placement_deg < 90:
            raise ModelError(f"hand lab: 'placement_deg' must lie in [0, 90) deg, got {self.placement_deg!r}")
        if not self.turn_pairs or any(k not in tpr.TURN_PAIRS for k in self.turn_pairs):
            raise ModelError(f"hand lab: 'turn_pairs' must be some of {tpr.TURN_PAIRS}, got {self.turn_pairs!r}")
        if self.budget_minutes is not None and not (math.isfinite(self.budget_minutes) and self.budget_minutes > 0):
            raise ModelError(f"hand lab: 'budget_minutes' must be a finite number > 0, got {self.budget_minutes!r}")
        if self.acc_noise_g is not None and not (math.isfinite(self.acc_noise_g) and self.acc_noise_g > 0):
            raise ModelError(f"hand lab: 'acc_noise_g' must be a finite number > 0, got {self.acc_noise_g!r}")

    def to_json(self) -> dict:
        """The lab as JSON (minutes, deg, g)."""
        return {
            "kind": "hand",
            "poses": self.poses,
            "max_minutes": self.max_minutes,
            "placement_deg": self.placement_deg,
            "acc_noise_g": self.acc_noise_g,
            "turn_pairs": list(self.turn_pairs),
            "budget_minutes": self.budget_minutes,
        }

    def shortest_minutes(self) -> float:
        """The shortest session of :attr:`poses` in which the design searches every structure of
        :attr:`turn_pairs` (min): its moves at a hand's pace, the known-angle turns, rests of 2 s. Every length the
        bisection tries then runs one compiled search."""
        turns = 6 * max(self.turn_pairs) * tpr.turn_seconds(tpr.TURN_DEG)
        return ((self.poses - 1) * tpr.turn_seconds(180.0) + turns + 2.0 * (self.poses + 3)) / 60.0


def accelerometer_noise(records) -> float | None:
    """The accelerometers' white noise (g per sample): the median over the records' static segments and axes of the
    samples' standard deviation; None without accelerometer columns or rests of 3 samples."""
    sds = []
    for r in records:
        a = acc_g(r)
        if a is None:
            continue
        label = np.asarray(r.columns["segment"])
        for s in r.meta["segments"]:
            rows = a[label == s["label"]]
            if s["type"] == "static" and len(rows) >= 3:
                sds += np.std(rows, axis=0, ddof=1).tolist()
    return float(np.median(sds)) if sds else None


def session_noise(fit, records, lab: HandLab) -> tuple[TriadNoise, list]:
    """(the next session's :class:`~gyrojax.planning.triad_fisher.TriadNoise`, notes) from the fit's noise and the
    lab (module doc): the largest channel's ARW (the white term of its long-run variance at the records' sample
    interval, :meth:`~gyrojax.noise.spec.SessionNoise.of_sample_variances`, deg/√h), the variance components as the
    fit estimated them (indicated units, :func:`~gyrojax.inference.triad.components_tau2`), the records' site and
    Earth rate."""
    dt = float(np.median(np.concatenate([np.diff(np.asarray(r.time_s, dtype=float)) for r in records])))
    if not dt > 0:
        raise ModelError(f"next test: the records' sample interval is {dt} s; their time_s must increase")
    arw = np.array([c.white for c in SessionNoise.of_sample_variances(fit.noise_q, dt).channels])
    acc = lab.acc_noise_g if lab.acc_noise_g is not None else accelerometer_noise(records)
    if acc is None:
        raise ModelError("next test: the records hold no accelerometer rests; give the lab's acc_noise_g")
    tau2 = components_tau2(fit.variance_components or {})
    notes = []
    if tau2.get("walk"):
        notes.append(
            "the fit finds a bias that walks from pose to pose: the session is designed without it, so its σ after "
            "are optimistic"
        )
    meta = records[0].meta
    site = meta.get("site") or {}
    earth = bool(meta.get("earth_rate", True))
    noise = TriadNoise(
        arw=float(arw.max()),
        acc_noise_g=float(acc),
        rate_hz=1.0 / dt,
        latitude_deg=site.get("latitude_deg") if earth else None,
        earth_rate=earth,
        placement_deg=lab.placement_deg,
        gravity_mps2=site.get("gravity_mps2"),
        pose_scatter_dph=math.sqrt(tau2.get("pose", 0.0)),
        move_angle_deg=math.degrees(math.sqrt(tau2.get("move", 0.0))),
    )
    if arw.max() > 1.05 * arw.min():
        notes.append(
            f"the channels' ARW differ ({', '.join(f'{x:.3g}' for x in arw)} deg/sqrt(h)): the session is designed "
            "at the largest, so the σ after it are upper bounds on the quieter channels"
        )
    return noise, notes


def prior_information(fit, model) -> np.ndarray:
    """The information of the records so far on the design model's coefficients (report units, θ order of
    :func:`~gyrojax.physics.triad.channel_names`): the inverse of the fit's covariance (module doc)."""
    names = list(tp.channel_names(model))
    if list(fit.names) != names:
        raise ModelError(
            f"next test: the fit's coefficients ({', '.join(fit.names)}) are not those of the design model "
            f"({', '.join(names)})"
        )
    cov = np.asarray(fit.cov, dtype=float)
    s = np.sqrt(np.diag(cov))
    return np.linalg.inv(cov / np.outer(s, s)) / np.outer(s, s)


def predicted_sigma(model, prior, proto) -> np.ndarray:
    """σ (report units, θ order) of the joint fit after the session ``proto``: (prior + its F)^{-1/2}, F from the
    protocol's written steps (:meth:`~gyrojax.planning.triad_protocol.TriadProtocol.fisher`)."""
    s = tpr.sigma(np.asarray(prior) + proto.fisher(), model)
    return np.array([s[n] for n in tp.channel_names(model)])


@dataclass
class HandDesign:
    """The designed session ``protocol`` (None when none meets the goal), its ``minutes``, σ after it (θ order),
    ``minutes_needed`` (the estimate when the lab's longest session does not suffice, else ``minutes``), the
    worst σ/target at the lab's longest session, the search's notes, and the session designed at the lab's longest
    (``longest``; σ after it are ``sigma_after`` when ``protocol`` is None)."""

    protocol: object
    minutes: float
    sigma_after: np.ndarray
    minutes_needed: float
    ratio_at_longest: float
    notes: list
    longest: object = None


def design_session(
    model,
    targets,
    prior,
    noise: TriadNoise,
    lab: HandLab,
    margin: float,
    *,
    seed: int = 0,
    starts: int = 4,
    steps: int = 150,
    lbfgs_steps: int | None = None,
) -> HandDesign:
    """The shortest session meeting every target (module doc). ``targets`` (θ order, report units; NaN where the
    goal sets none), ``prior`` the records' information (:func:`prior_information`), ``margin`` the goal's."""
    targets = np.asarray(targets, dtype=float)
    goal = np.isfinite(targets)
    weights = np.where(goal, 1.0 / np.where(goal, margin * targets, 1.0) ** 2, 0.0)
    crit = Criterion("ratio")
    tried = {}

    def session(minutes):
        if minutes not in tried:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                proto = tpr.design_protocol(
                    model.terms,
                    lab.poses,
                    minutes,
                    crit,
                    noise,
                    starts=starts,
                    steps=steps,
                    seed=seed,
                    turn_pairs=lab.turn_pairs,
                    prior=prior,
                    weights=weights,
                    **({} if lbfgs_steps is None else {"lbfgs_steps": lbfgs_steps}),
                )
            sig = predicted_sigma(model, prior, proto)
            tried[minutes] = (proto, sig, float(np.max(sig[goal] / targets[goal])))
        return tried[minutes]

    def snap(minutes):  # the session's length on the grid of RESOLUTION_S from the shortest
        k = math.ceil((minutes - lo) * 60.0 / RESOLUTION_S - 1e-9)
        return min(lo + k * RESOLUTION_S / 60.0, longest)

    def ok(minutes):
        return session(snap(minutes))[2] <= margin

    longest = lab.max_minutes
    lo = min(lab.shortest_minutes(), longest)
    proto, sig, worst = session(longest)
    if worst > margin:
        now = tpr.sigma(prior, model)
        now = np.array([now[n] for n in tp.channel_names(model)])
        f0, f1 = now[goal] ** -2.0, sig[goal] ** -2.0
        slope = np.maximum(f1 - f0, 1e-300) / longest
        need = float(np.max(((margin * targets[goal]) ** -2.0 - f0) / slope))
        return HandDesign(None, longest, sig, need, worst, _notes(proto), proto)
    minutes = lo if ok(lo) else snap(bisect(ok, lo, longest)[1])
    proto, sig, _ = session(minutes)
    return HandDesign(proto, minutes, sig, minutes, worst, _notes(proto), tried[longest][0])


def _notes(proto) -> list:
    return [f"design search: {proto.convergence_note}"] if not proto.converged else []


def session_comparison(proto, prior, model, targets) -> list[dict]:
    """Rows (plan, worst σ/target, σ after of every coefficient) of the designed session beside Ferraris' protocol
    and imu_tk's random poses of the same minutes (:func:`gyrojax.planning.triad_protocol.comparison`'s
    baselines), each added to the records' information; imu_tk's the mean over its draws. Ferraris' is left out
    when its turns and flips do not fit in the minutes."""
    names = list(tp.channel_names(model))
    n = sum(s["type"] == "rest" for s in proto.steps)
    protocols = [(proto.start_attitude, proto.steps)]
    groups = [(f"designed ({n} poses, after the records)", [0])]
    try:
        protocols.append(tpr.ferraris_steps(proto.total_s))
        groups.append((tpr.BASELINES[0], [1]))
    except ModelError:
        pass
    first = len(protocols)
    protocols += [tpr.random_steps(n, proto.total_s, seed) for seed in range(tpr.RANDOM_DRAWS)]
    groups.append((tpr.BASELINES[1].format(n=n, draws=tpr.RANDOM_DRAWS), list(range(first, len(protocols)))))
    f, _ = tpr.evaluate(model, protocols, proto.noise)
    goal = np.isfinite(targets)
    rows = []
    for name, idx in groups:
        sig = np.array([[tpr.sigma(prior + f[i], model)[c] for c in names] for i in idx]).mean(axis=0)
        rows.append(
            {
                "plan": name,
                "criterion": float(np.max(sig[goal] / targets[goal])),
                "sigma": dict(zip(names, sig.tolist())),
            }
        )
    return rows
