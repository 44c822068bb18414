"""The MEMS gyro triad's plug-in of the Monte Carlo pipeline: hand calibration sessions drawn and fitted in pure JAX,
``vmap``-ed over draws by :mod:`gyrojax.montecarlo.runner` like a turntable study.

A triad study (:class:`~gyrojax.montecarlo.study.Study` with ``instrument="imu-triad"``) names a session —
``ferraris`` (:func:`gyrojax.simulation.triad.simulate_ferraris`), ``multiposition`` (imu_tk's random poses and
moves, :func:`~gyrojax.simulation.triad.simulate_multiposition`) or ``protocol`` (the steps of a protocol file of
``gyrojax design --instrument imu-triad``, :func:`~gyrojax.simulation.triad_session.simulate_session`) — with its
options, the fitted terms, priors of per-channel coefficients (``D_F[x]``; a coefficient ``D_F`` or an effect
``sf_error`` names every channel's) and the gyro's white noise. The session's motion is simulated once, noise-free;
a draw d (key fold_in(key(seed), d)) then

1. draws the truth θ_d from the priors and, with the Earth rate on, the session's heading ψ_d ~ U(0, 2π) (the
   whole session turned about Up: the horizontal Earth rate Ω cos φ (cos ψ N + sin ψ E) in the body frame, N and E
   the body-frame North and East of the noise-free session);
2. indicates the triad model (:func:`gyrojax.physics.triad.triad_output`) on every sample plus white noise (σ = 60 N
   √rate deg/h), the accelerometers the specific force plus white noise (``acc_noise_g``, g);
3. fits as :func:`gyrojax.inference.triad.fit_triad` does with the noise given (``noise_q``): the rest and rotation
   means by the fit's segment model (:func:`gyrojax.inference.triad_rows.segment_means`) with their covariance
   q/n I + the segments' heading and angle terms (:func:`gyrojax.data.triad_segments.triad_segments`), the moves by
   the fit's residual u_to − Rᵀ u_from (:func:`gyrojax.inference.triad_rows.move_residual`; the Up directions from
   the draw's accelerometer means) with variance q n Δt² + the Earth's turn + the two directions' noise, both
   components ⟂ u_to; three Gauss–Newton steps from θ = 0, σ̂ = √diag (JᵀJ)⁻¹ of the whitened rows (the noise known).

A known-angle turn's angle error (Ferraris' ``angle_std_deg``, a protocol's √2 ``placement_deg``) is drawn per
turn and scales the turn's rate. Simplifications against a real session, stated: the motion is otherwise the same
in every draw but for the heading (no placement errors of the rests, which the moves do not see to first order, and
the heading after a turn does not carry its angle error), the segment model's specific force and a rotation's rate
shape are the noise-free session's, and the covariance is taken at S = I.
The fit of a real session, with its noise estimated and the noise passes, is :func:`~gyrojax.inference.triad.fit_triad`;
:meth:`TriadPipeline.draw_record` writes a draw's session as a record to compare the two on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.data.record import Record
from gyrojax.data.triad_segments import label_rows, triad_segments
from gyrojax.errors import GyrojaxError
from gyrojax.inference.lstsq import lstsq
from gyrojax.inference.triad_rows import move_residual, pack_moves, pack_segments, segment_means
from gyrojax.montecarlo.study import Study, StudyError, parse_prior
from gyrojax.physics import effects as fx
from gyrojax.physics import triad as tp
from gyrojax.physics.gravity import site_gravity
from gyrojax.simulation.triad import simulate_ferraris, simulate_multiposition
from gyrojax.simulation.triad_session import simulate_session

LATITUDE = 49.6
"""Latitude of the simulated site, deg (its gravity is the simulations' default, the normal gravity there)."""
SESSIONS = ("ferraris", "multiposition", "protocol")
"""The sessions a triad study simulates (module doc)."""
GAUSS_NEWTON_STEPS = 3
"""Gauss–Newton steps of a draw's fit (the moves are nonlinear in S; three leave θ̂ at rounding for MEMS sizes)."""


def with_vertical_earth_rate(truth: dict) -> dict:
    """The coefficients a fit with the latitude unknown should find: with the site's vertical Earth rate
    Ω sin φ u = (Ω sin φ / |a|) a left in the g-terms (deg/h/g), through each channel's scale factor and
    misalignment (at :data:`LATITUDE`, |a| its normal gravity)."""
    k = units.OMEGA_IE_DEG_PER_H * math.sin(math.radians(LATITUDE)) / (site_gravity(LATITUDE) / units.G0)
    want = dict(truth)
    for ch in "xyz":
        want[f"D_I[{ch}]"] += k * (1.0 + truth.get(f"E_SF[{ch}]", 0.0) * units.PPM)
        want[f"D_O[{ch}]"] += k * truth.get(f"M_O[{ch}]", 0.0) * units.ARCSEC
        want[f"D_S[{ch}]"] += k * truth.get(f"M_S[{ch}]", 0.0) * units.ARCSEC
    return want


def mems_truth(seed: int = 42) -> dict:
    """Per-channel MEMS-sized errors: bias ~500 deg/h, g-sensitivity ~30 deg/h/g, SF ~1 %, misalignment ~3000″."""
    rng = np.random.default_rng(seed)
    out = {}
    for ch in "xyz":
        out.update(
            {
                f"D_F[{ch}]": rng.normal(0, 500),
                f"D_I[{ch}]": rng.normal(0, 30),
                f"D_O[{ch}]": rng.normal(0, 30),
                f"D_S[{ch}]": rng.normal(0, 30),
                f"E_SF[{ch}]": rng.normal(0, 1e4),
                f"M_O[{ch}]": rng.normal(0, 3000),
                f"M_S[{ch}]": rng.normal(0, 3000),
            }
        )
    return out


@dataclass(frozen=True)
class ChannelCoefficients:
    """The coefficients of a triad's three channels: the channel ``model`` and the names ``D_F[x]``, … channel by
    channel (the order of θ, 3p)."""

    model: object

    @property
    def coefficient_names(self) -> tuple:
        """``<coefficient>[<channel>]`` in θ order."""
        return tp.channel_names(self.model)

    @property
    def size(self) -> int:
        """3p."""
        return 3 * self.model.size


ANGLE_ERROR_OPTIONS = {"ferraris": ("angle_std_deg", 1.0), "protocol": ("placement_deg", math.sqrt(2.0))}
"""The option of a session that declares its known-angle turns' angle error, and the factor from it to that error's
σ (a hand turn back to a mark is known to √2 σ_placement): the noise-free session is simulated without the error,
each draw draws it (module doc)."""


def _simulate(study: Study, **site) -> Record:
    """The study's session simulated noise-free at θ = 0, its turns declaring their angle error (``site``: latitude
    and Earth-rate options over the study's)."""
    opts = {k: v for k, v in study.plan_options.items() if k not in ("acc_noise_g", "steps", "start_attitude")}
    option, factor = ANGLE_ERROR_OPTIONS.get(study.plan, ("", 0.0))
    angle_sd = factor * float(opts.pop(option, 0.0))
    opts.update(site, gyro_noise_dps=0.0, acc_noise_g=0.0)
    try:
        if study.plan == "ferraris":
            rec = simulate_ferraris({}, terms=study.terms, **opts)
        elif study.plan == "multiposition":
            rec = simulate_multiposition({}, terms=study.terms, **opts)
        else:
            steps, start = study.plan_options.get("steps"), study.plan_options.get("start_attitude")
            rec = simulate_session(steps, {}, start_attitude=start, terms=study.terms, heading_deg=0.0, **opts)
    except (TypeError, GyrojaxError) as e:
        raise StudyError(f"study: key 'plan_options': {e}") from None
    for seg in rec.meta["segments"]:
        if seg["type"] == "rotation":
            seg["angle_std_deg"] = angle_sd
    return rec


@dataclass
class TriadPipeline:
    """A triad study compiled to arrays (module doc); :meth:`draw` is pure JAX."""

    study: Study
    record: Record
    fit_model: ChannelCoefficients
    truth_model: ChannelCoefficients
    prior_uniform: np.ndarray
    prior_a: np.ndarray
    prior_b: np.ndarray
    arrays: dict
    compiled: dict = field(default_factory=dict, repr=False)

    fit_method = "gls-triad-known-noise"

    @property
    def draw_bytes(self) -> float:
        """Bytes of the arrays of one draw (for the chunk size)."""
        return 8.0 * self.arrays["w_off"].shape[0] * 3 * (6 + self.fit_model.size)

    def draw_truth(self, key):
        """A truth θ (3p of the truth model, report units) from the priors: uniform on [a, b] or normal N(a, b²)."""
        kz, ku = jax.random.split(key)
        p = self.truth_model.size
        a, b = jnp.asarray(self.prior_a), jnp.asarray(self.prior_b)
        return jnp.where(
            self.prior_uniform, a + (b - a) * jax.random.uniform(ku, (p,)), a + b * jax.random.normal(kz, (p,))
        )

    def simulate(self, key):
        """(θ_true, indicated rates (N, 3) deg/h, specific force (N, 3) g) of one draw (module doc)."""
        x = self.arrays
        kt, kh, kg, ka, ke = jax.random.split(key, 5)
        theta = self.draw_truth(kt)
        psi = 2.0 * jnp.pi * jax.random.uniform(kh)
        eps = x["turn_sd"] * jax.random.normal(ke, x["turn_sd"].shape)  # each turn's angle error / its angle
        motion = x["w_off"] * jnp.concatenate([1.0 + eps, jnp.ones(1)])[x["turn_of_row"]][:, None]
        horizontal = jnp.cos(psi) * x["north"] + jnp.sin(psi) * x["east"]
        w = motion + x["vertical"] * x["up"] + x["horizontal"] * horizontal
        model = self.truth_model.model
        ind = tp.triad_output(model, theta.reshape(3, model.size), w, x["a"], x["t_h"], x["temp"])
        ind = ind + x["gyro_sd"] * jax.random.normal(kg, w.shape)
        acc = x["a"] + x["acc_sd"] * jax.random.normal(ka, w.shape)
        return theta, ind, acc

    def solve(self, ind, acc):
        """The fit of a draw's samples (module doc): (θ̂, σ̂, rms of the whitened residuals)."""
        x = self.arrays
        model = self.fit_model.model
        k = x["seg_counts"].shape[0]
        y = jax.ops.segment_sum(ind[x["seg_rows"]], x["seg_of_row"], k) / x["seg_counts"][:, None]
        seg_w = x["seg_whiten"]  # (K, 3, 3) L⁻¹ of each segment mean's covariance
        has_moves = x["move_rows"].shape[0] > 0
        if has_moves:
            rest = jax.ops.segment_sum(acc[x["rest_rows"]], x["rest_of_row"], x["rest_counts"].shape[0])
            up = rest / jnp.linalg.norm(rest, axis=1, keepdims=True)
            u_from, u_to = up[x["move_from"]], up[x["move_to"]]
            g_mv, a_mv = ind[x["move_rows"]], acc[x["move_rows"]]
            e1 = jnp.cross(u_to, jnp.eye(3)[jnp.argmin(jnp.abs(u_to), axis=1)])
            e1 = e1 / jnp.linalg.norm(e1, axis=1, keepdims=True)
            basis = jnp.stack([e1, jnp.cross(u_to, e1)], axis=1)  # (M, 2, 3)

        def residuals(theta):
            means = segment_means(model, theta, x["seg_arrays"]).reshape(k, 3)
            r = jnp.einsum("kij,kj->ki", seg_w, y - means).ravel()
            if not has_moves:
                return r
            axes = (None, None) + (0,) * 8
            mv = jax.vmap(move_residual, in_axes=axes)(
                model, theta, g_mv, a_mv, x["move_t"], x["move_temp"], x["move_mask"], x["move_dt"], u_from, u_to
            )
            return jnp.concatenate([r, (jnp.einsum("mij,mj->mi", basis, mv) / x["move_sd"][:, None]).ravel()])

        def gauss_newton(theta, _):
            step, ninv = lstsq(jax.jacfwd(residuals)(theta), -residuals(theta), "cholesky")
            return theta + step, ninv

        theta, ninv = jax.lax.scan(gauss_newton, jnp.zeros(self.fit_model.size), None, length=GAUSS_NEWTON_STEPS)
        r = residuals(theta)
        return theta, jnp.sqrt(jnp.diag(ninv[-1])), jnp.sqrt(jnp.mean(r * r))

    def draw(self, index):
        """One draw by index: dict of truth (truth model θ), estimate, std (fit model) and the residual rms."""
        theta, ind, acc = self.simulate(jax.random.fold_in(jax.random.PRNGKey(self.study.seed), index))
        est, std, rms = self.solve(ind, acc)
        return {"truth": theta, "estimate": est, "std": std, "rms": rms}

    def draw_record(self, index: int) -> Record:
        """The session of draw ``index`` as an ``imu-triad`` record (gyro deg/s, accelerometer g), for
        :func:`gyrojax.inference.triad.fit_triad`."""
        _, ind, acc = jax.jit(self.simulate)(jax.random.fold_in(jax.random.PRNGKey(self.study.seed), index))
        cols = dict(self.record.columns)
        for j, ch in enumerate(tp.CHANNELS):
            cols[f"gyro_{ch}_dps"] = np.asarray(ind)[:, j] / units.SECONDS_PER_HOUR
            cols[f"acc_{ch}_g"] = np.asarray(acc)[:, j]
        return Record(dict(self.record.meta, name=f"{self.record.name}-draw-{index}"), cols)


def triad_names(terms) -> ChannelCoefficients:
    """The channel coefficients of ``terms`` (an ``imu-triad``'s effects; :class:`StudyError` otherwise)."""
    try:
        return ChannelCoefficients(tp.channel_model(terms))
    except GyrojaxError as e:
        raise StudyError(f"study: key 'terms': {e}") from None


def expand_prior_key(name: str, where: str) -> tuple[str, ...]:
    """Per-channel coefficient names of a triad prior key: ``D_F[x]`` itself, a coefficient ``D_F`` or an effect
    ``sf_error`` on every channel."""
    idx = fx.coefficient_index()
    base, channels = name, tp.CHANNELS
    if name.endswith("]"):
        try:
            base, ch = tp.split_channel_name(name)
        except GyrojaxError:
            raise StudyError(f"{where}: key {name!r} is not a per-channel coefficient such as 'D_F[x]'") from None
        channels = (ch,)
    if base in fx.names() and not name.endswith("]"):
        coeffs = fx.get(base).coefficients
    elif base in idx:
        coeffs = (base,)
    else:
        raise StudyError(f"{where}: key {name!r} is neither an effect, a coefficient nor a per-channel coefficient")
    return tuple(tp.channel_name(c, ch) for ch in channels for c in coeffs)


def build_triad_pipeline(study: Study) -> TriadPipeline:
    """Arrays of a triad study (module doc): the noise-free session, its segments and moves as the fit sees them,
    the prior vectors and the noise."""
    if study.plan not in SESSIONS:
        raise StudyError(f"study: key 'plan' = {study.plan!r}; an imu-triad study simulates {', '.join(SESSIONS)}")
    if study.setup:
        raise StudyError("study: key 'setup': an imu-triad has no turntable set-up errors")
    fit = triad_names(study.terms)
    priors = {}
    for name, v in study.priors.items():
        for c in expand_prior_key(name, f"study: key 'priors.{name}'"):
            priors[c] = parse_prior(v, f"study: key 'priors.{name}'")
    named = [fx.effect_of_coefficient(tp.split_channel_name(c)[0]) for c in priors]
    truth = triad_names(tuple(fit.model.terms) + tuple(dict.fromkeys(t for t in named if t not in fit.model.terms)))
    names = truth.coefficient_names
    uni = np.array([priors.get(c, (False, 0.0, 0.0))[0] for c in names])
    a = np.array([priors.get(c, (False, 0.0, 0.0))[1] for c in names])
    b = np.array([priors.get(c, (False, 0.0, 0.0))[2] for c in names])
    rec = _simulate(study)
    return TriadPipeline(study, rec, fit, truth, uni, a, b, _arrays(study, rec))


def _arrays(study: Study, rec: Record) -> dict:
    """The draw's arrays (module doc) of the session ``rec``."""
    noise = study.noise
    slow = [k for k in ("quantization", "bias_instability", "random_walk", "rate_ramp") if getattr(noise, k)]
    if slow or noise.gauss_markov or noise.ar or noise.ma:
        raise StudyError("study: key 'noise': an imu-triad study draws white gyro noise only ({'white': N})")
    gyro = np.column_stack([rec.columns[f"gyro_{c}_dps"] for c in tp.CHANNELS]) * units.SECONDS_PER_HOUR
    acc = np.column_stack([rec.columns[f"acc_{c}_g"] for c in tp.CHANNELS])
    t = np.asarray(rec.time_s, dtype=float)
    dt = float(np.median(np.diff(t)))
    site = rec.meta["site"]
    earth = bool(rec.meta.get("earth_rate", True))
    lat = study.plan_options.get("latitude_deg", LATITUDE) if study.plan != "ferraris" else None
    lat = study.plan_options.get("latitude_deg", LATITUDE) if lat is None else lat
    vertical = horizontal = 0.0
    w_off, north = gyro, np.zeros_like(gyro)
    if earth:  # the Earth rate of the session, split into the motion, Up and the body's North (module doc)
        w_off = _rates(_simulate(study, earth_rate=False))
        north = (_rates(_simulate(study, latitude_deg=0.0)) - w_off) / units.OMEGA_IE_DEG_PER_H
        phi = math.radians(lat if lat is not None else 0.0)
        vertical, horizontal = units.OMEGA_IE_DEG_PER_H * math.sin(phi), units.OMEGA_IE_DEG_PER_H * math.cos(phi)
    up = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    gyro_sd = 60.0 * noise.white / math.sqrt(dt)  # deg/h per sample (IEEE 952: σ = 60 N / √Δt)
    acc_sd = float(study.plan_options.get("acc_noise_g", 0.002))
    q = gyro_sd**2
    segments, _, _, moves = triad_segments(rec)
    rows = label_rows(np.asarray(rec.columns["segment"]))
    specs = [sp for sp in rec.meta["segments"] if sp["type"] != "move"]
    seg_rows = [rows(sp["label"]) for sp in specs]
    cov = np.array([q / s.n * np.eye(3) + s.extra for s in segments])
    rests = [sp["label"] for sp in specs if sp["type"] == "static"]
    rest_rows = [rows(lab) for lab in rests]
    turns = [sp for sp in specs if sp["type"] == "rotation"]
    turn_of_row = np.full(len(t), len(turns))
    for i, sp in enumerate(turns):
        turn_of_row[rows(sp["label"])] = i
    x = {
        "w_off": w_off,
        "north": north,
        "east": np.cross(north, up),
        "up": up,
        "vertical": vertical,
        "horizontal": horizontal,
        "a": acc,
        "t_h": t / units.SECONDS_PER_HOUR,
        "temp": np.full(len(t), 20.0),
        "gyro_sd": gyro_sd,
        "acc_sd": acc_sd,
        "seg_rows": np.concatenate(seg_rows),
        "seg_of_row": np.concatenate([np.full(len(r), i) for i, r in enumerate(seg_rows)]),
        "seg_counts": np.array([len(r) for r in seg_rows], dtype=float),
        "seg_arrays": pack_segments(segments),
        "seg_whiten": np.linalg.inv(np.linalg.cholesky(cov)),
        "rest_rows": np.concatenate(rest_rows),
        "rest_of_row": np.concatenate([np.full(len(r), i) for i, r in enumerate(rest_rows)]),
        "rest_counts": np.array([len(r) for r in rest_rows], dtype=float),
        "turn_of_row": turn_of_row,
        "turn_sd": np.array([sp.get("angle_std_deg", 0.0) / sp["angle_deg"] for sp in turns]),
        "move_rows": np.zeros((0, 2), dtype=int),
    }
    if moves:
        g_site = float(site["gravity_mps2"]) / units.G0
        mv_specs = [sp for sp in rec.meta["segments"] if sp["type"] == "move"]
        g, a, t_h, temp, mask, mdt, _, _ = pack_moves(moves)
        length = g.shape[1]
        mv_rows = []
        for m in moves:  # the record's rows of each move's samples, padded with the last (as pack_moves pads)
            r = np.searchsorted(t, m.t_h * units.SECONDS_PER_HOUR - 0.5 * dt)
            mv_rows.append(np.concatenate([r, np.full(length - len(r), r[-1])]))
        n_rest = {lab: len(rows(lab)) for lab in rests}
        var_dir = np.array([acc_sd**2 / g_site**2 * (1 / n_rest[sp["from"]] + 1 / n_rest[sp["to"]]) for sp in mv_specs])
        n = np.array([len(m.g) for m in moves], dtype=float)
        angle_var = q * n * np.asarray(mdt) ** 2 * units.DEG_PER_H**2
        x.update(
            move_rows=np.array(mv_rows),
            move_from=np.array([rests.index(sp["from"]) for sp in mv_specs]),
            move_to=np.array([rests.index(sp["to"]) for sp in mv_specs]),
            move_t=t_h,
            move_temp=temp,
            move_mask=mask,
            move_dt=mdt,
            move_sd=np.sqrt(angle_var + np.array([m.earth_var for m in moves]) + var_dir),
        )
    return x


def _rates(rec: Record) -> np.ndarray:
    """The gyro columns of a record, deg/h (n, 3)."""
    return np.column_stack([rec.columns[f"gyro_{c}_dps"] for c in tp.CHANNELS]) * units.SECONDS_PER_HOUR
