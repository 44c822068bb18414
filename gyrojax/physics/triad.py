"""A three-axis gyro triad (MEMS IMU) as three SDF-like rate gyros, one per body axis (docs/conventions.md, triad).

Channel c ∈ {x, y, z} senses the body axis e_c: its input axis IA = e_c, and its output and spin axes follow
cyclically, so that IA × OA = SA as for an SDF gyro (conventions §4):

    x: (IA, OA, SA) = (x, y, z)      y: (y, z, x)      z: (z, x, y)

Each channel obeys the SDF balance equation with its own coefficients (Hu 2-45; conventions §4, §6),

    ω_ind,c = ω_I + E_SF ω_I + M_O ω_O + M_S ω_S + D_F + D_I a_I + D_O a_O + D_S a_S + …   (deg/h; a in g)

evaluated by the same :func:`gyrojax.physics.model.indicated_output` and the same named effects as an SDF gyro, so
every effect that needs no turntable applies (bias, g- and g²-sensitivity, scale factor and its asymmetry and
nonlinearity, IA misalignment, trend, temperature). Stacked over the channels the linear part is the familiar
matrix form of IMU calibration (imucal, Kalibr, imu_tk):

    ω_ind = S ω + G a + b,   S = I + [E_SF on the diagonal, M_O and M_S off it],  G (deg/h/g),  b (deg/h)

with row c of S holding 1 + E_SF at column c, M_O (rad) at column OA(c) and M_S at column SA(c), and G likewise
D_I, D_O, D_S. :func:`matrices` and the imucal / Kalibr forms below convert between the two.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.errors import ModelError
from gyrojax.physics import effects as fx
from gyrojax.physics.model import Model, indicated_output

CHANNELS = ("x", "y", "z")
FRAMES = ((0, 1, 2), (1, 2, 0), (2, 0, 1))
"""Body-axis indices of (IA, OA, SA) for channels x, y, z."""
TURNTABLE_ONLY = ("table_tilt", "table_azimuth", "encoder_harmonic")
DEFAULT_STATIC_TERMS = ("D_F", "D_I", "D_O", "D_S")
"""The triad's default channel model of a session of rests: bias and the g-sensitive drift."""
DEFAULT_ROTATION_TERMS = DEFAULT_STATIC_TERMS + ("sf_error", "ia_misalignment")
"""The default of a session with turns or moves: bias, g-terms, scale-factor error and misalignment."""


def channel_name(coefficient: str, channel: str) -> str:
    """``D_F`` and ``x`` → ``D_F[x]``: the per-channel coefficient name of the triad JSON."""
    return f"{coefficient}[{channel}]"


def channel_names(model: Model) -> tuple[str, ...]:
    """``<coefficient>[<channel>]`` of every coefficient, channel by channel: the order of a triad's θ (3p,)."""
    return tuple(channel_name(c, ch) for ch in CHANNELS for c in model.coefficient_names)


def channel_theta(model: Model, values: dict) -> np.ndarray:
    """(3, p) per-channel coefficients from ``{"D_F[x]": …}`` in report units; a name not given is 0."""
    return np.array([[values.get(channel_name(c, ch), 0.0) for c in model.coefficient_names] for ch in CHANNELS])


def split_channel_name(name: str) -> tuple[str, str]:
    """``D_F[x]`` → (``D_F``, ``x``); :class:`ModelError` for a name without a channel."""
    if name.endswith("]") and "[" in name:
        base, ch = name[:-1].split("[", 1)
        if ch in CHANNELS:
            return base, ch
    raise ModelError(f"{name!r} is not a per-channel coefficient name such as 'D_F[x]'")


def effect_of(coefficient: str) -> str | None:
    """The effect (conventions §6) of a coefficient, a channel's (``D_F[x]``) as its name's; None for a coefficient
    of no effect (a triad's power-up steps ``D_F_step_1[x]``)."""
    try:
        coefficient = split_channel_name(coefficient)[0]
    except ModelError:
        pass
    entry = fx.coefficient_index().get(coefficient)
    return entry[0] if entry else None


def channel_model(terms) -> Model:
    """The SDF model of one channel; refuses effects that need a turntable (there is none)."""
    model = Model.of(terms, fx.SDF)
    bad = [t for t in model.terms if t in TURNTABLE_ONLY]
    if bad:
        raise ModelError(f"effects {bad} describe a turntable; a hand-moved IMU triad has none")
    hinged = [t for t in model.terms if fx.get(t).knee is not None]
    if hinged:
        raise ModelError(f"effects {hinged} have a knee to fit, which the linear triad fit does not do")
    return model


def channel_inputs(w_body, a_body, t_h, temperature_C, c: int) -> dict:
    """SDF inputs of channel ``c`` from body-frame rates ``w_body`` (n, 3) deg/h and specific force ``a_body``
    (n, 3) g: w_I, w_O, w_S, a_I, a_O, a_S by the cyclic frames (module doc); t_h in h, temperature in °C."""
    i, o, s = FRAMES[c]
    return {
        "w_I": w_body[:, i],
        "w_O": w_body[:, o],
        "w_S": w_body[:, s],
        "a_I": a_body[:, i],
        "a_O": a_body[:, o],
        "a_S": a_body[:, s],
        "t_h": t_h,
        "temperature_C": temperature_C,
    }


def triad_output(model: Model, theta, w_body, a_body, t_h, temperature_C):
    """Indicated rates (n, 3) deg/h of the three channels; ``theta`` (3, p) holds each channel's coefficients in
    report units (rows x, y, z), ``w_body`` (n, 3) deg/h, ``a_body`` (n, 3) g, ``t_h`` (n,) h, temperature (n,) °C."""
    outs = [
        indicated_output(model, theta[c], channel_inputs(w_body, a_body, t_h, temperature_C, c), fx.SDF)
        for c in range(3)
    ]
    return jnp.stack(outs, axis=1)


def affine_rows(model: Model):
    """∂ω_ind/∂θ of :func:`triad_output` at θ = 0 as an affine function of the inputs, for a model whose effects
    are affine in the body rate ω (deg/h) and the specific force a (g) and independent of time and temperature
    (bias, g-terms, scale factor, misalignment): rows(ω, a) = B₀ + Σ_j ω_j B_ω[j] + Σ_j a_j B_a[j], each (3, 3p)
    (channels × θ of the three channels, in the order x, y, z), from ``jax.jacfwd`` of the channel model at unit
    inputs. Returns (B₀, B_ω (3, 3, 3p), B_a (3, 3, 3p)); traceable, so a jitted caller folds it into constants."""
    p = model.size
    eye, zero = jnp.eye(3), jnp.zeros((3, 3))
    w = jnp.concatenate([jnp.zeros((1, 3)), eye, zero])  # the inputs 0, ω = e_j, a = e_j
    a = jnp.concatenate([jnp.zeros((1, 3)), zero, eye])

    def out(theta):
        return triad_output(model, theta.reshape(3, p), w, a, jnp.zeros(7), jnp.full(7, 20.0))

    jac = jax.jacfwd(out)(jnp.zeros(3 * p))  # (7, 3, 3p)
    return jac[0], jac[1:4] - jac[0], jac[4:7] - jac[0]


BODY_RATE_ITERATIONS = 6
"""Chord steps of :func:`body_rates` for a model nonlinear in the rate: each divides the error by about
1/(2 |E_A| + 4 |E_2| ω) (≥ 10³ for MEMS sizes), so six leave it at the rounding of float64."""


def rate_nonlinear(model: Model) -> bool:
    """True when some effect of ``model`` is not linear in the input rate (E_A, E_2): ω must then be found by
    iteration, not one solve (dimensionless answer: the model's form, not its units)."""
    return not all(e.linear_in_rate for e in model.effects)


def body_rates(model: Model, theta, w_ind, a_body, t_h, temperature_C, iterations: int = BODY_RATE_ITERATIONS):
    """The body rates (n, 3) deg/h that make the channels indicate ``w_ind`` (n, 3) deg/h: :func:`triad_output`
    solved for ω (Hu 2-45 inverted), every effect of ``model`` included (g- and g²-terms, trend, temperature at
    ``a_body`` g, ``t_h`` h, ``temperature_C`` °C; ``theta`` (3, p) report units).

    The rate enters as ω_ind = B + S ω + N(ω): B every term at ω = 0, S the linear scale-and-misalignment matrix,
    N the rate-nonlinear terms (E_A |ω_I|, E_2 ω_I²). ω = S⁻¹ (ω_ind − B) is exact without N; with N the chord
    iteration ω ← ω + S⁻¹ (ω_ind − ω_ind(ω)) follows (``iterations`` steps). Differentiable in θ (jax)."""
    th = jnp.asarray(theta)
    n = w_ind.shape[0]
    bias = triad_output(model, th, jnp.zeros((n, 3)), a_body, t_h, temperature_C)
    eye, zero, t0, temp0 = jnp.eye(3), jnp.zeros((3, 3)), jnp.zeros(3), jnp.full(3, 20.0)
    s = (triad_output(model, th, eye, zero, t0, temp0) - triad_output(model, th, zero, zero, t0, temp0)).T
    s_inv_t = jnp.linalg.inv(s).T  # one 3×3 inverse, applied to every sample (a LAPACK solve per call costs ms)
    w = (w_ind - bias) @ s_inv_t
    if rate_nonlinear(model):
        for _ in range(iterations):
            w = w + (w_ind - triad_output(model, th, w, a_body, t_h, temperature_C)) @ s_inv_t
    return w


# ---- matrix forms ----------------------------------------------------------------------------------------------


def matrices(values: dict) -> dict:
    """Bias b (deg/h), scale-and-misalignment S (dimensionless) and g-sensitivity G (deg/h/g) of ω_ind = S ω + G a + b
    (module doc) from per-channel coefficients ``{"D_F[x]": …, "E_SF[y]": … (ppm), "M_O[z]": … (arcsec)}``.

    Absent coefficients are zero. Returns numpy arrays under ``b``, ``S``, ``G``."""
    b, s, g = np.zeros(3), np.eye(3), np.zeros((3, 3))
    for c, ch in enumerate(CHANNELS):
        i, o, sa = FRAMES[c]

        def v(name, _ch=ch):
            return float(values.get(channel_name(name, _ch), 0.0))

        b[c] = v("D_F")
        s[c, i] += v("E_SF") * units.PPM
        s[c, o] += v("M_O") * units.ARCSEC
        s[c, sa] += v("M_S") * units.ARCSEC
        g[c, i], g[c, o], g[c, sa] = v("D_I"), v("D_O"), v("D_S")
    return {"b": b, "S": s, "G": g}


def misalignment_angles(values: dict, cov=None, names=None) -> dict:
    """The misalignment of each channel's sensing axis as geometry: the angles between the axis it senses and the
    body frame, independent of the nominal scale (a scale error multiplies a whole row of S).

    Channel c senses ŝ_c = S_c / |S_c| (row c of :func:`matrices`' S normalised, the rows of imucal's R_g): tilted
    toward its output axis by μ_O = atan2(ŝ_c·OA, ŝ_c·IA) = atan(M_O / (1 + E_SF)) and toward its spin axis by
    μ_S = atan(M_S / (1 + E_SF)), in all by ψ = arccos(ŝ_c·IA) (arcsec). The nominal-scale form M_O, M_S (the
    coefficients of §6, rad of S's off-diagonal) equals these to first order only when the nominal scale is right.

    ``cov`` (with ``names``, the coefficient names of its rows): the covariance of the per-channel coefficients
    (report units); σ by the delta method. Returns ``{"M_O[x]": {"value", "std", "unit"}, …, "psi[x]": …}``.
    """
    out = {}
    idx = {n: i for i, n in enumerate(names or [])}
    for ch in CHANNELS:
        e = float(values.get(channel_name("E_SF", ch), 0.0)) * units.PPM
        mo = float(values.get(channel_name("M_O", ch), 0.0)) * units.ARCSEC
        ms = float(values.get(channel_name("M_S", ch), 0.0)) * units.ARCSEC
        d = 1.0 + e
        r2 = mo * mo + ms * ms
        angles = {
            "M_O": math.atan2(mo, d),
            "M_S": math.atan2(ms, d),
            "psi": math.atan2(math.sqrt(r2), d),
        }
        # derivatives by (E_SF ppm, M_O arcsec, M_S arcsec), each angle in rad (NaN where an angle has none: a row
        # with no component at all along its sensing axis and none toward one side)
        rho = math.sqrt(r2)
        with np.errstate(divide="ignore", invalid="ignore"):
            d_o, d_s, d_p = (np.float64(d * d) + x for x in (mo * mo, ms * ms, r2))
            jac = {
                "M_O": np.array([-mo / d_o * units.PPM, d / d_o * units.ARCSEC, 0.0]),
                "M_S": np.array([-ms / d_s * units.PPM, 0.0, d / d_s * units.ARCSEC]),
                "psi": np.array(
                    [-rho / d_p * units.PPM, d / d_p * mo / rho * units.ARCSEC, d / d_p * ms / rho * units.ARCSEC]
                )
                if rho
                else np.array([0.0, np.nan, np.nan]),
            }
        keys = [channel_name(k, ch) for k in ("E_SF", "M_O", "M_S")]
        rows = [idx.get(k) for k in keys]
        for k, a in angles.items():
            std = None
            if cov is not None:
                use = [(j, r) for j, r in enumerate(rows) if r is not None]
                sub = np.asarray(cov)[np.ix_([r for _, r in use], [r for _, r in use])]
                g = jac[k][[j for j, _ in use]]
                var = float(g @ sub @ g)
                std = math.sqrt(var) / units.ARCSEC if var >= 0 and math.isfinite(var) else None
            out[channel_name(k, ch)] = {"value": a / units.ARCSEC, "std": std, "unit": "arcsec"}
    return out


IMUCAL_GRAVITY = 9.81
"""imucal's ``grav``, m/s²: the 1 g its Ferraris calibration divides specific force by (a constant of that tool, not
a site's gravity)."""


def imucal_form(
    m: dict, counts_per_dps: float = 1.0, rotation_sign: float = 1.0, grav_mps2: float = IMUCAL_GRAVITY
) -> dict:
    """The gyro part of imucal's Ferraris calibration, ``raw = K_g R_g ω + K_ga a + b_g`` (ω in deg/s, a in m/s²,
    raw in counts; K_g diagonal, rows of R_g unit vectors), from :func:`matrices`.

    ``counts_per_dps``: the nominal scale the indicated rates were divided by (1 for records in deg/s).
    ``rotation_sign``: imucal's ``expected_angle`` sign (−1 for its default −360°, taken as clockwise): its R_g
    then carries the sign of the rotation convention. ``grav_mps2``: imucal's ``grav`` (its 1 g).
    """
    k = counts_per_dps
    kr = rotation_sign * k * m["S"]
    kg = np.sqrt((kr * kr).sum(axis=1))
    return {
        "K_g": np.diag(kg),
        "R_g": kr / kg[:, None],
        "b_g": k * m["b"] / units.SECONDS_PER_HOUR,
        "K_ga": k * m["G"] / units.SECONDS_PER_HOUR / grav_mps2,
        "gyr_unit": "deg/s",
        "acc_unit": "m/s^2",
    }


def kalibr_form(m: dict) -> dict:
    """Kalibr's ``scale-misalignment`` gyro intrinsics, ``ω_m = C_gyro_i · M · ω + A · a + b`` (rad/s, a in m/s²):
    S = C·M by a QR decomposition (C a rotation, M upper triangular with a positive diagonal), A = G in rad/s per
    m/s², b in rad/s. The full S is returned too, for tools that take it directly."""
    q, r = np.linalg.qr(m["S"])
    d = np.sign(np.diag(r))
    d[d == 0] = 1.0
    q, r = q * d, (r.T * d).T
    if np.linalg.det(q) < 0:  # keep C a proper rotation (a reflection would mean a left-handed triad)
        raise ModelError("the fitted scale-and-misalignment matrix has a negative determinant (left-handed axes?)")
    return {
        "C_gyro_i": q,
        "M": r,
        "A": m["G"] * units.DEG_PER_H / units.G0,
        "b": m["b"] * units.DEG_PER_H,
        "S": m["S"],
        "units": {"M": "-", "A": "rad/s per m/s^2", "b": "rad/s"},
    }
