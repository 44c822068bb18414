"""Eleven campaigns of the noise and slow effects real sensors have — a bias that walks between a hand session's
rests, a two-slope or quadratic temperature bias on a turntable, slow coloured drift, a bias step between power-ups —
written by the independent writers (tests/independent_triad_writer.py, tests/independent_writer.py), each with its
truth, the reference analysis' noise model (tests/reference_analysis.py) and the answer a diagnosis should give.

gyrojax is asked through its command line's JSON (conventions §7), the contract that outlives any refactor of its
inference: ``gyrojax diagnose RECORD... --terms T --json``, following its proposals (each added to ``--terms``) until
it proposes nothing.

Sizes are chosen so that every planted effect's test has power ≥ 0.999 at the truth (tests/reference_analysis.py
computes it), and gyrojax's diagnosis of a case stays within seconds.
"""

from __future__ import annotations

import contextlib
import io
import json
from dataclasses import dataclass, field

import numpy as np

from . import independent_triad_writer as itw
from . import independent_writer as iw
from . import reference_analysis as ra

TURNTABLE_BASE = {"D_F": 0.4, "D_I": 0.6, "D_O": -0.2, "D_S": 0.3}
DRIFT4 = ("D_F", "D_I", "D_O", "D_S")
ARW = 0.001  # deg/√h, the turntable campaigns' white noise
GM = (0.015, 1500.0)  # σ deg/h, τ s: slow coloured drift, τ five times a position's dwell
HINGE = (0.016, 0.004)  # seed 001's K_tx1 (hot) and K_tx2 (cold), deg/h/°C about 20 °C: told from a quadratic
HINGE_WEAK = (0.010, 0.002)  # a gentler two slopes: a temperature shape detectable, hinge and quadratic alike
QUADRATIC = 2.5e-4  # deg/h/°C² on (T − 20)²
D_TEMP = 0.006  # deg/h/°C, the registry's bias_temperature beside slow coloured drift
STEP_DPH = 20.0  # the triad walk's step per move, deg/h
REST_S, MOVE_S = 4.0, 2.0
TRANSITION_S = 0.2
RRW = STEP_DPH * np.sqrt(3600.0 / (REST_S + TRANSITION_S + MOVE_S))  # K with the steps' variance per rest interval
TREND_DPH_PER_H = 20000.0  # the triad trend beside the walk (z)
TURN_ON_STEP = 60.0  # deg/h on y between power-ups
# two power-ups are told from a trend only by the trend within each: 30 rests each, 30 s apart, 5 deg/h scatter
POWER_UP_POSES, POWER_UP_GAP_S, POWER_UP_SCATTER = 30, 30.0, 5.0
TRIAD_NOISE_DPS = 0.05
TURNTABLE_DWELL_S, TURNTABLE_DT_S = 480.0, 6.0


@dataclass
class Case:
    """One campaign: ``build(folder, seed)`` → (JSON paths, truth) (a triad's also ``build.records(seed)`` →
    (records in memory, truth)); ``terms`` the model gyrojax is given; ``noise``
    the reference's true noise model (``"steps"``, ``"rrw"``, ``"scatter"`` for triads; None or (σ, τ) Gauss–Markov
    for turntables); ``planted`` {candidate: value} of the effect a diagnosis should find (empty: a null);
    ``right`` what gyrojax should end with: ``"adequate"`` (nothing proposed), the effect its loop should add, or
    ``"temperature_hinge"`` / ``"temperature_shape"`` for a temperature shape the registry does not name (the hinge
    told from a quadratic, or either)."""

    name: str
    kind: str
    build: object
    terms: tuple
    noise: object
    planted: dict = field(default_factory=dict)
    right: str = "adequate"
    reference_components: dict = field(default_factory=dict)  # the true variance components of a triad case


def _turntable(name, extra=None, gauss_markov=None, coefficients=None):
    def build(folder, seed):
        run = iw.twenty_four_positions(
            name=f"{name}-{seed}", dwell=TURNTABLE_DWELL_S, dt=TURNTABLE_DT_S, temperature=iw.chamber_cycle()
        )
        truth = dict(TURNTABLE_BASE) | (coefficients or {})
        paths = iw.write_campaign(
            folder, [run], truth, noise_white=ARW, seed=seed, extra=extra, gauss_markov=gauss_markov
        )
        return paths, {"coefficients": truth, "white": ARW, "gauss_markov": gauss_markov}

    return build


class _Triad:
    """A triad case's generator: ``records(seed)`` in memory, ``__call__(folder, seed)`` written."""

    def __init__(self, make, **kw):
        self.make, self.kw = make, kw

    def records(self, seed):
        return self.make(seed, rest_s=REST_S, move_s=MOVE_S, **self.kw)

    def __call__(self, folder, seed):
        recs, truth = self.records(seed)
        return itw.write(folder, recs), truth


def _hand(drift, size, trend=None):
    return _Triad(itw.hand_session_records, drift=drift, drift_size=size, trend=trend)


def _power_ups(step):
    return _Triad(
        itw.power_up_records, step=step, poses=POWER_UP_POSES, gap_s=POWER_UP_GAP_S, scatter_dph=POWER_UP_SCATTER
    )


_K, _S = (0.5 * (HINGE[0] + HINGE[1]), 0.5 * (HINGE[0] - HINGE[1]))  # linear and |T − 20| parts of the two slopes
CASES = {
    c.name: c
    for c in (
        Case("walk-steps", "triad", _hand("steps", STEP_DPH), itw.MODEL, "steps", {}, "adequate", {"steps": 400.0}),
        Case("walk-rrw", "triad", _hand("rrw", RRW), itw.MODEL, "rrw", {}, "adequate", {"rrw": RRW**2}),
        Case(
            "pose-scatter",
            "triad",
            _hand("scatter", STEP_DPH),
            itw.MODEL,
            "scatter",
            {},
            "adequate",
            {"scatter": 400.0},
        ),
        Case(
            "trend-beside-walk",
            "triad",
            _hand("steps", STEP_DPH, {"z": TREND_DPH_PER_H}),
            itw.MODEL,
            "steps",
            {"bias_trend[z]": TREND_DPH_PER_H},
            "bias_trend",
            {"steps": 400.0},
        ),
        Case(
            "power-up-step",
            "triad",
            _power_ups({"y": TURN_ON_STEP}),
            itw.MODEL,
            "scatter",
            {"bias_turn_on[y]": TURN_ON_STEP},
            "bias_turn_on",
            {"scatter": POWER_UP_SCATTER**2},
        ),
        Case(
            "power-up-null",
            "triad",
            _power_ups({}),
            itw.MODEL,
            "scatter",
            {},
            "adequate",
            {"scatter": POWER_UP_SCATTER**2},
        ),
        Case(
            "two-slope-temperature",
            "turntable",
            _turntable("hinge", extra=iw.two_slope(*HINGE)),
            DRIFT4,
            None,
            {"bias_temperature": _K, "temperature_hinge": _S},
            "temperature_hinge",
        ),
        Case(
            "two-slope-gentle",
            "turntable",
            _turntable("hingeweak", extra=iw.two_slope(*HINGE_WEAK)),
            DRIFT4,
            None,
            {"bias_temperature": 0.5 * sum(HINGE_WEAK), "temperature_hinge": 0.5 * (HINGE_WEAK[0] - HINGE_WEAK[1])},
            "temperature_shape",
        ),
        Case(
            "quadratic-temperature",
            "turntable",
            _turntable("quad", extra=lambda t, temp: QUADRATIC * (temp - 20.0) ** 2),
            DRIFT4,
            None,
            {"temperature_quadratic": QUADRATIC},
            "temperature_shape",
        ),
        Case("slow-drift-null", "turntable", _turntable("gmnull", gauss_markov=GM), DRIFT4, GM, {}, "adequate"),
        Case(
            "linear-temperature-in-drift",
            "turntable",
            _turntable("lintemp", gauss_markov=GM, coefficients={"D_TEMP": D_TEMP}),
            DRIFT4,
            GM,
            {"bias_temperature": D_TEMP},
            "bias_temperature",
        ),
    )
}


def gyrojax_json(paths, terms) -> dict:
    """``gyrojax diagnose PATHS --terms TERMS --json`` run in this process; its JSON (exit code 0 asserted)."""
    from gyrojax.cli.app import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["diagnose", *map(str, paths), "--terms", ",".join(terms), "--json"])
    if code != 0:
        raise RuntimeError(f"gyrojax diagnose exited {code}")
    return json.loads(out.getvalue())


def named_noise(d: dict) -> list:
    """The noise processes a diagnosis JSON names: the triad's variance components, a turntable's gauss_markov."""
    names = [n["name"] for n in d.get("noise_processes", [])]
    names += [c["name"] for c in d["candidates"] if c["name"] == "gauss_markov" and c["p_value"] < d["alpha"]]
    return names


def unexplained_name(s: dict) -> str:
    """One entry of a diagnosis' ``unexplained``: a triad's shape name, or a turntable's shape against its input
    (with the expression gyrojax suggests for it)."""
    if "name" in s:
        return s["name"]
    return f"{s['shape']} in {s['versus']}" + (f" ({s['expression']})" if s.get("expression") else "")


def gyrojax_loop(paths, terms, steps=3) -> list:
    """gyrojax's diagnosis loop from ``terms``: diagnose, add the proposal, diagnose again, until nothing is proposed
    (at most ``steps`` additions). One dict per diagnosis: terms, verdict, proposal, the top candidate and its
    Holm p, the named noise, RMS and floor."""
    chain, terms = [], tuple(terms)
    for _ in range(steps + 1):
        d = gyrojax_json(paths, terms)
        top = next((c for c in d["candidates"] if c["name"] != "gauss_markov"), None)
        proposal = d.get("proposal")
        estimate = None
        if proposal and top is not None:
            est = top.get("estimate") or {}
            estimate = {k: v.get("value") for k, v in est.items()} if isinstance(est, dict) else est
        chain.append(
            {
                "terms": terms,
                "verdict": d["verdict"],
                "proposal": proposal,
                "top": top["name"] if top else None,
                "top_p_adjusted": top.get("p_adjusted") if top else None,
                "estimate": estimate,
                "noise": named_noise(d),
                "unexplained": [unexplained_name(s) for s in d.get("unexplained", [])],
                "rms": d["residual_rms_deg_per_h"],
                "floor": d["noise_floor_deg_per_h"],
                "chi2_with_components": d.get("chi2_with_components"),
                "family_size": d.get("family_size"),
            }
        )
        if not proposal or proposal in terms:
            break
        terms = terms + (proposal,)
    return chain


def judged(case: Case, chain: list) -> bool:
    """Did gyrojax's loop give the right answer? A null: nothing proposed at any step and the last verdict adequate.
    A planted effect: the loop added it (or, for a shape the registry does not name, kept the verdict missing-effect
    while it was unexplained) and ended adequate."""
    added = [c["proposal"] for c in chain if c["proposal"]]
    last = chain[-1]
    if case.right == "adequate":
        return not added and last["verdict"] == "adequate"
    if case.right in ("temperature_hinge", "temperature_shape"):
        # a temperature shape beyond the linear term: right when the loop adds something that follows it
        # (neither a trend nor nothing) and ends adequate; today's registry has no such effect
        beyond = [a for a in added if a not in ("bias_temperature", "bias_trend")]
        return bool(beyond) and last["verdict"] == "adequate"
    return case.right in added and last["verdict"] == "adequate"


def reference(case: Case, paths) -> dict:
    """The reference analysis of one campaign (tests/reference_analysis.py) at the true noise model: what forward
    selection takes (name, LM, Holm p) and the smallest Holm p left; for triads also the analysis under the
    independent per-rest scatter (the model gyrojax's triad fit assumes: its components, its smallest Holm p and
    the trend LM of each channel), the walk against the scatter (−2ℓ_R), the residual lag-1 autocorrelation of the
    rest means under the scatter, and with two power-ups the trend's LM beside the step; for turntables the shapes'
    LM beside every named candidate and the fitted knee."""
    if case.kind == "triad":
        taken, last = ra.triad_select(paths, TRIAD_NOISE_DPS, case.noise)
        out = {"taken": taken, "left": last.smallest_holm, "components": last.components}
        scatter = ra.triad_reference(paths, TRIAD_NOISE_DPS, "scatter")
        out["scatter"] = {
            "components": scatter.components,
            "left": scatter.smallest_holm,
            "trend_lm": {c: scatter.lm[f"bias_trend[{c}]"] for c in itw.CHANNELS},
        }
        out["walk_against_scatter"] = ra.walk_against_scatter(paths, TRIAD_NOISE_DPS)
        out["lag1_under_scatter"] = ra.rest_residual_lag1(paths, TRIAD_NOISE_DPS)
        if "bias_turn_on[y]" in case.planted:
            held = ra.triad_reference(paths, TRIAD_NOISE_DPS, case.noise, extra_x=("bias_turn_on[y]",))
            out["trend_beside_step_lm"] = {c: held.lm[f"bias_trend[{c}]"] for c in itw.CHANNELS}
        return out
    taken, last = ra.turntable_select(paths, case.terms, ARW, case.noise)
    out = {"taken": taken, "left": last.smallest_holm}
    with_temp = tuple(case.terms) + ("bias_temperature",)
    full = ra.turntable_reference(paths, with_temp, ARW, case.noise)
    out |= {k: full[k] for k in full if k.startswith(("knee", "hinge", "lm_beside"))}
    return out


RIVALS = {"power-up-step": ("bias_trend[y]",), "two-slope-temperature": ("temperature_quadratic",)}
"""What a planted effect must also beat to be named rightly: the step a trend over both power-ups, the hinge a
quadratic in temperature."""


def planted_power(case: Case, paths, families=(27, 60)) -> dict:
    """The noncentrality λ of the planted effect's test at the truth (beside the model, and for a turntable shape
    beside every named candidate and the linear temperature term), its power at the first Holm step of each family
    size in ``families`` (tests/reference_analysis.py), and the same beside its rivals (:data:`RIVALS`)."""
    rivals = RIVALS.get(case.name, ())
    if case.kind == "triad":
        comp, planted = case.reference_components, case.planted
        lam = ra.triad_noncentrality(paths, TRIAD_NOISE_DPS, comp, planted)
        lam_r = ra.triad_noncentrality(paths, TRIAD_NOISE_DPS, comp, planted, beside=rivals) if rivals else None
        df = len(planted)
    else:
        planted = dict(case.planted)
        model = tuple(case.terms)
        if "temperature_hinge" in planted or "temperature_quadratic" in planted:
            planted.pop("bias_temperature", None)
            model = model + ("bias_temperature",)
        lam = ra.turntable_noncentrality(paths, model, ARW, case.noise, planted)
        lam_r = ra.turntable_noncentrality(paths, model + rivals, ARW, case.noise, planted) if rivals else None
        df = len(planted)
    out = {"lambda": lam, "df": df} | {f"power_F{f}": ra.power(lam, df, ra.ALPHA, f) for f in families}
    if rivals:
        out |= {"rivals": rivals, "lambda_beside_rivals": lam_r}
        out |= {f"power_beside_rivals_F{f}": ra.power(lam_r, df, ra.ALPHA, f) for f in families}
    return out
