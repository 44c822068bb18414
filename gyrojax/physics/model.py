"""The measurement model: one path from coefficients to what a record measured.

``predict(model, theta, data)`` gives, for every measurement of a record, what the instrument would have
indicated. Simulation, fitting, diagnosis and design all call it; regressors are its ``jax.jacfwd`` in θ.

Measurements (``RecordData.y``):

* **rebalance** (SDF gyro, accelerometer): the indicated output S_nom·i at each sample (deg/h or g);
  TDF gyros stack channel X then channel Y.
* **servo**: the mean servo-axis rate over each sample interval, Δθ_read/Δt (deg/h), inside continuous segments.
  The model integrates the balance equation over the interval (trapezoid of the rate that keeps the pickoff at
  null, Hu 3-59), so the angle record keeps its full precision: the increments sum to the whole angle, and white
  rate noise gives independent increments.

θ is the flat vector of the model's coefficients in report units (deg/h, deg/h/g, ppm, arcsec …), in the order
of ``Model.coefficient_names``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics import frames, kinematics
from gyrojax.runtime.rows import clamped


@dataclass(frozen=True)
class Model:
    """An ordered set of named effects for one instrument kind."""

    terms: tuple[str, ...]
    kind: str = fx.SDF

    def __post_init__(self):
        seen = set()
        for t in self.terms:
            e = fx.get(t)
            if self.kind not in e.kinds:
                raise ModelError(f"effect {t!r} does not apply to a {self.kind} (it applies to {e.kinds})")
            if t in seen:
                raise ModelError(f"effect {t!r} is listed twice")
            seen.add(t)

    @classmethod
    def of(cls, terms, kind: str = fx.SDF) -> "Model":
        """A model from effect names or coefficient names (``"E_SF"`` is taken as ``"sf_error"``)."""
        out = []
        for t in terms:
            name = t if t in fx.names() else _effect_of(t)
            if name not in out:
                out.append(name)
        return cls(tuple(out), kind)

    @property
    def effects(self) -> tuple[fx.Effect, ...]:
        """The :class:`gyrojax.physics.effects.Effect` objects of ``terms``, in order."""
        return tuple(fx.get(t) for t in self.terms)

    @property
    def coefficient_names(self) -> tuple[str, ...]:
        """Coefficient names (conventions §6) in θ order: the effects' coefficients, effect after effect."""
        return tuple(c for e in self.effects for c in e.coefficients)

    @property
    def coefficient_units(self) -> tuple[str, ...]:
        """Report unit of each coefficient (``"deg/h"``, ``"deg/h/g"``, ``"ppm"``, ``"arcsec"`` …), θ order."""
        return tuple(u for e in self.effects for u in e.units)

    @property
    def size(self) -> int:
        """Number of coefficients p (the length of θ)."""
        return len(self.coefficient_names)

    @property
    def is_linear(self) -> bool:
        """True when the output is linear in every coefficient: one least-squares solve fits (built-in set-up
        effects are the nonlinear ones)."""
        return all(e.linear for e in self.effects)

    def slices(self) -> dict[str, slice]:
        """Effect name -> slice of θ holding that effect's coefficients."""
        out, i = {}, 0
        for e in self.effects:
            out[e.name] = slice(i, i + e.size)
            i += e.size
        return out

    def pack(self, coefficients: dict) -> np.ndarray:
        """Flat θ from a dict of coefficient values (absent ones are zero; unknown ones are errors)."""
        idx = fx.coefficient_index()
        for k in coefficients:
            if k not in idx:
                raise ModelError(f"unknown coefficient {k!r}; valid: {', '.join(idx)}")
        return np.array([float(coefficients.get(c, 0.0)) for c in self.coefficient_names])

    def full(self, theta):
        """θ of :attr:`effects` from the model's θ: itself (a :class:`Selected` places its padded θ in its
        library's)."""
        return theta

    def extend(self, *terms) -> "Model":
        """This model with effect (or coefficient) names appended; names already present are kept once."""
        return Model.of(self.terms + tuple(terms), self.kind)

    def without(self, *terms) -> "Model":
        """This model with the effects named ``terms`` removed (effect names; unknown names are ignored)."""
        return Model(tuple(t for t in self.terms if t not in terms), self.kind)


@partial(jax.tree_util.register_dataclass, data_fields=["present", "index"], meta_fields=["library"])
@dataclass(frozen=True)
class Selected:
    """A model as data over a library model of its kind: compiled code of the library serves every model of its terms.

    θ is the model's own, padded by ``index`` to a fixed length (:attr:`size`) and placed in the library's θ by
    :meth:`full` (the library's other coefficients zero, the padding dropped); ``present`` (L,) bool marks which of
    the library's contributing effects (those with a contribution, library order) the model holds: the others add
    nothing to :func:`indicated_output`. The sum is taken in the library's order, so it may differ from the model's in
    the last bits (as evaluating a record in pieces does). Built by :meth:`of`.
    """

    library: Model
    present: jax.Array  # (L,) bool
    index: jax.Array  # (size,) int: position in the library's θ of each coefficient; library.size for padding

    @classmethod
    def of(cls, model: Model, library: Model, size: int) -> "Selected":
        """``model`` (whose terms are all in ``library``) over ``library``, its θ padded to ``size``."""
        if not set(model.terms) <= set(library.terms) or size < model.size:
            raise ModelError(f"{model.terms} is not a selection of {library.terms} of at most {size} coefficients")
        present = np.array([e.name in model.terms for e in library.effects if e.contribution is not None])
        position = {c: i for i, c in enumerate(library.coefficient_names)}
        index = [position[c] for c in model.coefficient_names] + [library.size] * (size - model.size)
        return cls(library, present, np.array(index, dtype=np.int32))

    @property
    def kind(self) -> str:
        """The library's instrument kind."""
        return self.library.kind

    @property
    def effects(self) -> tuple[fx.Effect, ...]:
        """The library's effects: :func:`predict` evaluates them all, on θ placed by :meth:`full`."""
        return self.library.effects

    @property
    def size(self) -> int:
        """The length of the padded θ."""
        return int(self.index.shape[0])

    def slices(self) -> dict[str, slice]:
        """The library's slices (of :meth:`full`)."""
        return self.library.slices()

    def pad(self, theta) -> np.ndarray:
        """The padded θ (:attr:`size`) of the model's own θ (numpy, zeros after it)."""
        th = np.asarray(theta, dtype=np.float64)
        return np.concatenate([th, np.zeros(self.size - th.size)])

    def full(self, theta):
        """The library's θ of the padded θ of the model."""
        return jnp.zeros(self.library.size + 1, theta.dtype).at[self.index].set(theta)[: self.library.size]


def _effect_of(name: str) -> str:
    try:
        return fx.effect_of_coefficient(name)
    except KeyError:
        raise ModelError(f"unknown effect {name!r}; valid names: {', '.join(fx.names())}") from None


# ---------------------------------------------------------------------------------------------------------------


@partial(
    jax.tree_util.register_dataclass,
    data_fields=[
        "axes",
        "triad",
        "latitude",
        "gravity",
        "time_s",
        "angles",
        "rates",
        "temperature",
        "y",
        "weight",
        "command",
        "dt",
    ],
    meta_fields=["kind", "mode", "servo_axis", "encoder_axis", "rates_derived"],
)
@dataclass(frozen=True)
class RecordData:
    """A record as arrays (SI inside): what ``predict`` needs. Built by :func:`gyrojax.data.arrays.record_data`.

    Units: ``latitude`` rad, ``gravity`` m/s² (g_site), ``time_s`` s, ``angles`` (n, k) rad as read,
    ``rates`` (n, k) rad/s, ``temperature`` (n,) °C (20 °C when the record has none), ``y`` deg/h for gyros and
    g for accelerometers (servo: mean servo-axis rate per interval, deg/h), ``command`` deg/h (S_nom·i),
    ``dt`` (n−1,) s; ``axes`` and ``triad`` are unit vectors, ``weight`` is 1 or 0. ``rates_derived`` is True when
    the rates were differentiated from the angles, so the encoder error reaches them too (:func:`true_angles`).
    """

    axes: jax.Array  # (k, 3) table axes in L at zero angles
    triad: jax.Array  # (3, 3) instrument axes in platform coordinates (rows)
    latitude: jax.Array  # rad
    gravity: jax.Array  # m/s²
    time_s: jax.Array  # (n,)
    angles: jax.Array  # (n, k) rad, as read
    rates: jax.Array  # (n, k) rad/s (servo axis: ignored, solved for)
    temperature: jax.Array  # (n,) °C (20 when absent)
    y: jax.Array  # measurements (see module doc)
    weight: jax.Array  # 1 for a valid measurement, 0 for a masked one (servo intervals across segments)
    command: jax.Array  # (n,) indicated output of the commanded current in servo mode, deg/h (S_nom·i)
    dt: jax.Array  # (n−1,) sample intervals, s
    kind: str = fx.SDF
    mode: str = "rebalance"
    servo_axis: int | None = None
    encoder_axis: int = 0
    rates_derived: bool = False


def measurements(data: RecordData) -> int:
    """Number of measurement rows of a record per channel: its samples, in servo mode its sample intervals."""
    n = int(data.time_s.shape[0])
    return max(n - 1, 0) if data.mode == "servo" else n


def measurement_rows(data: RecordData, first: int, rows: int) -> RecordData:
    """Measurements ``first … first + rows − 1`` of a record (per channel, :func:`measurements`) as a record of their
    own (numpy arrays), those past the record's end copies of its last one (to be dropped from the outputs).

    A measurement depends on its own sample alone (rebalance: the balance equation at the sample) or on the two
    samples of its interval (servo: the table rate, rad/s, that nulls the pickoff, Hu 3-59, integrated over the
    interval), so :func:`predict` of the pieces, put together, is that of the whole record. A servo piece holds the
    samples ``first … first + rows`` (one more than its intervals); a TDF piece's measurements are channel X's, then
    channel Y's, of its samples.
    """
    n = int(data.time_s.shape[0])
    servo = data.mode == "servo"
    ix = clamped(first, rows + 1 if servo else rows, n - 1)
    gaps = np.minimum(ix[:-1], max(n - 2, 0))  # the interval after each sample of the piece but its last

    def samples(a):
        return np.asarray(a)[ix]

    def intervals(a):
        a = np.asarray(a)
        return a[gaps] if a.size else np.zeros(gaps.shape + a.shape[1:])

    def rows_of(a):
        if servo:
            return intervals(a)
        a = np.asarray(a)
        if data.kind == fx.TDF:
            return np.concatenate([a[:n][ix], a[n:][ix]])
        return a[ix]

    return dataclasses.replace(
        data,
        time_s=samples(data.time_s),
        angles=samples(data.angles),
        rates=samples(data.rates),
        temperature=samples(data.temperature),
        command=samples(data.command),
        y=rows_of(data.y),
        weight=rows_of(data.weight),
        dt=intervals(data.dt),
    )


# ---- the physics of one sample set ----------------------------------------------------------------------------


def setup_values(model: Model, theta) -> dict:
    """Set-up effect values from θ (report units, arcsec) as the kinematics take them: ``delta`` (3,) the base
    rotation (δ_E, δ_N, δ_U) in rad, ``encoder`` (4,) the harmonics (c1, s1, c2, s2) in rad; zero for set-up effects
    not in the model (conventions §6)."""
    sl = model.slices()

    def take(name, n):
        return theta[sl[name]] * units.ARCSEC if name in sl else jnp.zeros(n)

    return {
        "delta": jnp.concatenate([take("table_tilt", 2), take("table_azimuth", 1)]),
        "encoder": take("encoder_harmonic", 4),
    }


def encoder_error_trig(enc, c, s):
    """h(θ) and dh/dθ of :func:`encoder_error` from c = cos θ, s = sin θ (double-angle forms; no transcendental)."""
    c2, s2 = c * c - s * s, 2.0 * s * c
    h = enc[0] * c + enc[1] * s + enc[2] * c2 + enc[3] * s2
    dh = -enc[0] * s + enc[1] * c - 2.0 * enc[2] * s2 + 2.0 * enc[3] * c2
    return h, dh


def encoder_error(enc, angle):
    """Angle readout error h(θ) = c1 cos θ + s1 sin θ + c2 cos 2θ + s2 sin 2θ (rad), and dh/dθ (Hu 5-51)."""
    return encoder_error_trig(enc, jnp.cos(angle), jnp.sin(angle))


def true_angles(data: RecordData, setup: dict):
    """Table angles (n, k) rad and rates (n, k) rad/s with the encoder error removed from the encoder axis.

    First order in the readout error h(θ) of :func:`encoder_error` (Hu 5-51): θ_true = θ_read − h; the encoder axis's
    rate is scaled by 1 − dh/dθ when it was derived from the angles (``rates_derived``), else left alone.
    """
    e = data.encoder_axis
    h, dh = encoder_error(setup["encoder"], data.angles[:, e])
    angles = data.angles.at[:, e].add(-h)
    rates = data.rates
    if data.rates_derived:
        rates = rates.at[:, e].multiply(1.0 - dh)
    return angles, rates


def angle_trig(angles) -> list:
    """Per table axis (cos θ_i, sin θ_i) of angles (n, k) rad: the ``trig`` argument of :func:`instrument_inputs`."""
    return [(jnp.cos(angles[:, i]), jnp.sin(angles[:, i])) for i in range(angles.shape[1])]


_AXIS_NAMES = {fx.TDF: ("X", "Y", "Z"), fx.ACCEL: ("I", "P", "O")}


def _triad_inputs(axes, triad, latitude, gravity, trig, rates, delta) -> tuple:
    """Rates (deg/h) and specific forces (g) along the triad's three axes, each a 3-tuple of arrays shaped like the
    (cos, sin) of ``trig``; ``rates`` per table axis (rad/s)."""
    om = frames.earth_rate_enu(latitude)
    f = frames.specific_force_enu(gravity)
    wp, fp = kinematics.platform_inputs(axes, trig, rates, delta, om, f)
    w = tuple((triad[i, 0] * wp[0] + triad[i, 1] * wp[1] + triad[i, 2] * wp[2]) / units.DEG_PER_H for i in range(3))
    a = tuple((triad[i, 0] * fp[0] + triad[i, 1] * fp[1] + triad[i, 2] * fp[2]) / units.G0 for i in range(3))
    return w, a


def _record_inputs(data: RecordData, trig, rates, delta) -> tuple:
    """:func:`_triad_inputs` of a record: ``rates`` (n, k) rad/s."""
    per_axis = [rates[:, i] for i in range(rates.shape[1])]
    return _triad_inputs(data.axes, data.triad, data.latitude, data.gravity, trig, per_axis, delta)


def sensed(axes, triad, latitude, gravity, angles, rates, delta):
    """Inertial rate (deg/h) and specific force (g) along the three instrument axes, for one sample.

    ω_IP = Ω + ω_LP and f = (0, 0, g) in L, projected on C·axis (conventions §3–§4); the same code as
    :func:`instrument_inputs` (:func:`gyrojax.physics.kinematics.platform_inputs`), for angles (k,) rad and rates
    (k,) rad/s.
    """
    k = axes.shape[0]
    trig = [(jnp.cos(angles[i]), jnp.sin(angles[i])) for i in range(k)]
    w, a = _triad_inputs(axes, triad, latitude, gravity, trig, [rates[i] for i in range(k)], delta)
    return jnp.stack(w), jnp.stack(a)


def instrument_inputs(data: RecordData, setup: dict, angles=None, rates=None, trig=None) -> dict:
    """The inputs dict of :mod:`gyrojax.physics.effects` for every sample of a record (module doc there).

    Rates ``w_*`` in deg/h, specific forces ``a_*`` in g, ``t_h`` in h, ``temperature_C`` in °C.

    By default the table state is the read one corrected for the encoder error (:func:`true_angles`: θ = θ_read − h,
    applied as a small turn of (cos, sin) of the read angle, :func:`gyrojax.physics.kinematics.turn`); ``trig``
    (per axis (cos, sin) of ``data.angles``, :func:`angle_trig`) may be given precomputed, so that no
    transcendental function is evaluated (the Monte Carlo evaluates many draws on one plan). ``angles`` (n, k) rad
    and ``rates`` (n, k) rad/s replace the corrected table state when given (``trig`` is then ignored).
    """
    if angles is not None:
        trig = angle_trig(angles)
    else:
        e = data.encoder_axis
        trig = list(trig) if trig is not None else angle_trig(data.angles)
        h, dh = encoder_error_trig(setup["encoder"], *trig[e])
        trig[e] = kinematics.turn(trig[e][0], trig[e][1], -h)
        rates = data.rates
        if data.rates_derived:
            rates = rates.at[:, e].multiply(1.0 - dh)
    w, a = _record_inputs(data, trig, rates, setup["delta"])
    x = {"t_h": data.time_s / units.SECONDS_PER_HOUR, "temperature_C": data.temperature}
    for j, nm in enumerate(_AXIS_NAMES.get(data.kind, ("I", "O", "S"))):
        x[f"w_{nm}"] = w[j]
        x[f"a_{nm}"] = a[j]
    return x


def indicated_output(model: Model | Selected, theta, x: dict, kind: str):
    """The balance equation: what the instrument indicates for inputs ``x`` (conventions §4).

    SDF: ω_ind = ω_I + Σ effects (deg/h). TDF: channels X then Y stacked. Accelerometer: Σ effects (g; the
    K_1 a_I term is an effect like the others, Hu 3-38). θ is the model's (a :class:`Selected`: its library's).
    """
    if kind == fx.TDF:
        n = x["w_X"].shape[0]
        ones, zeros = jnp.ones(n), jnp.zeros(n)
        x = {k: jnp.concatenate([v, v]) for k, v in x.items()}
        x["channel_is_X"] = jnp.concatenate([ones, zeros])
        x["channel_is_Y"] = jnp.concatenate([zeros, ones])
        base = x["channel_is_X"] * x["w_X"] + x["channel_is_Y"] * x["w_Y"]
    elif kind == fx.ACCEL:
        base = jnp.zeros_like(x["a_I"])
    else:
        base = x["w_I"]
    sl = model.slices()
    adds = [e for e in model.effects if e.contribution is not None]
    parts = [e.contribution(x, theta[sl[e.name]]) for e in adds]
    if isinstance(model, Selected):
        parts = [jnp.where(model.present[k], p, 0.0) for k, p in enumerate(parts)]
    out = base
    for p in parts:
        out = out + p
    return out


def servo_rate(model: Model, theta, data: RecordData, setup: dict):
    """Rate of the servo axis (rad/s) that keeps the pickoff at null at each sample (Hu 3-59, general mounting).

    Solves ω_ind(θ̇_s) = S_nom·i by Newton's method (exact in one step when the model is linear in ω; two more
    steps settle |ω_I| and ω_I² terms).
    """
    angles, rates = true_angles(data, setup)
    s = data.servo_axis

    def residual(r):
        x = instrument_inputs(data, setup, angles, rates.at[:, s].set(r))
        return indicated_output(model, theta, x, data.kind) - data.command

    r = jnp.zeros(data.time_s.shape[0])
    nonlinear_in_rate = not all(e.linear_in_rate for e in model.effects)
    for _ in range(3 if nonlinear_in_rate else 1):
        f, df = jax.jvp(residual, (r,), (jnp.ones_like(r),))
        r = r - f / df
    return r, angles


def servo_sensitivity(data: RecordData):
    """∂ω_I/∂θ̇_s at each sample (dimensionless): how strongly turning the servo axis moves the input-axis rate.
    Zero means the table cannot null the pickoff (IA perpendicular to the servo axis)."""
    trig = angle_trig(data.angles)
    still = jnp.zeros_like(data.rates)
    unit = still.at[:, data.servo_axis].set(1.0)
    w1, _ = _record_inputs(data, trig, unit, jnp.zeros(3))
    w0, _ = _record_inputs(data, trig, still, jnp.zeros(3))
    return (w1[0] - w0[0]) * units.DEG_PER_H


def check_servo(data: RecordData, where: str) -> None:
    """Refuse a servo record whose IA has (almost) no component along the servo axis (Hu 3-59 needs one)."""
    if data.mode != "servo":
        return
    sens = np.abs(np.asarray(servo_sensitivity(data)))
    if sens.size and float(sens.min()) < 1e-6:
        i = int(np.argmin(sens))
        raise ModelError(
            f"{where}: in servo mode the IA must have a component along the servo axis; at sample {i} it has "
            f"{sens[i]:.3g} (IA perpendicular to the servo axis: turning the table cannot null the pickoff)"
        )


def predict(model: Model | Selected, theta, data: RecordData, trig=None):
    """Predicted measurement vector of a record (module doc), same shape as ``data.y`` (deg/h for gyros, g for
    accelerometers). ``trig``: optional precomputed (cos, sin) of ``data.angles`` (rad) per axis
    (:func:`angle_trig`; rebalance records). θ is the model's (a :class:`Selected`: padded, :meth:`Selected.full`)."""
    theta = model.full(jnp.asarray(theta, dtype=jnp.float64))
    setup = setup_values(model, theta)
    if data.mode == "servo":
        r, _ = servo_rate(model, theta, data, setup)
        s = data.servo_axis
        mean_rate = 0.5 * (r[1:] + r[:-1])
        dh = 0.0
        if data.encoder_axis == s:
            # the readout error's change over the interval, the trapezoid of dh/dθ times the predicted increment: the
            # read increment carries the measurement's own noise, so h at the next read angle would make a regressor
            # of the measurement itself; dh/dθ at both ends keeps the readout noise of the angles symmetric
            _, slope = encoder_error(setup["encoder"], data.angles[:, s])
            dh = 0.5 * (slope[1:] + slope[:-1]) * mean_rate
        return (mean_rate + dh) / units.DEG_PER_H * data.weight
    x = instrument_inputs(data, setup, trig=trig)
    return indicated_output(model, theta, x, data.kind)


def jacobian(model: Model, theta, data: RecordData):
    """Regressors: ∂ predict / ∂θ, shape (m, p), by forward-mode autodiff (never derived by hand)."""
    return jax.jacfwd(lambda th: predict(model, th, data))(jnp.asarray(theta, dtype=jnp.float64))


def predict_and_jacobian(model: Model, theta, data: RecordData):
    """(:func:`predict`, :func:`jacobian`) of a record in one forward-mode pass (the prediction is its primal): what a
    linearisation needs, one compiled function instead of two."""
    jac, y = jax.jacfwd(lambda th: (predict(model, th, data),) * 2, has_aux=True)(jnp.asarray(theta, dtype=jnp.float64))
    return y, jac


predict_jit = jax.jit(predict, static_argnums=0)
jacobian_jit = jax.jit(jacobian, static_argnums=0)
predict_and_jacobian_jit = jax.jit(predict_and_jacobian, static_argnums=0)
