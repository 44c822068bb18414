"""Importers that read what people have (issue 24 A), checked against the truth planted in simulated hand sessions
(gyrojax.simulation.triad: 36 rests of 1.3–3.2 s at 100 Hz, hand moves between them, MEMS noise) and against
imucal's own session and calibration (tests/data/imucal): short rests found and fitted, every dropped candidate
reported with its reason and time, imucal's section lists, real-log CSVs (delimiters, time units, a sample
counter beside a jittering receive time), every option honoured or refused, and the accelerometer never taken as
calibrated on trust."""

import json
import re
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from gyrojax import units
from gyrojax.cli.app import main
from gyrojax.data.importers import FERRARIS_FACES, FERRARIS_ROTATIONS, import_csv, triad_from_arrays
from gyrojax.data.records import load_records
from gyrojax.data.segments import detect_rests
from gyrojax.errors import RecordError
from gyrojax.inference.triad import fit_triad
from gyrojax.physics.gravity import site_gravity
from gyrojax.simulation.triad import simulate_multiposition

from .conftest import IMUCAL
from .test_triad_imucal import SCALE as IMUCAL_SCALE
from .test_triad_imucal import TERMS, imucal_reference

MAP = "time=t,gyro_x=gx,gyro_y=gy,gyro_z=gz,acc_x=ax,acc_y=ay,acc_z=az"


def _truth(rng) -> dict:
    """A MEMS-sized truth: bias ~1000 deg/h, scale factor ~2 %, misalignment ~3000″, g-sensitivity ~30 deg/h/g."""
    out = {}
    for ch in "xyz":
        out.update(
            {
                f"D_F[{ch}]": rng.normal(0, 1000),
                f"E_SF[{ch}]": rng.normal(0, 20000),
                f"M_O[{ch}]": rng.normal(0, 3000),
                f"M_S[{ch}]": rng.normal(0, 3000),
                f"D_I[{ch}]": rng.normal(0, 30),
                f"D_O[{ch}]": rng.normal(0, 30),
                f"D_S[{ch}]": rng.normal(0, 30),
            }
        )
    return out


def latitude_unknown_truth(truth: dict, latitude_deg=49.6, gravity_mps2=9.81) -> dict:
    """What a fit with the latitude unknown finds (closed form): the vertical Earth rate Ω sin φ along Up, seen
    through each channel's scale factor and misalignment, lies in its g-terms, (Ω sin φ / |a|)·(1 + E_SF, M_O,
    M_S) added to (D_I, D_O, D_S), deg/h/g."""
    k = 15.041067 * np.sin(np.radians(latitude_deg)) / (gravity_mps2 / units.G0)
    want = dict(truth)
    for ch in "xyz":
        want[f"D_I[{ch}]"] += k * (1.0 + truth[f"E_SF[{ch}]"] * 1e-6)
        want[f"D_O[{ch}]"] += k * np.radians(truth[f"M_O[{ch}]"] / 3600.0)
        want[f"D_S[{ch}]"] += k * np.radians(truth[f"M_S[{ch}]"] / 3600.0)
    return want


def hand_session(seed=3, rests=None, poses=36):
    """(record with the planted segment labels, truth): rests of 1.3–3.2 s, moves of 0.8–1.6 s at 100 Hz, gyro
    noise 0.07 deg/s and accelerometer noise 1.5 mg per sample (a BMI160 at 100 Hz)."""
    rng = np.random.default_rng(seed)
    truth = _truth(rng)
    rest = rng.uniform(1.3, 3.2, poses) if rests is None else np.asarray(rests)
    move = rng.uniform(0.8, 1.6, poses - 1)
    rec = simulate_multiposition(
        truth, poses=poses, static_s=rest, move_s=move, gyro_noise_dps=0.07, acc_noise_g=0.0015, seed=seed
    )
    return rec, truth


def sensors(rec):
    c = rec.columns
    return (
        np.stack([c[f"acc_{a}_g"] for a in "xyz"], axis=1),
        np.stack([c[f"gyro_{a}_dps"] for a in "xyz"], axis=1),
    )


def csv_argv(path, out, *options) -> list:
    """``gyrojax import csv PATH --map MAP --gyro-unit dps [options] --out OUT`` as an argv list."""
    return ["import", "csv", str(path), "--map", MAP, "--gyro-unit", "dps", *options, "--out", str(out)]


def write_log(path, columns: dict, delimiter=",", fmt="%.10g"):
    """A log file with a header row and the given columns (name → array), ``delimiter`` between fields."""
    data = np.column_stack(list(columns.values()))
    np.savetxt(path, data, delimiter=delimiter, header=delimiter.join(columns), comments="", fmt=fmt)
    return path


def log_columns(rec, acc=None) -> dict:
    a, g = sensors(rec)
    a = a if acc is None else acc
    cols = {"t": rec.time_s}
    cols.update({f"g{c}": g[:, j] for j, c in enumerate("xyz")})
    cols.update({f"a{c}": a[:, j] for j, c in enumerate("xyz")})
    return cols


def planted_rests(rec) -> dict:
    """Planted static label → (first, last + 1) sample."""
    seg = rec.columns["segment"]
    out = {}
    for s in rec.meta["segments"]:
        if s["type"] == "static":
            idx = np.flatnonzero(seg == s["label"])
            out[s["label"]] = (int(idx[0]), int(idx[-1]) + 1)
    return out


def match_rests(planted: dict, found: list) -> dict:
    """Planted label → the found intervals inside it; asserts that each found interval lies in one planted rest."""
    out = {k: [] for k in planted}
    for s, e in found:
        owners = [k for k, (ps, pe) in planted.items() if ps <= s and e <= pe]
        assert len(owners) == 1, ("a rest found outside every planted rest", s, e)
        out[owners[0]].append((s, e))
    return out


# ---- 1. short rests are found --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def session():
    return hand_session()


def test_all_36_short_rests_found_and_the_fit_uses_them(session, tmp_path, capsys):
    rec, truth = session
    planted = planted_rests(rec)
    lengths = np.array([e - s for s, e in planted.values()]) / 100.0
    assert len(planted) == 36 and lengths.min() >= 1.3 and lengths.max() <= 3.2
    path = write_log(tmp_path / "hand.csv", log_columns(rec))
    assert (
        main(["import", "csv", str(path), "--map", MAP, "--gyro-unit", "dps", "--out", str(tmp_path / "o"), "--json"])
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["segments"] == {"static": 36, "move": 35}
    assert out["import"]["rests_found"] == 36 and out["import"]["dropped"] == []
    (imp,) = load_records(tmp_path / "o")
    seg = imp.columns["segment"]
    found = [
        (int(np.flatnonzero(seg == s["label"])[0]), int(np.flatnonzero(seg == s["label"])[-1]) + 1)
        for s in imp.meta["segments"]
        if s["type"] == "static"
    ]
    per = match_rests(planted, found)
    for k, (ps, pe) in planted.items():  # one rest found in each, holding most of its samples
        assert len(per[k]) == 1, (k, per[k])
        s, e = per[k][0]
        assert (e - s) >= (pe - ps) - 45, (k, (ps, pe), (s, e))  # ≤ 0.45 s lost to the window and trim
    res = fit_triad(imp)
    assert sum(s.kind == "static" for s in res.segments) == 36
    assert res.dof == fit_triad(rec).dof  # as many measurement rows as the planted labels give: 36 rests, 35 moves
    z = {k: (res.values[k] - v) / res.stds[k] for k, v in latitude_unknown_truth(truth).items()}
    assert max(abs(v) for v in z.values()) < 4.0, z
    assert res.chi2 / res.dof < 1.5, (res.chi2, res.dof)


@pytest.mark.parametrize("seed", [4, 5, 6, 7, 8])
def test_short_rests_found_through_a_hand_release_wobble_and_drift(seed):
    """Each rest starts with the hand's release (a damped 8 Hz wobble, 0.1 s decay, 0.5 deg/s and 4 mg) and the
    gyro bias drifts 0.02 deg/s over the session: every planted rest is still found once, past its wobble."""
    rec, _ = hand_session(seed=seed)
    acc, gyr = (x.copy() for x in sensors(rec))
    rng = np.random.default_rng(seed)
    planted = planted_rests(rec)
    for s, e in planted.values():
        t = np.arange(e - s) / 100.0
        wobble = np.exp(-t / 0.1) * np.sin(2 * np.pi * 8 * t)
        gyr[s:e] += np.outer(wobble, rng.normal(0, 0.5, 3))
        acc[s:e] += np.outer(wobble, rng.normal(0, 0.004, 3))
    gyr += np.linspace(0.0, 0.02, len(gyr))[:, None]
    det = detect_rests(acc, 100.0, gyro=gyr)
    per = match_rests(planted, det.intervals)
    assert all(len(v) == 1 for v in per.values()) and det.dropped == [], det.summary()
    # the first 0.1 s of each release wobble left out (the record's first rest follows no move: not trimmed)
    assert all(v[0][0] - planted[k][0] >= 10 for k, v in per.items() if k > 0)


def test_a_longer_minimum_rest_drops_the_short_ones_and_says_which(session, tmp_path, capsys):
    rec, _ = session
    planted = planted_rests(rec)
    path = write_log(tmp_path / "hand.csv", log_columns(rec))
    argv = csv_argv(path, tmp_path / "o", "--min-rest", "2")
    assert main(argv) == 0
    text = capsys.readouterr().out
    (imp,) = load_records(tmp_path / "o")
    report = imp.meta["import"]
    assert report["min_rest_s"] == 2.0
    dropped = report["dropped"]
    assert {d["reason"] for d in dropped} == {"too short"}
    assert report["rests_found"] + len(dropped) == 36  # every planted rest found or reported dropped
    hit = set()
    for d in dropped:  # each drop is the quiet span of a planted rest shorter than 2 s plus the trims
        mid = (d["start_s"] + d["end_s"]) * 50
        (k,) = [k for k, (ps, pe) in planted.items() if ps <= mid < pe]
        ps, pe = planted[k]
        assert pe - ps < 250 and d["end_s"] - d["start_s"] < (pe - ps) / 100 + 0.3, (d, planted[k])
        hit.add(k)
    assert len(hit) == len(dropped)
    assert f"rests: {report['rests_found']} rests found" in text and f"{len(dropped)} candidate rests dropped" in text
    assert text.count("  dropped ") == len(dropped) and "too short" in text


def test_dropped_candidates_are_reported_with_reason_and_time(tmp_path, capsys):
    rests = np.random.default_rng(11).uniform(1.3, 3.2, 36)
    rests[10] = 0.35  # a hand pause too short to be a rest
    rec, _ = hand_session(seed=5, rests=rests)
    planted = planted_rests(rec)
    acc, gyr = sensors(rec)
    s, e = planted[2 * 20]  # a rest held by a trembling hand: gyro noise 4× the sensor's
    gyr = gyr.copy()
    gyr[s:e] += 0.07 * np.sqrt(15.0) * np.random.default_rng(1).standard_normal((e - s, 3))
    imp = triad_from_arrays(rec.time_s, acc, gyr)
    report = imp.meta["import"]
    assert report["rests_found"] == 34
    by_reason = {d["reason"]: d for d in report["dropped"]}
    assert set(by_reason) == {"too short", "too noisy"} and len(report["dropped"]) == 2
    for reason, label in (("too short", 20), ("too noisy", 40)):
        d = by_reason[reason]
        ps, pe = planted[label]  # the quiet run reported holds the planted rest's middle, and little more
        assert d["start_s"] < (ps + pe) / 200 < d["end_s"], (reason, d, planted[label])
        assert d["end_s"] - d["start_s"] < (pe - ps) / 100 + 0.5, (reason, d, planted[label])
    assert "variance 1" in by_reason["too noisy"]["detail"]  # ~16× the rest noise
    # the threshold is an option: above the trembling rest's variance, it is kept
    kept = triad_from_arrays(rec.time_s, acc, gyr, static_threshold=40.0).meta["import"]
    assert kept["rests_found"] == 35 and "too noisy" not in [d["reason"] for d in kept["dropped"]]


def test_the_threshold_is_relative_to_the_records_own_noise(session):
    rec, _ = session
    acc, gyr = sensors(rec)
    base = detect_rests(acc, 100.0, gyro=gyr)
    scaled = detect_rests(acc * 9.80665e3, 100.0, gyro=gyr * 16.4 + 32768.0)  # other units and offsets
    assert scaled.intervals == base.intervals
    noisier = detect_rests(acc * 3 + 0.003 * np.random.default_rng(2).standard_normal(acc.shape), 100.0, gyro=gyr * 3)
    assert len(noisier.intervals) == 36


def test_coloured_rest_noise_raises_the_threshold_and_keeps_the_rest_whole():
    """At 1 kHz behind a 40 Hz low-pass filter (a MEMS DLPF) a 0.2 s window holds ~16 independent samples per
    channel, not 200: the threshold follows the rest windows' measured spread (χ²_ν/ν, ν from it), so 2 min of rest
    stay one rest, where the white-noise threshold of 200 samples splits them."""
    from scipy import signal

    rng = np.random.default_rng(0)
    b, a = signal.butter(2, 40.0 / 500.0)
    acc = np.array([0.0, 0.0, 1.0]) + signal.lfilter(b, a, 0.002 * rng.standard_normal((120000, 3)), axis=0)
    gyr = signal.lfilter(b, a, 0.1 * rng.standard_normal((120000, 3)), axis=0)
    det = detect_rests(acc, 1000.0, gyro=gyr)
    assert det.intervals == [(0, 120000)], det.summary()
    white = float(stats.chi2.isf(1e-6, 200) / 200)
    assert all(v > 1.2 * white for v in det.threshold.values()), det.threshold
    assert len(detect_rests(acc, 1000.0, gyro=gyr, threshold=white).intervals) > 1


@pytest.mark.parametrize("lsb_over_sigma", [1.0, 3.0, 7.0])
def test_rests_of_a_gyro_quieter_than_its_lsb_are_found(session, lsb_over_sigma):
    """Counts of a gyro whose noise is a fraction of its LSB: most rest windows hold one value; the rest noise is
    then the quantisation's, LSB²/12, and the rests are found whole."""
    rec, _ = session
    acc, gyr = sensors(rec)
    lsb = 0.07 * lsb_over_sigma
    det = detect_rests(acc, 100.0, gyro=np.round(gyr / lsb))
    assert len(det.intervals) == 36 and det.dropped == [], det.summary()


def test_a_long_white_noise_rest_is_never_split():
    """The default threshold leaves a rest of white noise whole: 10 min at 100 Hz of three channels each, against
    a threshold of 1.5 (what an absolute tuning to a quiet window might give) that splits it."""
    rng = np.random.default_rng(4)
    acc = np.array([0.0, 0.0, 1.0]) + 0.0015 * rng.standard_normal((60000, 3))
    gyr = 0.07 * rng.standard_normal((60000, 3))
    det = detect_rests(acc, 100.0, gyro=gyr)
    assert det.intervals == [(0, 60000)] and det.dropped == [] and det.joined == []
    assert len(detect_rests(acc, 100.0, gyro=gyr, threshold=1.5).intervals) > 1


# ---- 3. imucal's own section list ------------------------------------------------------------------------------


def _imucal_sections():
    """The vendored session's parts as imucal's section list: row positions in file order, end exclusive."""
    import pandas as pd

    part = pd.read_csv(IMUCAL / "annotated_session.csv")["part"].to_numpy()
    out = {}
    for name in dict.fromkeys(part):
        idx = np.flatnonzero(part == name)
        assert np.all(np.diff(idx) == 1), name  # one contiguous run of rows per section
        out[str(name)] = {"start": int(idx[0]), "end": int(idx[-1]) + 1}
    return out


def test_imucal_section_names_are_imucals():
    import pandas as pd

    parts = set(pd.read_csv(IMUCAL / "annotated_session.csv")["part"])
    readme = (IMUCAL / "README.md").read_text()
    ours = set(FERRARIS_FACES) | set(FERRARIS_ROTATIONS)
    assert parts == ours and len(ours) == 9
    spans = re.findall(r"`([^`]*)`", readme)
    names = [[n.strip() for n in span.split(",")] for span in spans]
    listed = {n for ns in names if all(re.fullmatch(r"[xyz]_(p|a|rot)", n) for n in ns) for n in ns}
    assert listed == ours, (listed, ours)


@pytest.fixture(scope="module")
def imucal_by_part(tmp_path_factory):
    out = tmp_path_factory.mktemp("part")
    argv = ["import", "imucal", str(IMUCAL / "annotated_session.csv"), "--rate-hz", "204.8"]
    assert main(argv + ["--gyro-scale", str(IMUCAL_SCALE), "--out", str(out)]) == 0
    (rec,) = load_records(out)
    return rec


@pytest.mark.parametrize("form", ["imucal-json", "pandas-columns-json", "pairs-json", "imucal-csv"])
def test_imucal_section_list_imports_as_the_part_column(form, imucal_by_part, tmp_path, capsys):
    import pandas as pd

    sections = _imucal_sections()
    df = pd.read_csv(IMUCAL / "annotated_session.csv").drop(columns="part")
    session = tmp_path / "session.csv"
    df.to_csv(session, index=False)
    if form == "imucal-json":
        text = json.dumps(sections)
        assert text.startswith('{"x_a": {"start": 0, "end": ')  # imucal's own form
        (tmp_path / "s.json").write_text(text)
    elif form == "pandas-columns-json":
        table = pd.DataFrame(sections).T
        (tmp_path / "s.json").write_text(table.to_json())
    elif form == "pairs-json":
        (tmp_path / "s.json").write_text(json.dumps({k: [v["start"], v["end"]] for k, v in sections.items()}))
    else:
        pd.DataFrame(sections).T.to_csv(tmp_path / "s.csv")
    spath = tmp_path / ("s.csv" if form == "imucal-csv" else "s.json")
    argv = ["import", "imucal", str(session), "--sections", str(spath), "--gyro-scale", str(IMUCAL_SCALE)]
    assert main(argv + ["--rate-hz", "204.8", "--out", str(tmp_path / "o"), "--name", "annotated_session"]) == 0
    assert "9 sections" in capsys.readouterr().out
    # the six faces calibrate the accelerometer: 18 equations, 12 unknowns, each face's |a| = g to < 0.5 %
    assert imucal_by_part.meta["import"]["accelerometer"]["max_rest_magnitude_error"] < 5e-3
    (rec,) = load_records(tmp_path / "o")
    for k, v in imucal_by_part.columns.items():
        assert np.array_equal(rec.columns[k], v), k


def test_imucal_section_list_session_agrees_with_imucal_within_0_2_sigma(tmp_path, capsys):
    import pandas as pd

    df = pd.read_csv(IMUCAL / "annotated_session.csv").drop(columns="part")
    df.to_csv(tmp_path / "session.csv", index=False)
    (tmp_path / "s.json").write_text(json.dumps(_imucal_sections()))
    argv = ["import", "imucal", str(tmp_path / "session.csv"), "--sections", str(tmp_path / "s.json")]
    assert main(argv + ["--rate-hz", "204.8", "--gyro-scale", str(IMUCAL_SCALE), "--out", str(tmp_path / "o")]) == 0
    capsys.readouterr()
    assert main(["fit", str(tmp_path / "o"), "--terms", TERMS, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    for name, want in imucal_reference().items():
        c = res["coefficients"][name]
        assert abs(c["value"] - want) < 0.2 * c["std"], (name, c, want)


# ---- 4. real logs: delimiters, time units, a sample counter --------------------------------------------------


def test_semicolon_log_with_a_jittering_receive_time_and_a_wrapping_sample_counter(session, tmp_path, capsys):
    rec, _ = session
    rng = np.random.default_rng(9)
    n = rec.n
    cols = log_columns(rec)
    # received in packets of 4 samples, each packet 0.2–43 ms late: receive-time steps of 0.2 to ~80 ms
    packet_delay = rng.uniform(0.2e-3, 43e-3, n // 4 + 1)
    rx = rec.time_s + 0.03 + np.repeat(packet_delay, 4)[:n]
    rx = np.maximum.accumulate(rx) + np.arange(n) * 1e-6  # a receive clock never goes back
    cols["t"] = np.round(rx * 1e6)  # µs
    cols = {"cnt": (65000 + np.arange(n)) % 65536, **cols}  # a 16-bit counter that wraps
    path = write_log(tmp_path / "log.csv", cols, delimiter=";")
    argv = [
        "import",
        "csv",
        str(path),
        "--map",
        MAP + ",sample=cnt",
        "--gyro-unit",
        "dps",
        "--time-unit",
        "us",
        "--rate-hz",
        "100",
    ]
    assert main(argv + ["--out", str(tmp_path / "o")]) == 0
    text = capsys.readouterr().out
    assert "delimiter ';' detected" in text
    note = next(ln for ln in text.splitlines() if "jitters" in ln)
    steps = np.diff(cols["t"]) / 1e3
    assert f"{steps.max():.3g} ms" in note and "the sample counter 'cnt' is used instead" in note, note
    (imp,) = load_records(tmp_path / "o")
    assert np.allclose(imp.time_s, np.arange(n) / 100.0, atol=1e-12)
    assert imp.meta["import"]["rests_found"] == 36
    # the receive time alone: imported, and the note says it jitters and what to use
    argv = csv_argv(path, tmp_path / "o2", "--time-unit", "us")
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "jitters" in text and "a sample counter (sample=COL with --rate-hz)" in text


@pytest.mark.parametrize(
    "delim, flag, name",
    [("\t", "tab", "log.txt"), (",", ",", "log.csv"), (";", ";", "log.csv"), ("\t", None, "log.tsv.gz")],
)
def test_delimiters_and_a_millisecond_time_column(session, tmp_path, capsys, delim, flag, name):
    rec, _ = session
    cols = log_columns(rec)
    cols["t"] = np.round(rec.time_s * 1e3, 6)
    path = write_log(tmp_path / name, cols, delimiter=delim)  # numpy gzips a name ending .gz
    argv = csv_argv(path, tmp_path / "o", "--time-unit", "ms")
    assert main(argv + (["--delimiter", flag] if flag else [])) == 0
    text = capsys.readouterr().out
    assert ("detected" in text) == (flag is None) and "jitters" not in text
    (imp,) = load_records(tmp_path / "o")
    assert np.allclose(imp.time_s, rec.time_s, atol=1e-9)
    assert np.allclose(imp.columns["gyro_y_dps"], rec.columns["gyro_y_dps"], rtol=1e-9)


# ---- 5. every importer honours or refuses every option ---------------------------------------------------------


@pytest.mark.parametrize(
    "fmt, option",
    [
        ("imucal", ["--acc-unit", "counts"]),
        ("imucal", ["--map", "time=t"]),
        ("imucal", ["--time-unit", "ms"]),
        ("imucal", ["--min-rest", "1"]),
        ("imucal", ["--static-threshold", "5"]),
        ("imutk", ["--sections", "s.json"]),
        ("imutk", ["--rate-hz", "100"]),
        ("imutk", ["--angle", "360"]),
        ("imutk", ["--angle-std", "1"]),
        ("imutk", ["--map", "time=t"]),
        ("imutk", ["--delimiter", ";"]),
        ("imutk", ["--time-unit", "s"]),
        ("csv", ["--sections", "s.json"]),
        ("csv", ["--angle", "360"]),
        ("csv", ["--angle-std", "1"]),
    ],
)
def test_an_option_an_importer_does_not_take_is_refused(fmt, option, tmp_path, capsys):
    inputs = {"imucal": ["a.csv"], "imutk": ["a.mat", "g.mat"], "csv": ["a.csv", "--map", MAP]}[fmt]
    rc = main(["import", fmt, *inputs, *option, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1, err
    assert f"import {fmt}" in err and option[0] in err, err


def test_gyro_scale_with_rates_is_refused_and_imutk_honours_acc_unit(tmp_path, capsys):
    from .test_triad_imutk import IMUTK

    files = [str(IMUTK / "xsens_acc.mat.gz"), str(IMUTK / "xsens_gyro.mat.gz")]
    rc = main(["import", "imutk", *files, "--gyro-unit", "dps", "--gyro-scale", "16.4", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and "--gyro-scale" in err and "import imutk" in err and err.count("\n") == 1, err
    # imu_tk counts declared as g: |a| of tens of thousands is no calibrated accelerometer (today: ignored)
    rc = main(["import", "imutk", *files, "--gyro-scale", "109.2", "--acc-unit", "g", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and "--acc-unit g" in err and err.count("\n") == 1, err


def test_imucal_honours_rad_per_s_and_a_delimiter(imucal_by_part, tmp_path, capsys):
    import pandas as pd

    df = pd.read_csv(IMUCAL / "annotated_session.csv")
    for c in ("gyr_x", "gyr_y", "gyr_z"):
        df[c] = df[c] / IMUCAL_SCALE * units.DEG  # rad/s
    df.to_csv(tmp_path / "annotated_session.csv", index=False, sep=";")
    argv = ["import", "imucal", str(tmp_path / "annotated_session.csv"), "--gyro-unit", "rad/s", "--delimiter", ";"]
    assert main(argv + ["--rate-hz", "204.8", "--out", str(tmp_path / "o")]) == 0
    (rec,) = load_records(tmp_path / "o")
    want = imucal_by_part.columns["gyro_x_counts"] / IMUCAL_SCALE
    assert np.allclose(rec.columns["gyro_x_dps"], want, rtol=1e-12, atol=1e-12)


# ---- 6. the accelerometer is not taken on trust ----------------------------------------------------------------


def imutk_raw(acc_g, scale_g_per_unit, alphas=(0.004, -0.003, 0.006), bias=(0.05, -0.08, 0.12)):
    """Raw accelerometer readings that imu_tk's model a = T K (raw − b) maps back onto ``acc_g`` (g)."""
    ayz, azy, azx = alphas
    t = np.array([[1.0, -ayz, azy], [0.0, 1.0, -azx], [0.0, 0.0, 1.0]])
    k = np.diag(scale_g_per_unit)
    return np.linalg.solve(t @ k, acc_g.T).T + np.asarray(bias)


def _pose_ups(rec):
    seg = rec.columns["segment"]
    acc = np.stack([rec.columns[f"acc_{c}_g"] for c in "xyz"], axis=1)
    return [acc[seg == s["label"]].mean(axis=0) for s in rec.meta["segments"] if s["type"] == "static"]


@pytest.mark.parametrize("unit", ["m/s^2", "counts"])
def test_an_uncalibrated_accelerometer_is_calibrated_with_a_note(session, tmp_path, capsys, unit):
    rec, _ = session
    acc, _ = sensors(rec)
    raw = imutk_raw(acc, 1.0 / (units.G0 * np.array([1.048, 1.044, 1.052])))  # m/s², |a| 4.8 % high
    path = write_log(tmp_path / "log.csv", log_columns(rec, acc=raw))
    assert main(csv_argv(path, tmp_path / "o", "--acc-unit", unit)) == 0
    text = capsys.readouterr().out
    assert "calibrated by imu_tk's ellipsoid" in text
    if unit == "m/s^2":  # the median excess of |a| over the planted rests, computed here from the raw data
        planted = planted_rests(rec)
        mags = [np.linalg.norm(raw[s:e].mean(axis=0)) / units.G0 for s, e in planted.values()]
        excess = 100 * (np.median(mags) / (site_gravity(None) / units.G0) - 1)
        assert 4.0 < excess < 5.5 and f"|a| at rest is {excess:+.2f} % from the local g" in text, (excess, text)
    (imp,) = load_records(tmp_path / "o")
    assert imp.meta["accelerometer_calibration"]["raw_unit"] == unit
    assert imp.meta["import"]["accelerometer"]["calibrated_here"] is True
    truth = _pose_ups(rec)
    found = _pose_ups(imp)
    assert len(found) == 36
    for u, v in zip(found, truth):  # each pose's Up within 0.05° and |a| within 0.05 % of the truth
        angle = np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)))
        assert angle < 0.05 and abs(np.linalg.norm(u) / np.linalg.norm(v) - 1) < 5e-4, (angle, u, v)


def test_an_accelerometer_in_the_wrong_unit_is_refused(session, tmp_path, capsys):
    rec, _ = session
    acc, _ = sensors(rec)
    path = write_log(tmp_path / "log.csv", log_columns(rec, acc=acc * units.G0))  # m/s² declared as g
    rc = main(csv_argv(path, tmp_path / "o", "--acc-unit", "g"))
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "--acc-unit g" in err and "9.8" in err, err


def test_a_calibrated_accelerometer_is_kept_as_it_is(session):
    rec, _ = session
    acc, gyr = sensors(rec)
    imp = triad_from_arrays(rec.time_s, acc, gyr)
    assert "accelerometer_calibration" not in imp.meta and imp.meta["import"]["notes"] == []
    check = imp.meta["import"]["accelerometer"]
    assert check["calibrated_here"] is False and 0 < check["max_rest_magnitude_error"] < 1e-3
    assert np.array_equal(imp.columns["acc_z_g"], acc[:, 2])


def test_import_csv_api_reports_in_meta(session, tmp_path):
    rec, _ = session
    path = write_log(tmp_path / "log.csv", log_columns(rec))
    imp = import_csv(path, dict(p.split("=") for p in MAP.split(",")), delimiter=",")
    assert imp.meta["import"]["rests_found"] == 36 and imp.meta["import"]["notes"] == []


def test_xsens_rests_are_poses_and_the_gaps_between_them_turn():
    """imu_tk's Xsens recording (real data): each rest found is still (its raw gyro scatter that of the initial
    rest) and each pair of consecutive rests points in different directions (the accelerometer means, less
    their offset, ≥ 2° apart), so no rest was split and none is a pause inside a move — the 38th, 208.4–211.7 s,
    included."""
    from .test_triad_imutk import IMUTK

    acc = np.loadtxt(IMUTK / "xsens_acc.mat.gz")[:, 1:]
    gyr = np.loadtxt(IMUTK / "xsens_gyro.mat.gz")[:, 1:]
    det = detect_rests(acc, 100.0, gyro=gyr)
    assert len(det.intervals) == 38
    assert any(abs(s / 100 - 208.4) < 0.2 and abs(e / 100 - 211.7) < 0.2 for s, e in det.intervals)
    still = gyr[: 50 * 100].std(axis=0)
    for s, e in det.intervals:
        assert np.all(gyr[s:e].std(axis=0) < 1.3 * still), (s, e)
    means = np.array([acc[s:e].mean(axis=0) for s, e in det.intervals])
    # the accelerometer's offset (unsigned counts) from the sphere through the means: |m − c|² = r²
    sol = np.linalg.lstsq(np.column_stack([2 * means, np.ones(len(means))]), (means**2).sum(axis=1), rcond=None)[0]
    ups = means - sol[:3]
    for u, v in zip(ups[:-1], ups[1:]):
        angle = np.degrees(np.arccos(np.clip(u @ v / np.linalg.norm(u) / np.linalg.norm(v), -1, 1)))
        assert angle > 2.0, angle


def test_ellipsoid_search_that_stops_short_is_refused(monkeypatch):
    """A calibration is never taken from a least-squares search that did not converge (scipy's status is read)."""
    from types import SimpleNamespace

    from gyrojax.data import segments

    rng = np.random.default_rng(0)
    means = rng.normal(size=(12, 3))
    means /= np.linalg.norm(means, axis=1, keepdims=True)
    good = segments.ellipsoid_accelerometer(means * 1000.0 + 5.0, 1.0, 1e-3, np.zeros(3))
    np.testing.assert_allclose(good[3:6], 1e-3, rtol=1e-6)  # the unit sphere scaled by 1000 about (5, 5, 5)
    np.testing.assert_allclose(good[6:9], 5.0, atol=1e-6)
    stopped = SimpleNamespace(success=False, message="The maximum number of function evaluations is exceeded.", x=good)
    monkeypatch.setattr(segments.optimize, "least_squares", lambda *a, **k: stopped)
    with pytest.raises(RecordError, match="did not converge .*maximum number"):
        segments.ellipsoid_accelerometer(means * 1000.0 + 5.0, 1.0, 1e-3, np.zeros(3))


# ---- 6. a logger's preamble before the header, and a real MPU-6050 session that has one (tests/data/mpu6050) --------

MPU = IMUCAL.parent / "mpu6050"
MPU_MAP = "gyro_x=gx,gyro_y=gy,gyro_z=gz,acc_x=ax,acc_y=ay,acc_z=az"


def mpu_argv(out, *options) -> list:
    """``gyrojax import csv`` of the vendored MPU-6050 session (raw counts, nominal 131 counts per deg/s, 100 Hz)."""
    path = MPU / "example_data_calibration.csv.gz"
    units_ = ["--rate-hz", "100", "--gyro-unit", "counts", "--gyro-scale", "131", "--acc-unit", "counts"]
    return ["import", "csv", str(path), "--map", MPU_MAP, *units_, *options, "--out", str(out)]


@pytest.mark.parametrize("flag", [None, ","])
def test_a_loggers_preamble_is_skipped_and_said(session, tmp_path, capsys, flag):
    rec, _ = session
    plain = write_log(tmp_path / "plain.csv", log_columns(rec))
    pre = tmp_path / "pre.csv"  # two lines that split alike by ',' themselves, a blank line and a device name
    pre.write_text("Fs,100\nLogging Type,0\n\ndevice: MPU-6050\n" + plain.read_text())
    assert main(csv_argv(pre, tmp_path / "o", *(["--delimiter", flag] if flag else []))) == 0
    text = capsys.readouterr().out
    said = "3 line(s) before the table's header (line 5) skipped: 'Fs,100'; 'Logging Type,0'; 'device: MPU-6050'"
    assert said in text
    assert main(csv_argv(plain, tmp_path / "p")) == 0
    assert "before the table's header" not in capsys.readouterr().out
    (a,), (b,) = load_records(tmp_path / "o"), load_records(tmp_path / "p")
    for k in b.columns:
        assert np.array_equal(a.columns[k], b.columns[k]), k


def test_a_bad_cell_after_a_preamble_is_named_by_its_line_in_the_file(session, tmp_path):
    rec, _ = session
    lines = write_log(tmp_path / "plain.csv", log_columns(rec)).read_text().splitlines()
    cells = lines[3].split(",")  # the third data row
    cells[2] = "oops"  # column gy
    lines[3] = ",".join(cells)
    bad = tmp_path / "bad.csv"
    bad.write_text("Fs,100\nLogging Type,0\n" + "\n".join(lines) + "\n")  # header on line 3: that row is line 6
    with pytest.raises(RecordError, match=r"row 6, column 'gy' is not a finite number: 'oops'"):
        import_csv(bad, dict(kv.split("=") for kv in MAP.split(",")))


def test_a_table_without_a_header_is_refused_as_such(session, tmp_path):
    rec, _ = session
    path = tmp_path / "bare.csv"
    np.savetxt(path, np.column_stack(list(log_columns(rec).values()))[:200], delimiter=",")
    with pytest.raises(RecordError, match="no header line naming its columns .* split alike by ','"):
        import_csv(path, dict(kv.split("=") for kv in MAP.split(",")))


def test_spaces_after_the_delimiter_and_a_byte_order_mark_are_no_part_of_a_name(session, tmp_path):
    """A spreadsheet's export: a UTF-8 byte order mark before the header and ", " between fields."""
    rec, _ = session
    plain = write_log(tmp_path / "plain.csv", log_columns(rec))
    spaced = tmp_path / "spaced.csv"
    spaced.write_text(plain.read_text().replace(",", ", "), encoding="utf-8-sig")
    mapping = dict(kv.split("=") for kv in MAP.split(","))
    a, b = import_csv(spaced, mapping), import_csv(plain, mapping)
    for k in b.columns:
        assert np.array_equal(a.columns[k], b.columns[k]), k


@pytest.mark.parametrize("flag", [None, ";"])
def test_a_european_log_with_decimal_commas(session, tmp_path, capsys, flag):
    """';' between fields and ',' before the decimals: read as the plain file, and said."""
    rec, _ = session
    plain = write_log(tmp_path / "plain.csv", log_columns(rec))
    euro = tmp_path / "euro.csv"
    euro.write_text(plain.read_text().replace(",", ";").replace(".", ","))
    assert main(csv_argv(euro, tmp_path / "e", *(["--delimiter", flag] if flag else []))) == 0
    assert "decimal commas read" in capsys.readouterr().out
    assert main(csv_argv(plain, tmp_path / "p")) == 0
    assert "decimal commas" not in capsys.readouterr().out
    (a,), (b,) = load_records(tmp_path / "e"), load_records(tmp_path / "p")
    for k in b.columns:
        assert np.array_equal(a.columns[k], b.columns[k]), k


def test_iso_date_times_and_epoch_nanoseconds_are_clocks(session, tmp_path, capsys):
    """A phone logger's clocks: ISO 8601 date-times (read without --time-unit, and said) and nanoseconds since the
    epoch (--time-unit ns) give the times of the plain log in seconds (to the date-times' microsecond)."""
    import datetime as dt

    rec, _ = session
    base = dt.datetime(2026, 3, 1, 12, 0, 0)
    iso = [(base + dt.timedelta(seconds=float(x))).isoformat(timespec="microseconds") for x in rec.time_s]
    lines = write_log(tmp_path / "plain.csv", log_columns(rec)).read_text().splitlines()

    def with_clock(name, stamps):  # the plain log with its time column replaced
        body = [f"{c},{ln.split(',', 1)[1]}" for c, ln in zip(stamps, lines[1:])]
        (tmp_path / name).write_text("\n".join([lines[0], *body]) + "\n")
        return tmp_path / name

    assert main(csv_argv(with_clock("iso.csv", iso), tmp_path / "i")) == 0
    said = "time column 't' read as ISO 8601 date-times (s since the first, 2026-03-01T12:00:00"
    assert said in capsys.readouterr().out
    (a,) = load_records(tmp_path / "i")
    assert np.allclose(a.time_s, rec.time_s - rec.time_s[0], atol=1e-6, rtol=0)
    epoch = [str(1_772_366_400_000_000_000 + int(round(x * 1e9))) for x in rec.time_s]
    assert main(csv_argv(with_clock("ns.csv", epoch), tmp_path / "n", "--time-unit", "ns")) == 0
    (b,) = load_records(tmp_path / "n")
    assert np.allclose(b.time_s, rec.time_s - rec.time_s[0], atol=1e-6, rtol=0)


@pytest.mark.parametrize("flag", [None, ","])
def test_a_row_a_field_short_is_named(session, tmp_path, flag):
    """Detected, the delimiter no longer splits the header like the lines after it: the refusal says a row may have
    a field too many or too few; given, the short row's empty cell is named by its line."""
    rec, _ = session
    lines = write_log(tmp_path / "plain.csv", log_columns(rec)).read_text().splitlines()
    lines[4] = lines[4].rsplit(",", 1)[0]  # file line 5 loses its last field (az)
    path = tmp_path / "ragged.csv"
    path.write_text("\n".join(lines) + "\n")
    mapping = dict(kv.split("=") for kv in MAP.split(","))
    want = "a field too many or too few" if flag is None else r"row 5, column 'az' is empty \(a field missing"
    with pytest.raises(RecordError, match=want):
        import_csv(path, mapping, delimiter=flag)


def test_mpu6050_session_has_too_few_rests_for_the_default_detection_which_says_why(tmp_path, capsys):
    """The hand session's poses are held for well under the default 0.5 s of quiet: the import refuses, naming the
    poses found and every candidate it dropped, with its time and reason."""
    assert main(mpu_argv(tmp_path / "o")) == 2
    err = capsys.readouterr().err
    assert "found 5 static poses; the calibration needs at least 9" in err
    assert "22 candidate rests dropped" in err and "too short" in err and "too noisy" in err
    assert not (tmp_path / "o").exists()


def test_mpu6050_session_with_a_looser_detection_says_its_accelerometer_is_poorly_determined(tmp_path, capsys):
    """With rests of 0.2 s and 20× the rest noise variance, 10 rests: the accelerometer's ellipsoid (9 parameters)
    fits them to 0.016 % — which checks nothing, and the note says so: the y axis never points up (+0.66 g at most),
    so its scale factor is determined to ±34 % only at 0.1 % of g per rest (the Xsens session's 38 rests: ±0.03 %).
    The gyro biases, which the 36.5 s initial rest pins, agree with the authors' (tests/data/mpu6050/README.md)."""
    assert main(mpu_argv(tmp_path / "o", "--min-rest", "0.2", "--static-threshold", "20")) == 0
    out = capsys.readouterr().out
    assert "4 line(s) before the table's header (line 5) skipped: 'Fs,100'; 'Logging Type,0'" in out
    assert "the 10 rests determine the accelerometer's calibration poorly" in out
    (rec,) = load_records(tmp_path / "o")
    std = rec.meta["accelerometer_calibration"]["std_at_rest_error"]
    assert std["scale"][1] > 0.1 and max(std["scale"][0], std["scale"][2]) < 0.02
    fit = fit_triad(rec)
    said = [n for n in fit.notes if "determine the accelerometer's calibration poorly" in n]
    assert said and "the gyro's standard errors do not include that error" in said[0]
    # the fit sees it on the record's own rests, as a record another tool wrote would carry them (no import report)
    assert fit.to_json()["accelerometer"]["std_at_rest_error"]["scale"][1] > 0.1
    bare = replace(rec, meta={k: v for k, v in rec.meta.items() if k not in ("import", "accelerometer_calibration")})
    assert any("determine the accelerometer's calibration poorly" in n for n in fit_triad(bare).notes)
    theirs = np.loadtxt(MPU / "params_gyro.csv")[9:12] / 131.0 * 3600.0  # their biases, counts → deg/h
    for c, b in zip("xyz", theirs):
        assert abs(fit.values[f"D_F[{c}]"] - b) < 2.0 * fit.stds[f"D_F[{c}]"], (c, fit.values[f"D_F[{c}]"], b)


@pytest.mark.parametrize("n_rests, one_sided", [(38, False), (10, True)])
def test_accelerometer_standard_errors_are_those_of_a_monte_carlo_of_the_ellipsoid_fit(n_rests, one_sided):
    """The stated standard errors of the ellipsoid calibration (linearised least squares at 0.1 % of g per rest)
    against 400 refits of rests whose |a| err by that much: every scale factor and bias within 15 % of the
    spread of the refits (400 draws: the spread's own error is 3.5 %; the one-sided case is the less linear)."""
    from gyrojax.data.accelcheck import REST_ERROR_G, determinacy
    from gyrojax.data.segments import ellipsoid_accelerometer, imutk_acc_model

    rng = np.random.default_rng(11)
    truth = np.array([2e-3, -1e-3, 3e-3, 6.1e-5, 6.0e-5, 5.9e-5, 400.0, -200.0, 900.0])
    u = rng.normal(size=(n_rests, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    if one_sided:  # y never within 30° of up, as in the MPU-6050 session
        u[:, 1] = np.minimum(u[:, 1], 0.6)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
    tk = imutk_acc_model(truth, np.eye(3) + truth[6:9]).T  # T K, from the model's response to unit raw steps
    raw_of = lambda a: np.linalg.solve(tk, a.T).T + truth[6:9]  # noqa: E731
    stated, _ = determinacy(truth, raw_of(u), 1.0)
    fits = []
    for _ in range(400):
        a = u * (1.0 + REST_ERROR_G * rng.normal(size=(n_rests, 1)))
        fits.append(ellipsoid_accelerometer(raw_of(a), 1.0, 6e-5, truth[6:9]))
    fits = np.array(fits)
    spread = {"scale": fits[:, 3:6].std(axis=0) / truth[3:6], "bias": fits[:, 6:9].std(axis=0) * truth[3:6]}
    for k in ("scale", "bias"):
        assert np.allclose(stated[k], spread[k], rtol=0.15), (k, stated[k], spread[k])
