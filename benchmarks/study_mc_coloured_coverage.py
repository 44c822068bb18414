"""Monte Carlo coverage under every noise model ``gyrojax noise`` can choose (issue 25): is (θ̂ − θ)/σ̂ standard
normal when a static multiposition study is fitted by GLS of the position means with their known covariance
(:attr:`gyrojax.montecarlo.pipeline.Pipeline.fit_method` ``gls-position-means``)?

Plan ``multiposition`` (dt 10 s), model D_F, D_I, D_O (D_F ~ N(1, 0.1²) deg/h). Noise models: white + flicker
(B over 10 … 3000 s), white + GM + RW, white + 2 GM, quantization + white, white + flicker + RW. Printed per model
and coefficient: the coverage of ±1σ̂ and ±2σ̂ (0.6827, 0.9545 for an honest σ̂; binomial sd √(p(1 − p)/draws)), the
sd of z, and the rms error beside the mean σ̂.

Run: PYTHONPATH=. python benchmarks/study_mc_coloured_coverage.py [--draws 2000]
"""

import argparse
import math
from dataclasses import replace

from gyrojax.montecarlo.results import summarize
from gyrojax.montecarlo.runner import run_study
from gyrojax.montecarlo.study import study_from_dict
from gyrojax.noise.spec import NoiseSpec

STUDY = {
    "plan": "multiposition",
    "plan_options": {"dt_s": 10},
    "terms": ["D_F", "D_I", "D_O"],
    "priors": {"D_F": {"normal": [1, 0.1]}},
}
MODELS = {
    "white+flicker": NoiseSpec(white=0.01, bias_instability=0.03, flicker_band=(10.0, 3000.0)),
    "white+gm+rw": NoiseSpec(white=0.01, gauss_markov=((0.05, 300.0),), random_walk=0.02),
    "white+2gm": NoiseSpec(white=0.01, gauss_markov=((0.05, 300.0), (0.03, 3000.0))),
    "quant+white": NoiseSpec(white=0.005, quantization=5.0),
    "white+flicker+rw": NoiseSpec(white=0.01, bias_instability=0.03, flicker_band=(10.0, 3000.0), random_walk=0.01),
}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--draws", type=int, default=2000)
    args = ap.parse_args()
    sd1, sd2 = (math.sqrt(p * (1 - p) / args.draws) for p in (0.6827, 0.9545))
    print(f"{args.draws} draws per model; binomial sd of the coverage: ±1σ {sd1:.4f}, ±2σ {sd2:.4f}")
    for name, noise in MODELS.items():
        study = replace(study_from_dict({**STUDY, "draws": args.draws}), noise=noise)
        s = summarize(run_study(study))
        for _, r in s.iterrows():
            print(
                f"{name:18s} {r['coefficient']:4s} fit {r['fit']:20s} cover1 {r['cover_1sigma']:.4f} "
                f"cover2 {r['cover_2sigma']:.4f} sd_z {r['std_z']:.3f} rms {r['rms_error']:.4g} "
                f"mean_std {r['mean_std']:.4g}"
            )


if __name__ == "__main__":
    main()
