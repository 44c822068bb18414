"""Simulation speed: a 24 h, 1 Hz polar servo record and a 2 × 2-revolution tumble (flipped, CW/CCW).

Reports compile (first call) and run (second call, same shapes) times apart, against a plain numpy/scipy baseline of
the same work: the servo ODE integrated by fixed-step RK4 in a numpy loop (as gyrojax's scan does) and the
tumble's indicated rate computed in a numpy loop with scipy rotations.
Run: python -m benchmarks.bench_simulate
"""

import time

import numpy as np
from scipy.spatial.transform import Rotation

from benchmarks.timing import compile_here
from gyrojax import simulate, units
from gyrojax.data import plans

TRUTH = {"coefficients": {"D_F": 0.4, "D_I": 0.6, "D_S": -0.3, "D_IS": 0.05}, "noise": {"white": 0.001}}


def timed(f):
    t = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t


def numpy_servo(hours=2.0, lat=39.98):
    """Polar servo, IA on the axis: θ̇ = −Ω·IA − drift(θ) (Hu 3-59), fixed-step RK4 at 1 Hz in a numpy loop —
    the same work as gyrojax's scan."""
    p = np.deg2rad(lat)
    axis = np.array([0, np.cos(p), np.sin(p)])
    omega = units.OMEGA_IE * axis
    ia, oa = axis, np.array([1.0, 0, 0])
    sa = np.cross(ia, oa)
    g = np.array([0, 0, 9.80155])
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])

    def rhs(th):
        c = np.eye(3) + np.sin(th) * k + (1 - np.cos(th)) * (k @ k)
        a = c.T @ g / units.G0
        ai, as_ = a @ ia, a @ sa
        d = 0.4 + 0.6 * ai - 0.3 * as_ + 0.05 * ai * as_
        return -(omega @ ia) - d * units.DEG_PER_H

    th, out = 0.0, []
    for _ in range(int(hours * 3600)):
        k1 = rhs(th)
        k2 = rhs(th + 0.5 * k1)
        k3 = rhs(th + 0.5 * k2)
        k4 = rhs(th + k3)
        th += (k1 + 2 * k2 + 2 * k3 + k4) / 6
        out.append(th)
    return np.array(out)


def numpy_tumble(plan):
    out = []
    for run in plan.runs:
        u = np.asarray(run.axes[0][1])
        seg = run.segments[0]
        t, ang, rate = seg.samples()
        ia = np.asarray(run.instrument["ia"])
        for th, r in zip(np.deg2rad(ang[:, 0]), np.deg2rad(rate[:, 0])):
            c = Rotation.from_rotvec(u * th).as_matrix()
            out.append(ia @ (c.T @ (r * u)))
    return out


def main():
    servo = plans.servo("polar", hours=24.0, dt_s=1.0)
    _, c1 = timed(lambda: simulate(servo, TRUTH, seed=0))
    _, r1 = timed(lambda: simulate(servo, TRUTH, seed=1))
    _, n1 = timed(lambda: numpy_servo(2.0))
    n1 *= 12  # 2 h measured, scaled to 24 h
    tumble = plans.tumble(revolutions=2.0, dt_s=2.0)
    _, c2 = timed(lambda: simulate(tumble, TRUTH, seed=0))
    _, r2 = timed(lambda: simulate(tumble, TRUTH, seed=1))
    _, n2 = timed(lambda: numpy_tumble(tumble))
    print(f"{'case':34s} {'first call (s)':>15s} {'run (s)':>9s} {'numpy/scipy (s)':>16s} {'ratio':>7s}")
    print(f"{'24 h polar servo, 1 Hz (86400)':34s} {c1:15.2f} {r1:9.2f} {n1:16.2f} {n1 / r1:7.1f}x")
    n_t = sum(len(r.segments[0].samples()[0]) for r in tumble.runs)
    print(f"{f'tumble 4 × 2 rev ({n_t} samples)':34s} {c2:15.2f} {r2:9.2f} {n2:16.2f} {n2 / r2:7.1f}x")
    print("(first call includes compilation; the run column is the target < 2 s; numpy servo extrapolated from 2 h)")


if __name__ == "__main__":
    compile_here()
    main()
