"""GMWM on the published Allan variance tables of the R package ``avar`` (NavChip, LN-200, iMAR, KVH1750 gyros).

The tables (maximum-overlap AV at dyadic τ of real static recordings, with the sampling rate and length) are data
nobody here wrote; only their numbers are used (the package is AGPL: no code of it is used or copied). For each gyro
axis: the model WIC selects, the largest |model/empirical − 1| of the ADEV over the τ whose published interval
half-width is under 15 % (the issue's adequacy criterion: ≤ 25 %), and the derived ARW / bias instability with
the τ where read. For the NavChip the package's vignette publishes AVLR estimates of the gyros (white noise,
quantization, random walk, from the axis-mean AV on hand-picked scales); they are compared with (a) the same
slope read-off on our side (our AV formulas), (b) GMWM of white + quantization + random walk on each axis.

The tables are not vendored. To run: clone https://github.com/SMAC-Group/avar, ``pip install rdata`` (reads .rda),
then ``PYTHONPATH=. python benchmarks/bench_gmwm_avar.py /path/to/avar/data``.
"""

import math
import sys
import warnings
from pathlib import Path

import numpy as np

from gyrojax.noise import gmwm, readoff

SENSORS = ("navchip", "ln200", "imar", "kvh1750")
RAD_S_TO_DEG_H = 180.0 / math.pi * 3600.0

NAVCHIP_AVLR = {"WN": 5.945877e-05, "QN": 7.208553e-06, "RW": 3.062325e-05}
"""avar vignette, ``avlr(navchip_av, qn_gyro = 1:4, wn_gyro = 6:8, rw_gyro = 10:13, …)``, gyroscopes: AV = WN²/τ,
3 QN²/τ², RW² τ/3 (τ in s, AV in (rad/s)²)."""


def load(data_dir: Path, name: str) -> dict:
    import rdata

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return rdata.read_rda(str(data_dir / f"{name}_av.rda"))[f"{name}_av"]


def slope_readoff(taus, av, scales, f):
    """exp(mean(log(AV_j / f(τ_j)))) over the 1-based ``scales``: the fixed-slope log-log regression."""
    i = np.asarray(list(scales)) - 1
    return math.sqrt(math.exp(np.mean(np.log(av[i] / f(taus[i])))))


def main(data_dir: Path) -> None:
    print(
        f"{'sensor':9s} {'axis':8s} {'model':20s} {'max|rel| hw<15%':>16s} {'all τ':>7s} {'ARW deg/√h':>11s} "
        f"{'BI deg/h':>9s}"
    )
    for name in SENSORS:
        d = load(data_dir, name)
        freq, n = float(d["freq"][0]), int(d["n"][0])
        for axis, a in d["avar"].items():
            if not str(axis).startswith("Gyro"):
                continue
            taus = np.asarray(a["levels"], float)
            av = np.asarray(a["allan"], float) * RAD_S_TO_DEG_H**2
            est = gmwm.WaveletVariance.from_allan_table(taus, av, 1.0 / freq, n)
            m = gmwm.fit_wv(est)
            rel = m.adev(taus) / np.sqrt(av) - 1.0
            hw = (np.asarray(a["uci"]) - np.asarray(a["lci"])) / (2.0 * np.asarray(a["adev"]))
            good = hw < 0.15
            der = m.derived(taus.min(), taus.max())
            arw = der["arw"]["value"]
            bi = der["bias_instability"]["value"]
            print(
                f"{name:9s} {axis:8s} {m.spec.label():20s} {np.max(np.abs(rel[good])):16.3f} "
                f"{np.max(np.abs(rel)):7.3f} {arw if arw else float('nan'):11.4f} {bi if bi else float('nan'):9.3f}"
            )

    # NavChip: published AVLR against our read-off and our GMWM (their units: rad/s, τ in s)
    d = load(data_dir, "navchip")
    freq, n = float(d["freq"][0]), int(d["n"][0])
    gyros = [d["avar"][k] for k in d["avar"] if str(k).startswith("Gyro")]
    taus = np.asarray(gyros[0]["levels"], float)
    av_mean = np.mean([np.asarray(g["allan"], float) for g in gyros], axis=0)
    ours = {
        "WN": slope_readoff(taus, av_mean, range(6, 9), lambda t: 1.0 / t),
        "QN": slope_readoff(taus, av_mean, range(1, 5), lambda t: 3.0 / t**2),
        "RW": slope_readoff(taus, av_mean, range(10, 14), lambda t: t / 3.0),
    }
    c = 1.0 / RAD_S_TO_DEG_H  # deg/h -> rad/s
    spec = gmwm.ModelSpec(white=True, quantization=True, random_walk=True, n_gm=0)
    fits, arws = [], []
    for g in gyros:
        av = np.asarray(g["allan"], float) * RAD_S_TO_DEG_H**2
        est = gmwm.WaveletVariance.from_allan_table(taus, av, 1 / freq, n)
        p = gmwm.fit_wv(est, spec).parameters()
        arws.append(readoff.derived(gmwm.fit_wv(est), taus.min(), taus.max())["arw"]["value"])
        fits.append(
            {
                "WN": 60.0 * p["white"]["value"] * c,
                "QN": p["quantization"]["value"] * c,
                "RW": p["random_walk"]["value"] * c / 60.0,
            }
        )
    print("\nNavChip gyros: published AVLR (avar vignette) against ours")
    print(f"{'term':4s} {'published':>12s} {'our read-off':>13s} {'ratio':>7s} {'GMWM X/Y/Z mean':>16s} {'ratio':>7s}")
    for k, v in NAVCHIP_AVLR.items():
        g = float(np.mean([f[k] for f in fits]))
        print(f"{k:4s} {v:12.4e} {ours[k]:13.4e} {ours[k] / v:7.3f} {g:16.4e} {g / v:7.3f}")
    pub_arw = NAVCHIP_AVLR["WN"] * RAD_S_TO_DEG_H / 60.0
    print(
        f"ARW: published AVLR {pub_arw:.4f} deg/√h; GMWM (selected model, read at slope −½) mean of the axes "
        f"{np.mean(arws):.4f} deg/√h, ratio {np.mean(arws) / pub_arw:.3f}"
    )


def run(argv) -> None:
    """Entry point: ``argv[0]`` the avar data directory (prints how to get it when absent)."""
    if not argv or not Path(argv[0]).is_dir():
        print(__doc__)
        return
    try:
        import rdata  # noqa: F401
    except ModuleNotFoundError:
        print("bench_gmwm_avar: needs the `rdata` package to read the avar .rda tables (pip install rdata)")
        return
    main(Path(argv[0]))


if __name__ == "__main__":
    run(sys.argv[1:])
