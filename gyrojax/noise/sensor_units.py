"""The noise report of an accelerometer channel in accelerometer units.

:func:`gyrojax.noise.readoff.noise_report` reads the IEEE 952 annex C figures with the formulas of a rate in deg/h
(conventions §6: N = σ(τ)·√τ/60 deg/√h, B = σ_min/0.664 deg/h, K = σ(τ)·√(3·3600/τ) deg/h/√h, Q = σ(τ)·τ/√3
arcsec, R = σ(τ)·√2·3600/τ deg/h/h, τ in s). Fed a specific force in m/s², the same formulas give B in m/s², K in
m/s²/√h, Q in m/s and R in m/s²/h as they stand (each is σ in the series' unit times a power of τ in h, or of τ in s
for Q), but N in (m/s²)·√h: the velocity random walk σ(τ)·√τ in m/s/√s is 60 × that in m/s/√h, so
VRW (m/s/√h) = 3600 × the formula's N. :data:`ACCEL_UNITS` holds that factor and the unit label of each figure;
:func:`accelerometer_report` applies it to every figure of a report (``terms``, ``derived``, ``model.parameters``,
``headline``, ``spectral_lines`` and the notes made of them) and renames the ADEV arrays' keys
(``adev_deg_per_h`` → ``adev_mps2``), so that no accelerometer number carries a deg/h label. Conventions §1–§8 fix
no accelerometer noise unit; this is an extension in SI (§1's internal unit for acceleration), the unit Kalibr's
accelerometer figures use.

The noise model itself (``model``, :class:`~gyrojax.noise.spec.NoiseSpec` fields and ``cov``) stays in the
analysis unit, IEEE 952's fields with m/s² in place of deg/h (``model.rate_unit``), so that its ADEV is that of the
series; ``model.parameters`` gives each one in accelerometer units.
"""

from __future__ import annotations

import copy

from gyrojax.noise import headline
from gyrojax.noise import lines as lines_mod

RATE_UNIT = "m/s^2"
"""The unit of an accelerometer channel's series, ADEV and model ADEV."""

ACCEL_UNITS = {
    # figure or model parameter: (unit, factor from the value read with the deg/h formulas on an m/s² series)
    "arw": ("m/s/sqrt(h)", 3600.0),
    "white": ("m/s/sqrt(h)", 3600.0),
    "bias_instability": ("m/s^2", 1.0),
    "rrw": ("m/s^2/sqrt(h)", 1.0),
    "random_walk": ("m/s^2/sqrt(h)", 1.0),
    "quantization": ("m/s", 1.0),
    "rate_ramp": ("m/s^2/h", 1.0),
    "sigma": ("m/s^2", 1.0),
    "tau": ("s", 1.0),
    "ar": ("1", 1.0),
}
"""Unit and conversion factor of each IEEE 952 figure and noise-model parameter of an accelerometer channel."""

ADEV_KEYS = {"adev_deg_per_h": "adev_mps2", "adev_model_deg_per_h": "adev_model_mps2"}
"""The ADEV arrays' keys of a gyro report and of an accelerometer report (values in deg/h and in m/s²)."""


def _scaled(fig: dict, name: str) -> dict:
    """One read-off (``value``, ``std``, ``unit`` …) in accelerometer units; one not read keeps its reason."""
    unit, f = ACCEL_UNITS[name]
    out = dict(fig)
    for k in ("value", "std", "std_given_model"):
        if out.get(k) is not None:
            out[k] = out[k] * f
    for k in ("ci", "ci_given_model"):  # the selection's interval and the chosen model's own
        if out.get(k) is not None:
            out[k] = [None if c is None else c * f for c in out[k]]
    if "unit" in out or out.get("value") is not None:
        out["unit"] = unit
    return out


def accelerometer_report(out: dict) -> dict:
    """A copy of a ``noise_report`` dict of an accelerometer channel (series in m/s²) with every figure in
    accelerometer units (module doc): VRW N m/s/√h, B m/s², K m/s²/√h, Q m/s, R m/s²/h, Gauss–Markov σ m/s²;
    ADEV arrays under ``adev_mps2`` / ``adev_model_mps2`` (m/s², band ``adequacy.low``/``high`` likewise)."""
    out = copy.deepcopy(out)
    for old, new in ADEV_KEYS.items():
        if old in out:
            out[new] = out.pop(old)
    out["rate_unit"] = RATE_UNIT
    terms = out.get("terms", {})
    for k, v in terms.items():
        if k == "gauss_markov":
            v["unit"] = [ACCEL_UNITS["sigma"][0], ACCEL_UNITS["tau"][0]]
        elif k in ACCEL_UNITS:
            unit, f = ACCEL_UNITS[k]
            v["value"], v["unit"] = v["value"] * f, unit
    for k, v in out.get("derived", {}).items():
        out["derived"][k] = _scaled(v, k)
    if "model" in out:
        out["model"]["rate_unit"] = RATE_UNIT
        for k, p in out["model"].get("parameters", {}).items():
            unit, f = ACCEL_UNITS.get(k, ACCEL_UNITS.get(k.rsplit("_", 1)[-1], ACCEL_UNITS["ar"]))  # as NoiseSpec.unit
            p["unit"] = unit
            for key in ("value", "std"):
                if p.get(key) is not None:
                    p[key] = p[key] * f
            if p.get("ci95") is not None:
                p["ci95"] = [None if c is None else c * f for c in p["ci95"]]
    _relabel_lines(out)
    old_notes = {f"{k}: {v['note']}" for k, v in out["headline"].items() if v["note"]}
    model = {k: _scaled(v["model"], k) for k, v in out["headline"].items()}
    curve = {k: _scaled(v["curve"], k) for k, v in out["headline"].items()}
    out["headline"] = headline.compare(model, curve)
    notes = []
    for n in out["notes"]:
        if n in old_notes:
            continue
        if n.startswith("terms.bias_instability"):  # B's factor is 1: only its unit changes
            n = n.replace(" deg/h", f" {ACCEL_UNITS['bias_instability'][0]}")
        notes.append(n)
    out["notes"] = notes + [f"{k}: {v['note']}" for k, v in out["headline"].items() if v["note"]]
    return out


def _relabel_lines(out: dict) -> None:
    """The spectral lines of a report (``spectral_lines``, their note and the verdict's words) in m/s²: the
    amplitude and the Allan deviation peak are in the series unit already (factor 1), only the label changes."""
    old = out.get("spectral_lines") or []
    if not old:
        return
    new = [{**ln, "unit": RATE_UNIT} for ln in old]
    search = out.get("spectral_line_search", {})
    old_note, new_note = lines_mod.note(old, search), lines_mod.note(new, search)
    out["notes"] = [new_note if n == old_note else n for n in out["notes"]]
    verdict = out.get("adequacy", {}).get("verdict")
    if verdict:
        for a, b in zip(old, new):
            verdict = verdict.replace(lines_mod.describe(a), lines_mod.describe(b))
        out["adequacy"]["verdict"] = verdict
    out["spectral_lines"] = new
