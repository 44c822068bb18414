"""Speed of the table-servo loop: a 24 h servo test at a 1 kHz loop rate for a batch of 16 gyros.

The loop is ``gyrojax.dynamics.loops.servo_state_space`` (5 states, 3 inputs: base rate, gyro torque-equivalent rate,
table disturbance torque), discretised once per gyro with the exact ZOH. Inputs: Earth rate along a polar axis,
a constant drift plus white rate noise, and M_DC + G·m·cos φ·sin θ_nom + white torque noise (Hu 5-36/5-37) with
the unbalance taken at the nominal table angle (linear time-invariant loop, so every implementation steps the
very same recursion x[k+1] = A_d x[k] + B_d u[k], y = C x). The table angle is kept at 10 Hz, as a recorder
would.

Implementations timed on the same input chunk: JAX ``lax.scan`` one step per iteration, JAX lifted scan
(``loops.lifted_dlsim``: 32 steps per iteration as batched matrix products), ``scipy.signal.dlsim`` (one gyro
at a time), numba (compiled step loop, if installed). The full 24 h is run with the fastest JAX form, in chunks
with inputs generated on the fly; scipy is run on a shorter span and extrapolated (it says so).

Run from the repo root:  python -m benchmarks.bench_loops  [--hours 24] [--chunk-s 300]
"""

from __future__ import annotations

import argparse
import math
import time

import jax
import jax.numpy as jnp
import numpy as np
import scipy.signal as sig

from benchmarks.timing import compile_here
from gyrojax import units
from gyrojax.dynamics import loops
from gyrojax.dynamics.discretize import zoh

DT = 1e-3
N_GYRO = 16
DECIM = 100  # keep the angle at 10 Hz
BLOCK = 32


def batch_params(n=N_GYRO):
    rng = np.random.default_rng(0)
    base = loops.default_servo(G_m=0.5, phi_axis=math.radians(40.0))
    return jax.tree_util.tree_map(lambda v: jnp.asarray(v * (1 + 0.02 * rng.standard_normal(n))), base)


def discretised(params):
    def one(p):
        a, b, c, d = loops.servo_state_space(p)
        ad, bd, c, d = zoh(a, b, c, d, DT)
        return ad, bd, c[:1], d[:1]

    return jax.jit(jax.vmap(one))(params)


def make_inputs(params, key, k0, n):
    """(n_gyro, n, 3) inputs for steps k0 .. k0+n−1 (deg/h, deg/h, N·m)."""
    lat = math.radians(40.0)
    w_ib = units.OMEGA_IE_DEG_PER_H  # polar axis: the full Earth rate
    drift = 0.01 + 0.002 * jnp.arange(N_GYRO)
    k1, k2 = jax.random.split(key)
    t = (k0 + jnp.arange(n)) * DT
    theta_nom = -(w_ib + drift[:, None]) * units.DEG_PER_H * t[None, :]
    arw = 0.001 * 60.0 / jnp.sqrt(DT)  # 0.001 deg/√h
    u_g = drift[:, None] + arw * jax.random.normal(k1, (N_GYRO, n))
    m = 0.02 + params.G_m[:, None] * math.cos(lat) * jnp.sin(theta_nom) + 1e-3 * jax.random.normal(k2, (N_GYRO, n))
    return jnp.stack([jnp.full((N_GYRO, n), w_ib), u_g, m], axis=-1)


make_inputs_jit = jax.jit(make_inputs, static_argnums=(3,))


@jax.jit
def run_scan(ad, bd, c, d, x0, u):
    def one(ad, bd, c, d, x0, u):
        def step(x, uk):
            return ad @ x + bd @ uk, (c @ x + d @ uk)[0]

        xf, y = jax.lax.scan(step, x0, u, unroll=8)
        return y[::DECIM], xf

    return jax.vmap(one)(ad, bd, c, d, x0, u)


@jax.jit
def run_lifted(ad, bd, c, d, x0, u):
    def one(ad, bd, c, d, x0, u):
        y, xf = loops.lifted_dlsim(ad, bd, c, d, u, x0, block=BLOCK)
        return y[::DECIM, 0], xf

    return jax.vmap(one)(ad, bd, c, d, x0, u)


def numba_runner():
    try:
        import numba
    except ImportError:
        return None

    @numba.njit(cache=False)
    def run(ad, bd, c, d, x0, u, decim):
        ng, n, m = u.shape
        nx = ad.shape[1]
        out = np.empty((ng, n // decim))
        xf = np.empty((ng, nx))
        x = np.empty(nx)
        xn = np.empty(nx)
        for g in range(ng):
            for i in range(nx):
                x[i] = x0[g, i]
            for k in range(n):
                if k % decim == 0:
                    y = 0.0
                    for i in range(nx):
                        y += c[g, 0, i] * x[i]
                    for j in range(m):
                        y += d[g, 0, j] * u[g, k, j]
                    out[g, k // decim] = y
                for i in range(nx):
                    s = 0.0
                    for j in range(nx):
                        s += ad[g, i, j] * x[j]
                    for j in range(m):
                        s += bd[g, i, j] * u[g, k, j]
                    xn[i] = s
                for i in range(nx):
                    x[i] = xn[i]
            for i in range(nx):
                xf[g, i] = x[i]
        return out, xf

    return run


def timed(f, *a, reps=2):
    best = math.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        r = f(*a)
        jax.block_until_ready(r)
        best = min(best, time.perf_counter() - t0)
    return best, r


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=24.0, help="simulated span for the full JAX run (h)")
    ap.add_argument("--chunk-s", type=float, default=288.0, help="chunk length (s) for the long run and the race")
    ap.add_argument("--scipy-s", type=float, default=20.0, help="span given to scipy.signal.dlsim (s)")
    args = ap.parse_args(argv)

    params = batch_params()
    ad, bd, c, d = discretised(params)
    n_chunk = int(round(args.chunk_s / DT)) // (BLOCK * DECIM) * (BLOCK * DECIM)
    key = jax.random.PRNGKey(0)
    u = make_inputs_jit(params, key, 0, n_chunk)
    x0 = jnp.zeros((N_GYRO, 5))
    steps = N_GYRO * n_chunk
    rows = []

    t0 = time.perf_counter()
    jax.block_until_ready(run_scan(ad, bd, c, d, x0, u))
    c_scan = time.perf_counter() - t0
    t_scan, (y_scan, _) = timed(run_scan, ad, bd, c, d, x0, u)
    rows.append(("JAX lax.scan, 1 step/iter", c_scan, steps / t_scan))

    t0 = time.perf_counter()
    jax.block_until_ready(run_lifted(ad, bd, c, d, x0, u))
    c_lift = time.perf_counter() - t0
    t_lift, (y_lift, _) = timed(run_lifted, ad, bd, c, d, x0, u)
    rows.append((f"JAX lifted scan, {BLOCK} steps/iter", c_lift, steps / t_lift))
    agree = float(jnp.max(jnp.abs(y_lift - y_scan)) / jnp.max(jnp.abs(y_scan)))

    # scipy.signal.dlsim on a shorter span, one gyro at a time (it has no batch axis)
    n_sp = int(args.scipy_s / DT) // DECIM * DECIM
    un = np.asarray(u[:, :n_sp])
    adn, bdn, cn, dn = (np.asarray(v) for v in (ad, bd, c, d))
    t0 = time.perf_counter()
    y_sp = [sig.dlsim((adn[g], bdn[g], cn[g], dn[g], DT), un[g])[1][::DECIM, 0] for g in range(N_GYRO)]
    t_sp = time.perf_counter() - t0
    rows.append((f"scipy.signal.dlsim ({args.scipy_s:g} s span)", 0.0, N_GYRO * n_sp / t_sp))
    agree_sp = float(np.max(np.abs(np.array(y_sp) - np.asarray(y_scan)[:, : n_sp // DECIM])))

    nb = numba_runner()
    if nb is not None:
        un_full = np.asarray(u)
        x0n = np.zeros((N_GYRO, 5))
        t0 = time.perf_counter()
        nb(adn, bdn, cn, dn, x0n, un_full[:, : BLOCK * DECIM], DECIM)
        c_nb = time.perf_counter() - t0
        t_nb, (y_nb, _) = timed(nb, adn, bdn, cn, dn, x0n, un_full, DECIM)
        rows.append(("numba njit step loop", c_nb, steps / t_nb))
        agree_nb = float(np.max(np.abs(y_nb - np.asarray(y_scan))) / np.max(np.abs(np.asarray(y_scan))))
    else:
        t_nb = None

    # the full span with the faster JAX form, inputs generated on the fly chunk by chunk
    runner = run_lifted if t_lift <= t_scan else run_scan
    n_total = int(args.hours * 3600 / DT)
    n_chunks = max(1, n_total // n_chunk)
    x = x0
    t_in = t_loop = 0.0
    for i in range(n_chunks):
        t0 = time.perf_counter()
        ui = jax.block_until_ready(make_inputs_jit(params, jax.random.fold_in(key, i), i * n_chunk, n_chunk))
        t1 = time.perf_counter()
        y, x = jax.block_until_ready(runner(ad, bd, c, d, x, ui))
        t_in, t_loop = t_in + t1 - t0, t_loop + time.perf_counter() - t1
    t_full = t_in + t_loop
    span_h = n_chunks * n_chunk * DT / 3600

    best_jax = max(r[2] for r in rows[:2])
    print(f"\nTable-servo loop, 5 states, {N_GYRO} gyros, dt = {DT * 1e3:g} ms, chunk {n_chunk * DT:g} s")
    print(f"{'implementation':42s} {'compile s':>10s} {'M gyro-steps/s':>15s} {'JAX best / it':>14s}")
    for name, comp, rate in rows:
        print(f"{name:42s} {comp:10.2f} {rate / 1e6:15.2f} {best_jax / rate:14.2f}")
    print(f"\nlifted vs step scan, max relative difference of the angle: {agree:.1e}")
    print(f"scipy vs step scan, max abs difference of the angle: {agree_sp:.1e} rad")
    if t_nb is not None:
        print(f"numba vs step scan, max relative difference of the angle: {agree_nb:.1e}")
    else:
        print("numba not installed: `pip install numba` to add the compiled baseline")
    print(
        f"\nfull run: {span_h:g} h × {N_GYRO} gyros = {N_GYRO * n_chunks * n_chunk / 1e9:.2f} G gyro-steps in "
        f"{t_full:.1f} s with the {'lifted' if runner is run_lifted else 'step'} scan: loop {t_loop:.1f} s "
        f"({N_GYRO * n_chunks * n_chunk / t_loop / 1e6:.1f} M gyro-steps/s), input generation {t_in:.1f} s "
        f"(random normals and sines; {N_GYRO * n_chunks * n_chunk / t_full / 1e6:.1f} M gyro-steps/s end to end)"
    )
    if span_h < 24:
        print(f"  extrapolated to 24 h: {t_full * 24 / span_h:.0f} s")
    sp_rate = rows[2][2]
    print(f"  scipy.signal.dlsim would need ≈ {N_GYRO * 86_400_000 / sp_rate / 3600:.1f} h for 24 h (extrapolated)")
    print(f"\nratio JAX / scipy.dlsim: {best_jax / sp_rate:.0f}×  (target ≥ 100×)")
    if t_nb is not None:
        print(f"ratio JAX / numba:       {best_jax / rows[-1][2]:.2f}×  (target ≥ 0.5×)")


if __name__ == "__main__":
    compile_here()
    main()
