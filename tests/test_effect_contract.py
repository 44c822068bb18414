"""The effect contract (optax style): every registered effect, built in or added later, keeps the same promises.

For each name in the registry (:func:`gyrojax.physics.effects.names`, read when the tests are collected, so an
effect registered by any module imported by ``gyrojax`` is covered without being listed here):

* its coefficients carry report units from :data:`gyrojax.units.REPORT_UNITS`, and its flags are coherent;
* its contribution to the indicated output is finite on representative inputs, and survives ``jax.jit``,
  ``jax.vmap`` and ``jax.grad`` with the same numbers;
* it is linear in its coefficients when it says ``linear=True``, and affine in the input rates when it says
  ``linear_in_rate=True`` (what the servo solver relies on);
* simulate → fit recovers it on a plan that excites it (a plan chosen by instrument kind and effect family).

Set-up effects (no contribution of their own) are checked through the measurement model's ``predict``.
"""

import dataclasses
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyrojax import units
from gyrojax.data import plans
from gyrojax.data.arrays import record_data
from gyrojax.inference.identify import fit
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, indicated_output, predict
from gyrojax.simulation.simulator import plan_records, simulate

EFFECTS = fx.names()

RATE_KEYS = {
    fx.TDF: ("w_X", "w_Y", "w_Z"),
    fx.ACCEL: ("w_I", "w_P", "w_O"),
}
FORCE_KEYS = {
    fx.TDF: ("a_X", "a_Y", "a_Z"),
    fx.ACCEL: ("a_I", "a_P", "a_O"),
}
SDF_LIKE = ("w_I", "w_O", "w_S"), ("a_I", "a_O", "a_S")

TYPICAL = {  # a representative size of a coefficient, by report unit
    "deg/h": 0.5,
    "deg/h/g": 0.3,
    "deg/h/g²": 0.08,
    "deg/h/h": 0.2,
    "deg/h/°C": 0.05,
    "°C": 25.0,
    "ppm": 300.0,
    "ppm/(deg/s)": 20.0,
    "arcsec": 40.0,
    "g": 2e-3,
    "g/g": 1.0,
    "g/g²": 2e-4,
    "g/g³": 5e-5,
}
LOCK_IN = 300.0  # deg/h: a rate-ladder's first rungs sit above it


def _keys(kind):
    rates, forces = SDF_LIKE
    return RATE_KEYS.get(kind, rates), FORCE_KEYS.get(kind, forces)


def _inputs(kind, n=48, seed=0):
    """Representative instrument inputs: rates up to ±50 deg/s (deg/h), forces within ±1 g, 0–5 h, 10–40 °C."""
    rng = np.random.default_rng(seed)
    rates, forces = _keys(kind)
    x = {k: jnp.asarray(rng.uniform(-1, 1, n) * 50 * 3600.0) for k in rates}
    x.update({k: jnp.asarray(rng.uniform(-1, 1, n)) for k in forces})
    x["t_h"] = jnp.asarray(np.linspace(0.0, 5.0, n))
    x["temperature_C"] = jnp.asarray(rng.uniform(10.0, 40.0, n))
    return x


def _atol(x, y):
    """Absolute tolerance for comparing contributions computed as (ω + contribution) − ω: rounding of the rates."""
    return 1e-14 * max(float(max(jnp.abs(v).max() for v in x.values())), float(jnp.abs(y).max()))


def _typical(effect, scale=1.0):
    return np.array([TYPICAL.get(u, 1.0) * scale for u in effect.units])


def _geometry(kind):
    """A small record (no simulation) of each kind on a skew multi-position plan, as ``predict`` sees it."""
    return record_data(plan_records(_on_kind(plans.multiposition(6, minutes=0.2, dt_s=4.0), kind))[0])


def _on_kind(plan, kind):
    """``plan`` with its runs' instrument declared as ``kind`` (mounted on the same axes)."""
    ia, oa = plans.SKEW_MOUNT["ia"], plans.SKEW_MOUNT["oa"]
    runs = []
    for r in plan.runs:
        inst = dict(r.instrument)
        if kind == fx.TDF:
            inst = plans.tdf_mount(inst.get("ia", ia), inst.get("oa", oa))
        elif kind == fx.ACCEL:
            inst = plans.accel_mount(inst.get("ia", ia), inst.get("oa", oa))
        else:
            inst["kind"] = kind
        sf = 1e-3 if kind == fx.ACCEL else r.scale_factor
        runs.append(dataclasses.replace(r, instrument=inst, scale_factor=sf))
    return dataclasses.replace(plan, runs=tuple(runs))


def _contribution(effect, kind):
    """f(x, c): what the effect adds to the indicated output, through the model's own balance equation (so a TDF
    effect sees its channel flags); for a set-up effect, what it changes in ``predict`` of a small record."""
    if effect.setup:
        data = _geometry(kind)
        base = predict(Model((), kind), jnp.zeros(0), data)
        model = Model((effect.name,), kind)
        # jitted once: op-by-op dispatch of the kinematics under vmap/grad is what would make this test slow
        return jax.jit(lambda x, c: predict(model, c, data) - base)
    model, none = Model((effect.name,), kind), Model((), kind)
    return lambda x, c: indicated_output(model, c, x, kind) - indicated_output(none, jnp.zeros(0), x, kind)


@pytest.mark.parametrize("name", EFFECTS)
def test_declares_units_and_coherent_flags(name):
    e = fx.get(name)
    assert len(e.units) == len(e.coefficients) >= 1, name
    unknown = [u for u in e.units if u not in units.REPORT_UNITS]
    assert not unknown, f"{name}: units {unknown} are not report units (gyrojax.units.REPORT_UNITS)"
    assert e.kinds and set(e.kinds) <= set(fx.INSTRUMENT_KINDS), e.kinds
    assert e.description and e.reference
    assert (e.contribution is None) == e.setup, "set-up effects act on the kinematics, others contribute"
    for c in e.coefficients:
        assert fx.effect_of_coefficient(c) == name


@pytest.mark.parametrize("name", EFFECTS)
def test_finite_and_transformable(name):
    e = fx.get(name)
    for kind in e.kinds[:1] if e.setup else e.kinds:
        f = _contribution(e, kind)
        x, c = _inputs(kind), jnp.asarray(_typical(e))
        y = f(x, c)
        assert np.all(np.isfinite(np.asarray(y))), f"{name} on a {kind}: non-finite contribution"
        assert float(jnp.abs(y).max()) > 0, f"{name} on a {kind}: no contribution at typical coefficients"
        np.testing.assert_allclose(jax.jit(f)(x, c), y, rtol=1e-12, atol=1e-12 * float(jnp.abs(y).max()))
        batch = jnp.stack([c, 0.5 * c, -2.0 * c])
        yb = jax.vmap(f, in_axes=(None, 0))(x, batch)
        for k in range(3):
            np.testing.assert_allclose(yb[k], f(x, batch[k]), rtol=1e-12, atol=1e-12 * float(jnp.abs(y).max()))
        g = jax.grad(lambda cc: jnp.sum(f(x, cc)))(c)
        jac = jax.jacfwd(lambda cc: f(x, cc))(c)
        assert np.all(np.isfinite(np.asarray(g))), f"{name}: non-finite gradient"
        np.testing.assert_allclose(g, jac.sum(axis=0), rtol=1e-9, atol=1e-12 * float(jnp.abs(jac).max()))


@pytest.mark.parametrize("name", [n for n in EFFECTS if fx.get(n).linear])
def test_linear_in_coefficients_where_declared(name):
    e = fx.get(name)
    rng = np.random.default_rng(1)
    for kind in e.kinds:
        f = _contribution(e, kind)
        x = _inputs(kind, seed=2)
        c1, c2 = _typical(e) * rng.normal(size=e.size), _typical(e) * rng.normal(size=e.size)
        a, b = 1.7, -0.6
        lhs = f(x, jnp.asarray(a * c1 + b * c2))
        rhs = a * f(x, jnp.asarray(c1)) + b * f(x, jnp.asarray(c2))
        np.testing.assert_allclose(lhs, rhs, rtol=1e-10, atol=_atol(x, rhs))


@pytest.mark.parametrize("name", [n for n in EFFECTS if fx.get(n).linear_in_rate and not fx.get(n).setup])
def test_affine_in_rate_where_declared(name):
    """ω ↦ contribution(s·ω) is affine in s, so the servo balance ω_ind(θ̇) = S_nom·i has a one-step Newton root."""
    e = fx.get(name)
    for kind in e.kinds:
        f = _contribution(e, kind)
        x, c = _inputs(kind, seed=3), jnp.asarray(_typical(e))
        rates, _ = _keys(kind)

        def at(s, x=x):
            return f({k: (v * s if k in rates else v) for k, v in x.items()}, c)

        y0, y1 = at(0.0), at(1.0)
        for s in (2.5, -1.5):
            want = y0 + s * (y1 - y0)
            np.testing.assert_allclose(at(s), want, rtol=1e-9, atol=_atol(x, want))


@pytest.mark.parametrize("name", [n for n in EFFECTS if not fx.get(n).linear_in_rate])
def test_nonlinear_in_rate_flag_is_needed(name):
    """An effect flagged ``linear_in_rate=False`` really is not affine in the rate (else the flag costs servo
    Newton steps for nothing)."""
    e = fx.get(name)
    kind = e.kinds[0]
    f, x, c = _contribution(e, kind), _inputs(kind, seed=4), jnp.asarray(_typical(e))
    rates, _ = _keys(kind)

    def at(s):
        return f({k: (v * s if k in rates else v) for k, v in x.items()}, c)

    y0, y1 = at(0.0), at(1.0)
    off = max(float(jnp.abs(at(s) - (y0 + s * (y1 - y0))).max()) for s in (2.5, -1.5))
    assert off > 1e-6 * float(jnp.abs(y1).max()), f"{name} is affine in the rate: declare linear_in_rate=True"


# ---- simulate → fit recovers each effect on a plan that excites it ---------------------------------------------

RATE_FAMILY = {"sf_error", "sf_asymmetry", "sf_quadratic", "ia_misalignment", "table_tilt", "lock_in"}


def _plan_for(effect):
    """The instrument kind and a short plan that excites ``effect``: a rate ladder (three mountings) for the
    scale-factor family, misalignment, lock-in and table tilt; a 24-position static test on a two-axis table for
    the g-terms, trends, temperature, table azimuth and the platform encoder's harmonics (its angle error moves the
    Earth-rate projection), mounted as the instrument kind needs."""
    kind = fx.RLG if effect.name == "lock_in" else effect.kinds[0]
    if effect.name in RATE_FAMILY:
        rates = (0.1, 0.2, 0.5, 1.0) if effect.name == "lock_in" else (5, 50)
        plan = plans.rate_ladder(rates_dps=rates, seconds=8, dt_s=0.5)
    elif effect.name == "encoder_harmonic":  # the platform (encoder) axis at 24 distinct angles
        plan = plans.multiposition(minutes=0.5, dt_s=5.0, positions=[(45.0 * (j % 4), 15.0 * j) for j in range(24)])
    else:
        plan = plans.multiposition(24, minutes=0.5, dt_s=5.0)
    if effect.name in fx.TEMPERATURE_EFFECTS:  # a temperature ramp of 15 → 35 °C over the run
        ramp = tuple(dataclasses.replace(r, temperature_C=(15.0, 35.0)) for r in plan.runs)
        plan = dataclasses.replace(plan, runs=ramp)
    return kind, _on_kind(plan, kind)


def _base_terms(kind):
    return {fx.TDF: ["DX_F", "DY_F"], fx.ACCEL: ["K_0", "K_1"]}.get(kind, ["D_F"])


@pytest.mark.parametrize("name", EFFECTS)
def test_simulate_then_fit_recovers_it(name):
    e = fx.get(name)
    kind, plan = _plan_for(e)
    base = [t for t in _base_terms(kind) if t != name]
    value = _typical(e) * np.array([(-1.0) ** k * (1.0 - 0.15 * k) for k in range(e.size)])  # distinct, both signs
    if name == "lock_in":
        value = np.array([LOCK_IN])
    if e.knee is not None:  # a knee inside the recorded range: 25 °C on the 15 → 35 °C ramp
        value[-1] = TYPICAL["°C"]
    coefficients = {fx.get(t).coefficients[0]: TYPICAL[fx.get(t).units[0]] for t in base}
    truth = {"coefficients": dict(coefficients), "noise": {"white": 1e-8 if kind == fx.ACCEL else 1e-5}}
    if e.setup:
        truth["setup"] = {name: value.tolist()}
    else:
        truth["coefficients"].update(zip(e.coefficients, value.tolist()))
    recs = simulate(plan, truth, seed=11)
    # a hinged effect starts from its knee's profile (gyrojax.inference.knee), the set-up effects from near the truth
    theta0 = None if e.linear or e.knee else np.concatenate([[0.0] * len(base), 0.8 * value])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a fit that did not converge fails the contract
        res = fit(recs, base + [name], noise="white", theta0=theta0)
    for c, v in zip(e.coefficients, value):
        est, sd = res.values[c], res.stds[c]
        assert sd < 0.25 * abs(v), f"{name}: {c} is barely seen by this plan (σ {sd:.3g} for {v:.3g})"
        assert abs(est - v) < 5 * sd + 1e-9 * abs(v), f"{name}: {c} = {est:.6g} ± {sd:.3g}, truth {v:.6g}"
