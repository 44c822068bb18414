"""GMWM noise models: speed on 10⁶ samples, `gyrojax noise` against allantools, and Monte Carlo coverage.

1. GMWM of a white + Gauss–Markov + random-walk model on 10⁶ samples (warm: after compilation), and the identified
   model selection among the 16 default candidates.
2. The `gyrojax noise` analysis (overlapping ADEV + EDF intervals + IEEE 952 read-off + GMWM model + adequacy +
   derived figures) on 10⁶ samples against allantools.oadev at the same taus, both warm: time ratio, and the
   ADEV ratio / difference.
3. Monte Carlo: ``draws`` simulated white + GM + RW series (2^18 samples at 100 Hz); coverage of θ̂ ± 2σ for each
   log-parameter (binomial 95 % interval of the coverage) and of the natural-parameter 95 % interval, and the
   median relative error of each natural parameter.

Run: PYTHONPATH=. python benchmarks/bench_gmwm.py [draws=500] [n_mc=262144]
"""

import sys
import time

import allantools
import jax
import numpy as np
from scipy import stats

from benchmarks.timing import compile_here
from gyrojax.noise import allan, gmwm
from gyrojax.noise import gmwm_model as gm
from gyrojax.noise.processes import simulate
from gyrojax.noise.readoff import noise_report
from gyrojax.noise.spec import NoiseSpec

DT = 0.01
SPEC = gmwm.ModelSpec(white=True, random_walk=True, n_gm=1)
TRUE = {"white": 0.05, "random_walk": 10.0, "gm1_sigma": 2.0, "gm1_tau": 5.0}


NOISE = NoiseSpec(
    white=TRUE["white"], random_walk=TRUE["random_walk"], gauss_markov=((TRUE["gm1_sigma"], TRUE["gm1_tau"]),)
)


def best_of(f, k=3):
    ts, out = [], None
    for _ in range(k):
        t = time.perf_counter()
        out = f()
        ts.append(time.perf_counter() - t)
    return min(ts), out


def speed(n=1_000_000):
    y = np.asarray(simulate(NOISE, jax.random.PRNGKey(0), np.arange(n) * DT, dt_white=DT))
    t = time.perf_counter()
    gmwm.fit_gmwm(y, DT, model=SPEC)
    first = time.perf_counter() - t
    t_fix, m = best_of(lambda: gmwm.fit_gmwm(y, DT, model=SPEC))
    t_est, _ = best_of(lambda: gmwm.WaveletVariance.of(y, DT))
    gmwm.fit_gmwm(y, DT)
    t_sel, s = best_of(lambda: gmwm.fit_gmwm(y, DT), k=2)
    print(
        f"GMWM, n = {n}: fixed model {SPEC.label()} {t_fix:.3f} s warm (first call incl. compile {first:.1f} s), "
        f"of which the wavelet variance {t_est:.3f} s"
    )
    n_cand = len(gmwm.DEFAULT_CANDIDATES)
    print(f"  identified selection over {n_cand} candidates: {t_sel:.3f} s warm -> {s.info['model']}")
    for k, v in m.parameters().items():
        print(f"  {k:10s} {v['value']:.5g} ± {v['std']:.2g} {v['unit']}  (true {TRUE[k]:g})")

    # gyrojax noise analysis vs allantools oadev at the same taus
    mlist = allan.default_m_list(n)
    noise_report([y], DT, mlist)
    t_ours, (out, res, _, _) = best_of(lambda: noise_report([y], DT, mlist), k=2)
    t_adev, ours = best_of(lambda: np.asarray(allan.overlapping_adev(y, DT, mlist)))
    t_ref, ref = best_of(lambda: allantools.oadev(y, rate=1 / DT, data_type="freq", taus=mlist * DT), k=2)
    ratio = np.asarray(out["adev_deg_per_h"]) / ref[1]
    print(
        f"\n{len(mlist)} taus: allantools.oadev {t_ref:.3f} s; gyrojax overlapping_adev {t_adev:.3f} s "
        f"(allantools/gyrojax {t_ref / t_adev:.1f}); whole `gyrojax noise` analysis {t_ours:.3f} s "
        f"= {t_ours / t_ref:.2f} x allantools (target < 5)"
    )
    print(
        f"  ADEV gyrojax/allantools: max |ratio - 1| = {np.max(np.abs(ratio - 1)):.2e}, "
        f"max |difference| = {np.max(np.abs(np.asarray(out['adev_deg_per_h']) - ref[1])):.2e} deg/h"
    )
    print(
        f"  model vs empirical: {out['adequacy']['verdict']}; max |model/empirical - 1| where the 95 % half-width "
        f"< 15 %: {out['adequacy']['max_rel_deviation_well_measured']:.3f}"
    )


def coverage(draws=500, n=2**18):
    th = gm.theta_from_natural(SPEC, TRUE, DT)
    times = np.arange(n) * DT
    sim = jax.jit(lambda k: simulate(NOISE, k, times, dt_white=DT))
    z, inside, rel = [], [], []
    t = time.perf_counter()
    for d in range(draws):
        m = gmwm.fit_gmwm(np.asarray(sim(jax.random.PRNGKey(10_000 + d))), DT, model=SPEC)
        th_hat = gm.theta_of(SPEC, m)
        jac = np.abs(np.diag(np.asarray(gm._natural_and_jacobian(SPEC, th_hat, DT)[1])))
        z.append((th_hat - th) / (np.array([m.std(k) for k in m.cov_names]) / jac))
        par = m.parameters()
        inside.append(
            [par[k]["ci95"] is not None and par[k]["ci95"][0] <= v <= par[k]["ci95"][1] for k, v in TRUE.items()]
        )
        rel.append([par[k]["value"] / v - 1 for k, v in TRUE.items()])
    wall = time.perf_counter() - t
    z, inside, rel = np.array(z), np.array(inside), np.array(rel)
    print(f"\nMonte Carlo: {draws} draws of {n} samples ({wall:.0f} s, {wall / draws:.2f} s per draw)")
    print(f"{'parameter':12s} {'|z|<=2':>8s} {'95% CI':>15s} {'ci95 hit':>9s} {'median rel err':>15s} {'sd z':>6s}")
    for i, (name, k) in enumerate(zip(SPEC.names, TRUE)):
        c = np.mean(np.abs(z[:, i]) <= 2)
        lo, hi = stats.binomtest(int(round(c * draws)), draws).proportion_ci(0.95)
        print(
            f"{name + '/' + k:12s} {c:8.3f} [{lo:.3f}, {hi:.3f}] {np.mean(inside[:, i]):9.3f} "
            f"{np.median(rel[:, i]):15.4f} {np.std(z[:, i]):6.2f}"
        )
    all_in = np.mean(np.all(np.abs(z) <= 2, axis=1))
    print(f"every parameter within 2σ at once: {all_in:.3f} (independent parameters would give 0.95^4 = {0.95**4:.3f})")
    return z


if __name__ == "__main__":
    compile_here()
    nums = [int(a) for a in sys.argv[1:] if a.isdigit()]  # (python -m benchmarks passes bench names)
    draws = nums[0] if nums else 500
    n_mc = nums[1] if len(nums) > 1 else 2**18
    speed()
    if draws > 0:
        coverage(draws, n_mc)
