"""The rows of a triad fit as arrays: segment means and the moves' integrals, each in one jitted, vmapped pass.

:func:`gyrojax.inference.triad.fit_triad` evaluates two things of the channel model (:mod:`gyrojax.physics.triad`)
many times over:

* the **segment means** (3 per static pose or rotation, deg/h): one evaluation of the model over the samples of
  every segment concatenated, summed per segment (:func:`segment_means`); value and exact Jacobian (``jax.jacfwd``)
  come out of one compiled call, :func:`segment_rows`;
* the **gravity-to-gravity moves** (imu_tk, Tedaldi et al. 2014 §IV-C): the residual u_to − Rᵀ u_from of each move,
  R the product of the exact exponentials of each step's mean calibrated rate (:func:`move_residual`). Its exact
  Jacobian (:func:`move_rows`) is the first-order perturbation of that product, without a tangent through the
  product's scan: with P_k = E_1⋯E_k the prefix products, J_r the right Jacobian of SO(3) and y = Rᵀ u_from,

      ∂r/∂θ = −[y×] Rᵀ Σ_k P_k J_r(v_k) ∂v_k/∂θ,

  the step rotation vectors v_k being linear in the body rates, whose derivative is the implicit-function one of
  the channel model inverted (:func:`gyrojax.physics.triad.body_rates`): ∂ω/∂θ = −(∂f/∂ω)⁻¹ ∂f/∂θ at the solved ω.

Shapes are bucketed (:func:`bucket`: four lengths per octave; padded samples masked, padded moves and segments
dropped) so that sessions of similar size share one compiled function. Each pass of a built-in model is kept
across processes (:func:`gyrojax.physics.kept_model.kept_call`): a fresh process neither traces nor lowers it.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax import units
from gyrojax.physics import effects as fx
from gyrojax.physics import so3
from gyrojax.physics import triad as tp
from gyrojax.physics.kept_model import kept_call
from gyrojax.physics.model import indicated_output


def bucket(n: int) -> int:
    """The padded length of ``n`` items (dimensionless count): ``n`` rounded up to one of four lengths per octave
    (≤ 19 % padding), at least 1."""
    n = max(int(n), 1)
    if n <= 8:
        return n
    step = 1 << (int(math.log2(n)) - 2)
    return -(-n // step) * step


def linear_matrices(model, theta):
    """b (3,) deg/h, S (3, 3) and G (3, 3) deg/h/g of a linear channel model at θ (3p,), from the channel model
    itself (unit inputs through :func:`gyrojax.physics.triad.triad_output`), differentiable in θ."""
    th = theta.reshape(3, model.size)
    zero = jnp.zeros((3, 3))
    eye = jnp.eye(3)
    t, temp = jnp.zeros(3), jnp.full(3, 20.0)
    b = tp.triad_output(model, th, zero, zero, t, temp)[0]
    s = (tp.triad_output(model, th, eye, zero, t, temp) - b).T
    g = (tp.triad_output(model, th, zero, eye, t, temp) - b).T
    return b, s, g


linear_matrices_jit = jax.jit(linear_matrices, static_argnums=0)


def channel_matrices(model, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """b, S and G of :func:`linear_matrices` at θ as numpy arrays, compiled and kept."""
    th = np.asarray(theta, dtype=float)
    return tuple(
        np.asarray(m) for m in kept_call("triad_linear_matrices", linear_matrices, linear_matrices_jit, model, th)
    )


def scale_matrix(model, theta) -> np.ndarray:
    """S (3, 3) of the channel model at θ (:func:`linear_matrices`, compiled and kept)."""
    return channel_matrices(model, theta)[1]


# ---- segment means ---------------------------------------------------------------------------------------------


def segment_means(model, theta, arrays):
    """Model of the stacked segment means (3 per segment, deg/h) for θ (3p,).

    ``arrays`` = (w (N, 3) deg/h, a (N, 3) g, t_h (N,), temperature (N,) °C, segment index (N,), counts (m,)): the
    samples of every segment concatenated, so that one evaluation of the channel model serves them all (one small
    compiled graph, reused while the shapes stay)."""
    w, a, t, temp, idx, counts = arrays
    y = tp.triad_output(model, theta.reshape(3, model.size), w, a, t, temp)
    sums = jax.ops.segment_sum(y, idx, num_segments=counts.shape[0])
    return (sums / counts[:, None]).reshape(-1)


def pack_segments(segments, bucketed: bool = False) -> tuple:
    """The ``arrays`` of :func:`segment_means` from :class:`~gyrojax.data.triad_segments.TriadSegment` s; with
    ``bucketed`` the samples and segments padded to :func:`bucket` lengths (padding in a segment of its own, after
    the real ones, count 1)."""
    w = np.concatenate([s.w for s in segments])
    a = np.concatenate([s.a for s in segments])
    t = np.concatenate([s.t_h for s in segments])
    temp = np.concatenate([s.temp for s in segments])
    idx = np.concatenate([np.full(len(s.t_h), i) for i, s in enumerate(segments)])
    counts = np.array([len(s.t_h) for s in segments], dtype=float)
    if bucketed:
        n, m = len(t), len(segments)
        extra, m_pad = bucket(n) - n, bucket(m + 1)
        w, a = (np.concatenate([x, np.zeros((extra, 3))]) for x in (w, a))
        t, temp = np.concatenate([t, np.zeros(extra)]), np.concatenate([temp, np.full(extra, 20.0)])
        idx = np.concatenate([idx, np.full(extra, m_pad - 1)])
        counts = np.concatenate([counts, np.ones(m_pad - m)])
    return tuple(jax.device_put(x) for x in (w, a, t, temp, idx, counts))  # a copy to the device, no compiled op


def _means_twice(model, theta, arrays):
    y = segment_means(model, theta, arrays)
    return y, y


_segment_rows = jax.jacfwd(_means_twice, argnums=1, has_aux=True)
_segment_rows_jit = jax.jit(_segment_rows, static_argnums=0)


def segment_rows(model, theta, arrays, n_segments: int):
    """(model of the segment means (3m,) deg/h, its Jacobian (3m, 3p) in deg/h per report unit) at θ, one compiled
    call; ``arrays`` from :func:`pack_segments` (bucketed or not), ``n_segments`` = m real segments."""
    th = np.asarray(theta, dtype=float)
    jac, y = kept_call("triad_segment_rows", _segment_rows, _segment_rows_jit, model, th, arrays)
    k = 3 * n_segments
    return np.asarray(y)[:k], np.asarray(jac)[:k]


# ---- moves -----------------------------------------------------------------------------------------------------


def _inv3(m):
    """Inverses of 3×3 matrices (..., 3, 3) by the adjugate (cofactors over the determinant): a triad's S, or
    ∂f/∂ω per sample, is near the identity, so the closed form is as accurate as an LU and one fused pass."""
    c0 = jnp.cross(m[..., 1, :], m[..., 2, :])
    c1 = jnp.cross(m[..., 2, :], m[..., 0, :])
    c2 = jnp.cross(m[..., 0, :], m[..., 1, :])
    det = (m[..., 0, :] * c0).sum(axis=-1)
    return jnp.stack([c0, c1, c2], axis=-1) / det[..., None, None]


def move_residual(model, theta, g, a, t_h, temp, mask, dt, u_from, u_to):
    """Residual u_to − Rᵀ u_from of a gravity-to-gravity move: R is the body's rotation over the move, integrated
    from the calibrated rates ω of the whole channel model (:func:`gyrojax.physics.triad.body_rates`: bias, g-terms,
    scale factor and misalignment, E_A, E_2, trend and temperature at each sample; sample by sample, exact
    exponential of each step's mean rate); Up stays fixed in space, so the predicted Up at the end is Rᵀ u_from
    (imu_tk, Tedaldi et al. §IV-C). ``g`` (n, 3) deg/h, ``a`` (n, 3) g, ``t_h`` (n,) h, ``temp`` (n,) °C, ``dt`` s,
    unit vectors ``u_from``/``u_to``; the residual is dimensionless. ``mask`` (n−1,) is 1 for the steps of the move
    and 0 for padding (moves are padded to one length, one compile)."""
    w = tp.body_rates(model, theta.reshape(3, model.size), g, a, t_h, temp) * units.DEG_PER_H  # rad/s
    steps = 0.5 * (w[1:] + w[:-1]) * dt * mask[:, None]

    def step(r, v):
        return r @ so3.exp(v), None

    r, _ = jax.lax.scan(step, jnp.eye(3), steps)
    return u_to - r.T @ u_from


def _moves_residual(model, theta, g, a, t_h, temp, mask, dt, u_from, u_to):
    """:func:`move_residual` of every move at once (arrays of :func:`pack_moves`: gyro deg/h, specific force g,
    time h, temperature °C, dt s, Up directions unit vectors); (M, 3), dimensionless."""
    axes = (None, None) + (0,) * 8
    return jax.vmap(move_residual, in_axes=axes)(model, theta, g, a, t_h, temp, mask, dt, u_from, u_to)


moves_residual_jit = jax.jit(_moves_residual, static_argnums=0)
moves_jacobian_jit = jax.jit(jax.jacfwd(_moves_residual, argnums=1), static_argnums=0)


def _body_rates_jacobian(model, theta, g, a, t_h, temp):
    """Body rates ω (N, 3) deg/h of the samples and the parts of ∂ω/∂θ = −K ∂f/∂θ (implicit-function theorem at
    the solved ω, module doc): ∂f_c/∂θ_c (N, 3, p) of each channel at fixed ω by ``jax.jacfwd`` (channel c sees
    its own p coefficients only) and K = (∂f/∂ω)⁻¹: S⁻¹ (3, 3) for a model linear in the rate, else per sample
    (N, 3, 3)."""
    p = model.size
    th = theta.reshape(3, p)
    w = tp.body_rates(model, th, g, a, t_h, temp)

    def channel(c):
        def out(x):
            return indicated_output(model, x, tp.channel_inputs(w, a, t_h, temp, c), fx.SDF)

        return jax.jacfwd(out)(th[c])

    df = jnp.stack([channel(c) for c in range(3)], axis=1)
    if tp.rate_nonlinear(model):

        def out(ww):
            return tp.triad_output(model, th, ww, a, t_h, temp)

        cols = [jax.jvp(out, (w,), (jnp.zeros_like(w).at[:, j].set(1.0),))[1] for j in range(3)]
        return w, df, _inv3(jnp.stack(cols, axis=-1))  # ∂f/∂ω: (N, 3 outputs, 3 body axes)
    return w, df, _inv3(linear_matrices(model, theta)[1])


def _move_rows(model, theta, g, a, t_h, temp, mask, dt, u_from, u_to, basis, inv_sd):
    """(r (M, 3), whitened rows (M, 2), their Jacobian (M, 2, 3p)) of every move (module doc). The sum over the
    steps: v_k = c_k (ω_k + ω_k+1) and ∂ω_n/∂θ = −K_n ∂f_n/∂θ, so Σ_k P_k J_r(v_k) ∂v_k/∂θ = −Σ_k A_k (X_k + X_k+1)
    with A_k = c_k P_k J_r(v_k) and X_n = K_n ∂f_n/∂θ; one contraction over the steps and body axes per move."""
    m, length = g.shape[:2]
    p = model.size
    w, df, k_inv = _body_rates_jacobian(
        model, theta, g.reshape(-1, 3), a.reshape(-1, 3), t_h.reshape(-1), temp.reshape(-1)
    )
    scale = (0.5 * units.DEG_PER_H * dt)[:, None] * mask  # deg/h → rad over one step, 0 on padding
    w = w.reshape(m, length, 3)
    v = scale[:, :, None] * (w[:, 1:] + w[:, :-1])

    def step(r, ek):
        r = so3.compose(r, ek)
        return r, r

    rot, prefix = jax.lax.scan(step, jnp.broadcast_to(jnp.eye(3), (m, 3, 3)), jnp.swapaxes(so3.exp(v), 0, 1))
    a_k = so3.compose(jnp.swapaxes(prefix, 0, 1), so3.right_jacobian(v)) * scale[:, :, None, None]  # (M, L−1, 3, 3)
    k_n = k_inv if k_inv.ndim == 2 else k_inv.reshape(m, length, 3, 3)
    # X_n is block-diagonal in the channels (channel c sees its own p coefficients): X[n, j, c, q] = K[j, c] ∂f_c/∂θ_cq
    x = (k_n[..., :, :, None] * df.reshape(m, length, 1, 3, p)).reshape(m, length, 3, 3 * p)
    gsum = jnp.einsum("mkij,mkjq->miq", a_k, x[:, 1:] + x[:, :-1])  # (M, 3, 3p)
    y = jnp.einsum("mji,mj->mi", rot, u_from)
    r = u_to - y
    jf = -jnp.einsum("mij,mkj,mkq->miq", so3.hat(y), rot, gsum)  # −[y×] Rᵀ Σ: −∂r/∂θ, the Jacobian of "y − f"
    rows = jnp.einsum("mia,mi->ma", basis, r) * inv_sd[:, None]
    jac = jnp.einsum("mia,mip->map", basis, jf) * inv_sd[:, None, None]
    return r, rows, jac


_move_rows_jit = jax.jit(_move_rows, static_argnums=0)


def move_rows(model, theta, packed, whitening):
    """Per move at θ: the residual r (M, 3) (dimensionless), the whitened rows (2M,) P_kᵀ r_k / σ_k and their
    Jacobian (2M, 3p) (rows of "y − f": ∂f/∂θ = −∂r/∂θ), one compiled call. ``packed`` from :func:`pack_moves`
    (bucketed or not), ``whitening`` the list of (P (3, 2), σ rad) of
    :func:`gyrojax.inference.triad.move_whitening`."""
    m, m_pad = len(whitening), packed[0].shape[0]
    basis = np.zeros((m_pad, 3, 2))
    inv_sd = np.zeros(m_pad)
    basis[:m] = [p for p, _ in whitening]
    inv_sd[:m] = [1.0 / sd for _, sd in whitening]
    # numpy arguments go to the compiled call as they are (jnp.asarray would dispatch a conversion op each)
    th = np.asarray(theta, dtype=float)
    r, rows, jac = kept_call("triad_move_rows", _move_rows, _move_rows_jit, model, th, *packed, basis, inv_sd)
    return np.asarray(r)[:m], np.asarray(rows)[:m].reshape(-1), np.asarray(jac)[:m].reshape(2 * m, -1)


def pack_moves(moves, bucketed: bool = False) -> tuple:
    """The moves padded to one length: (g (M, L, 3), a (M, L, 3), t_h (M, L), temp (M, L), mask (M, L−1), dt (M,),
    u_from (M, 3), u_to); a move without times or temperatures gets 0 h and 20 °C. With ``bucketed`` the steps
    and the number of moves are padded to :func:`bucket` lengths (padded moves: mask 0, Up e_z to e_z)."""
    steps = max(len(m.g) for m in moves) - 1
    n_mv = len(moves)
    if bucketed:
        steps, n_mv = bucket(steps), bucket(n_mv)
    length = steps + 1
    g = np.zeros((n_mv, length, 3))
    a = np.zeros((n_mv, length, 3))
    t_h = np.zeros((n_mv, length))
    temp = np.full((n_mv, length), 20.0)
    mask = np.zeros((n_mv, length - 1))
    dt = np.ones(n_mv)
    u0 = np.tile([0.0, 0.0, 1.0], (n_mv, 1))
    u1 = u0.copy()
    for i, m in enumerate(moves):
        n = len(m.g)
        g[i, :n], a[i, :n] = m.g, m.a
        g[i, n:], a[i, n:] = m.g[-1], m.a[-1]
        if m.t_h is not None:
            t_h[i, :n], t_h[i, n:] = m.t_h, m.t_h[-1]
        if m.temp is not None:
            temp[i, :n], temp[i, n:] = m.temp, m.temp[-1]
        mask[i, : n - 1] = 1.0
        dt[i], u0[i], u1[i] = m.dt, m.u_from, m.u_to
    return tuple(jax.device_put(x) for x in (g, a, t_h, temp, mask, dt, u0, u1))
