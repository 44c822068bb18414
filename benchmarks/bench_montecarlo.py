"""Monte Carlo throughput: simulated 24-position campaigns, each with its own set-up errors, fitted by the 9-term
SDF drift model — the JAX pipeline of :mod:`gyrojax.montecarlo` against a plain numpy implementation of the same work.

    python -m benchmarks.bench_montecarlo                 # 10,000 draws + a 20,000-draw scale run
    python -m benchmarks.bench_montecarlo --scale-draws 1000000

The numpy reference is vectorised within a draw (all samples at once: rotation matrices, regressors) and loops
over draws in Python, solving with ``numpy.linalg.lstsq``. Both compute, per draw: truth coefficients and set-up
errors (table tilt, azimuth, encoder harmonics) from their priors, the read encoder angles, the measurements
through the perturbed kinematics plus white noise, the regressors on the read angles with nominal set-up, and the
least-squares estimate with its σ̂. Also reported: the per-draw cost over the time numpy takes only to draw that
draw's normal variates (the floor of any Monte Carlo of this size), and peak memory (``ru_maxrss``) of a long,
chunked run.

The plan is static, so the pipeline reduces each draw to per-position sums of the per-sample noise
(:func:`gyrojax.montecarlo.pipeline.constant_runs`; the same estimates to rounding). The sample-level JAX path, which
evaluates the kinematics and regressors at every sample as numpy does, is timed beside it for comparison.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time

import numpy as np


def _devices_from_argv() -> int:
    """``--devices N`` (default: every core) must reach XLA before jax is imported."""
    n = os.cpu_count() or 1
    if "--devices" in sys.argv:
        n = int(sys.argv[sys.argv.index("--devices") + 1])
    return n


if "jax" not in sys.modules:
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={_devices_from_argv()}"
    ).strip()

from benchmarks.timing import compile_here  # noqa: E402
from gyrojax import units  # noqa: E402
from gyrojax.montecarlo import pipeline, runner  # noqa: E402
from gyrojax.montecarlo import study as mc  # noqa: E402

NINE = list(mc.SDF_NINE_TERMS)


def study(draws: int, minutes: float = 10.0, dt_s: float = 1.0) -> mc.Study:
    return mc.Study(
        plan="multiposition",
        plan_options={"n": 24, "minutes": minutes, "dt_s": dt_s},
        terms=NINE,
        priors={c: {"normal": [0.0, 0.5]} for c in NINE},
        setup={
            "table_tilt": {"normal": [0.0, 10.0]},
            "table_azimuth": {"normal": [0.0, 10.0]},
            "encoder_harmonic": {"normal": [0.0, 3.0]},
        },
        noise={"white": 0.01},
        draws=draws,
        seed=0,
    )


# ---- the numpy reference -------------------------------------------------------------------------------------------


def _rotate(u, c, s, v):
    """R(u, θ) v for every sample (Rodrigues on (3, n) arrays): v cos θ + (u × v) sin θ + u (u·v)(1 − cos θ)."""
    return v * c + np.cross(u, v, axis=0) * s + u[:, None] * (u @ v) * (1 - c)


class NumpyMC:
    """The same per-draw work as the JAX pipeline in numpy, vectorised over samples (one record, two-axis table)."""

    def __init__(self, pipe: pipeline.Pipeline):
        d = pipe.data[0]
        self.axes = np.asarray(d.axes)
        self.triad = np.asarray(d.triad)
        self.ang = np.asarray(d.angles)
        self.rates = np.asarray(d.rates)
        lat = float(d.latitude)
        self.omega = units.OMEGA_IE * np.array([0.0, np.cos(lat), np.sin(lat)])
        self.f = np.array([0.0, 0.0, float(d.gravity)])
        self.e = d.encoder_axis
        self.sig = pipe.noise.white * 60.0 / np.sqrt(pipe.dt_white[0])
        self.m = self.ang.shape[0]

    @staticmethod
    def _h(enc, a):
        return enc[0] * np.cos(a) + enc[1] * np.sin(a) + enc[2] * np.cos(2 * a) + enc[3] * np.sin(2 * a)

    def inputs(self, ang, delta):
        """Rate (deg/h) and specific force (g) along IA, OA, SA, (n, 3) each, vectorised over samples."""
        b = np.eye(3) + np.array([[0, -delta[2], delta[1]], [delta[2], 0, -delta[0]], [-delta[1], delta[0], 0]])
        u1, u2 = self.axes
        c1, s1, c2, s2 = np.cos(ang[:, 0]), np.sin(ang[:, 0]), np.cos(ang[:, 1]), np.sin(ang[:, 1])
        n = len(c1)
        w_lp = self.rates[:, 0] * u1[:, None] + self.rates[:, 1] * _rotate(u1, c1, s1, np.repeat(u2[:, None], n, 1))
        w = b.T @ (self.omega[:, None] + b @ w_lp)  # Cᵀ = R2ᵀ R1ᵀ Bᵀ
        f = np.repeat((b.T @ self.f)[:, None], n, 1)
        w, f = _rotate(u1, c1, -s1, w), _rotate(u1, c1, -s1, f)
        w, f = _rotate(u2, c2, -s2, w), _rotate(u2, c2, -s2, f)
        return (self.triad @ w).T / units.DEG_PER_H, (self.triad @ f).T / units.G0

    @staticmethod
    def regressors(a):
        ai, ao, as_ = a[:, 0], a[:, 1], a[:, 2]
        return np.column_stack([np.ones_like(ai), ai, ao, as_, ai * ai, as_ * as_, ai * ao, ai * as_, ao * as_])

    def draw(self, rng):
        theta = rng.normal(0.0, 0.5, 9)
        delta = rng.normal(0.0, 10.0, 3) * units.ARCSEC
        enc = rng.normal(0.0, 3.0, 4) * units.ARCSEC
        read = self.ang.copy()
        read[:, self.e] += self._h(enc, self.ang[:, self.e])
        true = read.copy()
        true[:, self.e] -= self._h(enc, read[:, self.e])
        w, a = self.inputs(true, delta)
        y = w[:, 0] + self.regressors(a) @ theta + self.sig * rng.standard_normal(self.m)
        w0, a0 = self.inputs(read, np.zeros(3))
        j = self.regressors(a0)
        est, res, *_ = np.linalg.lstsq(j, y - w0[:, 0], rcond=None)
        s2 = float(res[0]) / (self.m - 9)
        std = np.sqrt(s2 * np.diag(np.linalg.inv(j.T @ j)))
        return theta, est, std


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=10_000)
    ap.add_argument("--numpy-draws", type=int, default=300)
    ap.add_argument("--scale-draws", type=int, default=20_000, help="draws of the chunked scale run (1e6: long)")
    ap.add_argument("--chunk", type=int, default=None)
    ap.add_argument("--devices", type=int, default=None, help="CPU devices (default: every core)")
    args = ap.parse_args(argv)
    import jax

    st = study(args.draws)
    t = time.perf_counter()
    pipe = pipeline.build_pipeline(st)
    print(
        f"plan: 24 positions x 10 min at 1 Hz = {pipe.n_measurements} samples/draw; 9-term fit; "
        f"set-up errors drawn per draw (built in {time.perf_counter() - t:.1f} s)"
    )

    ndev = len(jax.devices())
    res1 = runner.run_study(st, pipeline=pipe, chunk=args.chunk, devices=jax.devices()[:1])
    print(
        f"JAX, 1 device : {len(res1.draw)} draws in {res1.run_s:.2f} s = {len(res1.draw) / res1.run_s:,.0f} draws/s "
        f"(compile {res1.compile_s:.1f} s apart)"
    )
    res = runner.run_study(st, pipeline=pipe, chunk=args.chunk)
    jax_rate = len(res.draw) / res.run_s
    print(
        f"JAX, {ndev} devices: {len(res.draw)} draws in {res.run_s:.2f} s = {jax_rate:,.0f} draws/s "
        f"(compile {res.compile_s:.1f} s apart; one CPU device per core)"
    )
    assert np.allclose(res.estimate, res1.estimate, rtol=1e-12, atol=1e-15)
    from dataclasses import replace

    sample_pipe = replace(pipe, runs=None, compiled={})
    n_s = min(len(res.draw), 2000)
    res_s = runner.run_study(st, pipeline=sample_pipe, draws=n_s, chunk=args.chunk)
    sample_rate = n_s / res_s.run_s
    print(
        f"JAX, sample-level path (no per-position reduction), {ndev} devices: {sample_rate:,.0f} draws/s "
        f"(compile {res_s.compile_s:.1f} s apart); max |Δθ̂| vs reduced "
        f"{np.abs(res_s.estimate - res.estimate[:n_s]).max():.1e}"
    )

    ref = NumpyMC(pipe)
    rng = np.random.default_rng(1)
    ref.draw(rng)
    t = time.perf_counter()
    errs = []
    for _ in range(args.numpy_draws):
        th, est, std = ref.draw(rng)
        errs.append((est - th) / std)
    np_s = (time.perf_counter() - t) / args.numpy_draws
    print(f"numpy : {1 / np_s:,.0f} draws/s ({np_s * 1e3:.2f} ms/draw over {args.numpy_draws} draws)")
    print(
        f"ratio JAX/numpy throughput: {jax_rate * np_s:.1f}x on {ndev} devices, "
        f"{len(res1.draw) / res1.run_s * np_s:.1f}x on 1 (target >= 10x; numpy is single-threaded); "
        f"sample-level JAX path {sample_rate * np_s:.1f}x"
    )

    t = time.perf_counter()
    for _ in range(200):
        rng.standard_normal(pipe.n_measurements)
    normals_s = (time.perf_counter() - t) / 200
    per_draw = 1.0 / jax_rate
    per1 = res1.run_s / len(res1.draw)
    print(
        f"numpy normal variates of one draw: {normals_s * 1e3:.3f} ms; JAX per-draw wall cost {per_draw * 1e3:.3f} ms "
        f"= {per_draw / normals_s:.2f}x that on {ndev} devices, {per1 / normals_s:.2f}x on 1 (target <= 2.5x); "
        f"sample-level path {1 / sample_rate / normals_s:.2f}x"
    )

    # both implementations agree statistically (and the regressors exactly)
    zj = (res.estimate - res.truth_of_fit()) / res.std
    zn = np.array(errs)
    print(
        f"check: fraction |z|<=2  JAX {np.mean(np.abs(zj) <= 2):.4f}  numpy {np.mean(np.abs(zn) <= 2):.4f} "
        f"(0.9545 expected)"
    )
    import jax.numpy as jnp

    from gyrojax.physics.model import jacobian_jit

    jx = np.asarray(jacobian_jit(pipe.fit_model, jnp.zeros(9), pipe.data[0]))
    _, a0 = ref.inputs(ref.ang, np.zeros(3))
    print(f"check: max |J_jax - J_numpy| = {np.abs(jx - ref.regressors(a0)).max():.2e} (nominal angles)")

    # scale run: chunked, memory bounded
    if args.scale_draws:
        big = study(args.scale_draws)
        chunk = args.chunk or runner.auto_chunk(pipe, len(jax.devices()))
        t = time.perf_counter()
        r2 = runner.run_study(big, pipeline=pipe, chunk=chunk, progress=True)
        peak_gb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
        print(
            f"scale : {len(r2.draw):,} draws in {time.perf_counter() - t:.1f} s "
            f"({len(r2.draw) / r2.run_s:,.0f} draws/s), chunk {chunk}, peak RSS {peak_gb:.2f} GB (limit 8 GB); "
            f"results {r2.estimate.nbytes * 3 / 1e6:.0f} MB"
        )


if __name__ == "__main__":
    compile_here()
    main()
