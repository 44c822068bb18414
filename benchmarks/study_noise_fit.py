"""Monte Carlo spread of the IEEE 952 noise fit: the numbers quoted in tests/test_allan.py.

Campaigns of ``n_records`` 10-h, 1 Hz records with N = 0.001 deg/√h, B = 0.05 deg/h (flicker band 1 s to
1e5 s) and K = 0.5 deg/h/√h, pooled and fitted by ``allan.analyze``; prints mean, sd and worst relative error of
N, B, K over ``campaigns`` seeds, and how often each falls outside ±10 %.
Run: PYTHONPATH=. python benchmarks/study_noise_fit.py [campaigns] [n_records]
"""

import sys

import jax
import jax.numpy as jnp
import numpy as np

from gyrojax.noise import allan
from gyrojax.noise import processes as noise

N0, B0, K0, n = 0.001, 0.05, 0.5, 36000
steps = jnp.ones(n)


@jax.jit
def record(key):
    k = jax.random.split(key, 3)
    return (
        noise.white(k[0], n, 1.0, N0)
        + noise.bias_instability(k[1], steps, B0, 1.0, 1e5)
        + noise.random_walk(k[2], steps, K0)
    )


def main(campaigns=25, n_records=3):
    est = []
    for c in range(campaigns):
        recs = [np.asarray(record(jax.random.PRNGKey(1000 * c + j))) for j in range(n_records)]
        _, fit = allan.analyze(recs, 1.0)
        est.append([getattr(fit, k) for k in ("white", "bias_instability", "random_walk")])
    rel = np.array(est) / np.array([N0, B0, K0])
    for i, name in enumerate(("white N", "bias_instability B", "random_walk K")):
        r = rel[:, i]
        print(
            f"{name:20s} mean {r.mean():.4f}  sd {r.std(ddof=1):.4f}  worst |err| {np.abs(r - 1).max():.3f}  "
            f"outside ±10 %: {(np.abs(r - 1) > 0.1).sum()}/{campaigns}"
        )


if __name__ == "__main__":
    a = [int(v) for v in sys.argv[1:3]]
    main(*a)
