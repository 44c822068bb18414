"""Results of a Monte Carlo study: the per-draw arrays (:class:`StudyResult`), their summary (bias, RMS error,
mean σ̂, coverage of θ̂ ± σ̂ and θ̂ ± 2σ̂ per coefficient), the result directory written by ``gyrojax mc`` and read
back, and the merge of results of disjoint draw ranges. Figures are :mod:`gyrojax.report`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gyrojax import protocol
from gyrojax.errors import FormatError
from gyrojax.montecarlo.study import STUDY_FORMAT, STUDY_VERSION, Study, StudyError, load_study, study_from_dict
from gyrojax.protocol import atomic_write_bytes, atomic_write_text


@dataclass
class StudyResult:
    """Per-draw arrays of a study: truth (n, p_true), estimate and std (n, p_fit), rms (n,)."""

    study: Study
    truth_names: tuple
    fit_names: tuple
    draw: np.ndarray
    truth: np.ndarray
    estimate: np.ndarray
    std: np.ndarray
    rms: np.ndarray
    compile_s: float = 0.0
    run_s: float = 0.0
    fit: str = ""
    """How the draws were fitted and their σ̂ obtained (:attr:`gyrojax.montecarlo.pipeline.Pipeline.fit_method`)."""

    def truth_of_fit(self) -> np.ndarray:
        """Truth of the fitted coefficients only, (n, p_fit), report units, aligned with ``estimate``."""
        return self.truth[:, [self.truth_names.index(c) for c in self.fit_names]]

    def table(self):
        """Tidy pandas DataFrame: one row per draw; ``<c>_truth`` for every truth coefficient, ``<c>_estimate`` and
        ``<c>_std`` for every fitted one, ``rms``."""
        import pandas as pd

        cols = {"draw": self.draw}
        for j, c in enumerate(self.truth_names):
            cols[f"{c}_truth"] = self.truth[:, j]
        for j, c in enumerate(self.fit_names):
            cols[f"{c}_estimate"] = self.estimate[:, j]
            cols[f"{c}_std"] = self.std[:, j]
        cols["rms"] = self.rms
        return pd.DataFrame(cols)


def summarize(res: StudyResult):
    """Per fitted coefficient: bias, RMS error, mean σ̂, mean and std of (θ̂−θ)/σ̂, coverage of ±1σ̂ and ±2σ̂, and
    (``fit``) how the draws were fitted when the result says."""
    import pandas as pd

    err = res.estimate - res.truth_of_fit()
    z = err / res.std
    rows = []
    for j, c in enumerate(res.fit_names):
        rows.append(
            {
                "coefficient": c,
                "bias": err[:, j].mean(),
                "rms_error": np.sqrt((err[:, j] ** 2).mean()),
                "mean_std": res.std[:, j].mean(),
                "mean_z": z[:, j].mean(),
                "std_z": z[:, j].std(ddof=1),
                "cover_1sigma": np.mean(np.abs(z[:, j]) <= 1.0),
                "cover_2sigma": np.mean(np.abs(z[:, j]) <= 2.0),
                **({"fit": res.fit} if res.fit else {}),
            }
        )
    return pd.DataFrame(rows)


RESULT_FORMAT = "gyrojax-mc-result"
RESULT_VERSION = 1
RESULT_FILE = "result.json"
"""The file of a result directory that says what it holds: the study, the coefficient columns, the draws table
and the timings (s). Directories written before it (``study.json`` + the draws table) still load."""


def save_result(res: StudyResult, out_dir, force: bool = False) -> dict:
    """Write draws (Parquet if pyarrow is importable, else CSV), the study JSON (``draws`` = the draws written, so
    that it re-runs this result), the summary and ``result.json`` (``RESULT_FORMAT``) into ``out_dir``; returns the
    paths by role. :func:`load_result` reads the directory back equal. No figure: ``gyrojax mc`` draws
    ``coverage.png`` with :func:`gyrojax.report.figures.montecarlo_figure`."""
    import io as _io

    out = Path(out_dir)
    names = {"study": out / "study.json", "summary": out / "summary.csv"}
    try:
        import pyarrow  # noqa: F401

        names["draws"] = out / "draws.parquet"
    except ImportError:
        names["draws"] = out / "draws.csv"
    names["result"] = out / RESULT_FILE
    if not force:
        clash = [str(p) for p in names.values() if p.exists()]
        if clash:
            raise StudyError(f"{clash[0]} exists; use --force to overwrite")
    df = res.table()
    if names["draws"].suffix == ".parquet":
        buf = _io.BytesIO()
        df.to_parquet(buf, index=False)
        atomic_write_bytes(names["draws"], buf.getvalue())
    else:
        atomic_write_text(names["draws"], df.to_csv(index=False, float_format="%.17g"))
    d = res.study.to_dict()
    d["draws"] = int(len(res.draw))
    atomic_write_text(names["study"], protocol.dumps(d, STUDY_FORMAT, STUDY_VERSION))
    atomic_write_text(names["summary"], summarize(res).to_csv(index=False, float_format="%.6g"))
    manifest = {
        "study": res.study.to_dict(),
        "truth_names": list(res.truth_names),
        "fit_names": list(res.fit_names),
        "draws_file": names["draws"].name,
        "compile_s": res.compile_s,
        "run_s": res.run_s,
        "fit": res.fit,
    }
    protocol.save(names["result"], manifest, RESULT_FORMAT, RESULT_VERSION, force=True)  # clashes checked above
    return {k: str(v) for k, v in names.items()}


def load_result(out_dir) -> StudyResult:
    """A result written by :func:`save_result`, whole: its ``result.json`` and its draws table (Parquet or CSV);
    a directory without ``result.json`` (written before it) from its study JSON and draws table, with zero timings.
    Errors name the directory and the file."""
    import pandas as pd

    out = Path(out_dir)
    manifest = None
    if (out / RESULT_FILE).exists():
        try:
            manifest = protocol.load(out / RESULT_FILE, RESULT_FORMAT, RESULT_VERSION)
            protocol.require(manifest, ("study", "truth_names", "fit_names", "draws_file"), str(out / RESULT_FILE))
        except FormatError as e:
            raise StudyError(str(e)) from None
        study = study_from_dict(manifest["study"], f"{out / RESULT_FILE}: key 'study'")
        table = out / str(manifest["draws_file"])
    else:
        study = load_study(out / "study.json")
        table = out / "draws.parquet"
        if not table.exists():
            table = out / "draws.csv"
    if not table.exists():
        raise StudyError(f"{out}: no draws.parquet or draws.csv (not a directory written by gyrojax mc)")
    try:
        df = pd.read_parquet(table) if table.suffix == ".parquet" else pd.read_csv(table)
    except (OSError, ValueError) as e:
        raise StudyError(f"{table}: cannot be read as a draws table ({e})") from None
    cols = list(df.columns)
    if manifest is None:
        truth = tuple(c[: -len("_truth")] for c in cols if c.endswith("_truth"))
        fit = tuple(c[: -len("_estimate")] for c in cols if c.endswith("_estimate"))
    else:
        truth, fit = tuple(manifest["truth_names"]), tuple(manifest["fit_names"])
    need = ["draw", "rms"] + [f"{c}_truth" for c in truth] + [f"{c}_{k}" for c in fit for k in ("estimate", "std")]
    missing = [c for c in need if c not in cols]
    if missing or not truth or not fit:
        raise StudyError(f"{table}: missing column {missing[0] if missing else '<coefficient>_truth/_estimate'!r}")
    timing = [float(manifest.get(k) or 0.0) if manifest else 0.0 for k in ("compile_s", "run_s")]
    return StudyResult(
        study,
        truth,
        fit,
        df["draw"].to_numpy(dtype=np.int64),
        df[[f"{c}_truth" for c in truth]].to_numpy(dtype=float),
        df[[f"{c}_estimate" for c in fit]].to_numpy(dtype=float),
        df[[f"{c}_std" for c in fit]].to_numpy(dtype=float),
        df["rms"].to_numpy(dtype=float),
        *timing,
        str(manifest.get("fit") or "") if manifest else "",
    )


def merge_results(results, where=None) -> StudyResult:
    """One result from the results of disjoint draw ranges of one study (the index-range split: ``gyrojax mc
    --start S --draws N`` per host, no coordination), rows in draw order. Refuses different studies (any key but
    ``draws``) and a draw index present twice; ``where`` names the inputs in error messages."""
    results = list(results)
    if not results:
        raise StudyError("merge: no results given")
    where = list(where) if where is not None else [f"result {i}" for i in range(len(results))]

    def key(r):
        d = r.study.to_dict()
        d.pop("draws")
        return d

    ref = results[0]
    for r, w in zip(results[1:], where[1:]):
        if key(r) != key(ref):
            diff = sorted(k for k in key(ref) if key(ref)[k] != key(r).get(k))
            raise StudyError(f"merge: {w} is a different study from {where[0]} (key {diff[0]!r} differs)")
        if r.truth_names != ref.truth_names or r.fit_names != ref.fit_names:
            raise StudyError(f"merge: {w} has other coefficient columns than {where[0]}")
    draw = np.concatenate([r.draw for r in results])
    order = np.argsort(draw, kind="stable")
    dup = draw[order][1:][np.diff(draw[order]) == 0]
    if dup.size:
        owners = [w for r, w in zip(results, where) if dup[0] in r.draw]
        raise StudyError(f"merge: draw {int(dup[0])} is in {' and '.join(owners)} (the draw ranges overlap)")

    def cat(name):
        return np.concatenate([getattr(r, name) for r in results])[order]

    return StudyResult(
        replace(ref.study, draws=int(draw.size)),
        ref.truth_names,
        ref.fit_names,
        draw[order],
        cat("truth"),
        cat("estimate"),
        cat("std"),
        cat("rms"),
        sum(r.compile_s for r in results),
        sum(r.run_s for r in results),
        ref.fit,
    )
