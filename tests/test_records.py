"""Record files: the independent examples load, and their instrument inputs agree with a plain-numpy
computation written from conventions §2–§4 alone (Rodrigues by scipy's Rotation)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gyrojax import units
from gyrojax.data import records
from gyrojax.data.arrays import record_data
from gyrojax.data.record import Record
from gyrojax.data.records import load_record
from gyrojax.errors import RecordError
from gyrojax.physics import model

from .conftest import EXAMPLES


def _numpy_inputs(rec):
    """Inputs along IA/OA/SA computed with scipy rotations and numpy only."""
    axes = rec.axes_enu
    ang = np.deg2rad(rec.angles_deg)
    rat = np.deg2rad(rec.rates_dps)
    lat = np.deg2rad(rec.latitude_deg)
    omega = units.OMEGA_IE * np.array([0.0, np.cos(lat), np.sin(lat)])
    f = np.array([0.0, 0.0, rec.gravity_mps2])
    out_w, out_a = [], []
    for th, rt in zip(ang, rat):
        c = np.eye(3)
        w = np.zeros(3)
        for u, t, r in zip(axes, th, rt):
            w = w + r * (c @ u)
            c = c @ Rotation.from_rotvec(u * t).as_matrix()
        wp = c.T @ (omega + w)
        fp = c.T @ f
        out_w.append(rec.triad @ wp / units.DEG_PER_H)
        out_a.append(rec.triad @ fp / units.G0)
    return np.array(out_w), np.array(out_a)


def test_every_example_loads_and_inputs_match_numpy(example_campaigns):
    for camp in example_campaigns:
        for name in camp["records"]:
            rec = load_record(EXAMPLES / f"{name}.json")
            assert rec.n > 1000
            data = record_data(rec)
            setup = model.setup_values(model.Model(()), np.zeros(0))
            x = model.instrument_inputs(data, setup)
            idx = np.linspace(0, rec.n - 1, 200).astype(int)
            sub = Record(rec.meta, {k: v[idx] for k, v in rec.columns.items()})
            w, a = _numpy_inputs(sub)
            np.testing.assert_allclose(np.asarray(x["w_I"])[idx], w[:, 0], rtol=0, atol=1e-9)
            np.testing.assert_allclose(np.asarray(x["w_O"])[idx], w[:, 1], rtol=0, atol=1e-9)
            np.testing.assert_allclose(np.asarray(x["w_S"])[idx], w[:, 2], rtol=0, atol=1e-9)
            for j, k in enumerate(("a_I", "a_O", "a_S")):
                np.testing.assert_allclose(np.asarray(x[k])[idx], a[:, j], rtol=0, atol=1e-12)


def test_load_by_either_path_and_roundtrip(tmp_path, example_campaigns):
    name = example_campaigns[0]["records"][0]
    a = load_record(EXAMPLES / f"{name}.csv")
    b = load_record(EXAMPLES / f"{name}.json")
    assert a.name == b.name == name
    records.save_record(a, tmp_path)
    c = load_record(tmp_path / f"{name}.json")
    for k in a.columns:
        np.testing.assert_array_equal(a.columns[k], c.columns[k])
    with pytest.raises(RecordError, match="exists"):
        records.save_record(a, tmp_path)
    df = c.to_pandas()
    assert "segment_id" in df and df.attrs["name"] == name


def test_csv_cells_with_blanks_and_quotes_parse_as_the_csv_module(tmp_path, example_campaigns):
    """Blanks and tabs around numbers, quoted cells after a blank, exponents and signs: every cell equals
    ``float()`` of what Python's csv module reads (skipinitialspace), whichever parsing path the loader takes."""
    import csv

    name = example_campaigns[0]["records"][0]
    rec = load_record(EXAMPLES / f"{name}.json")
    header = list(rec.columns)
    rng = np.random.default_rng(3)
    styles = ["{}", " {}", "{} ", "\t{}", '"{}"', ' "{}"', "  {}  "]
    lines = [",".join(header)]
    for i in range(50):
        cells = []
        for h in header:
            v = repr(float(rec.columns[h][i]))
            v = v if i % 7 else v.replace("e-", "E-")
            v = "+" + v if i % 5 == 0 and not v.startswith("-") else v
            cells.append(styles[rng.integers(len(styles))].format(v))
        lines.append(",".join(cells))
    for quoted in (False, True):
        text = "\n".join(lines if quoted else [ln.replace('"', "") for ln in lines]) + "\n"
        (tmp_path / f"{name}.csv").write_text(text)
        (tmp_path / f"{name}.json").write_bytes((EXAMPLES / f"{name}.json").read_bytes())
        got = load_record(tmp_path / f"{name}.json")
        rows = list(csv.reader(text.splitlines()[1:], skipinitialspace=True))
        for j, h in enumerate(header):
            np.testing.assert_array_equal(got.columns[h], [float(r[j]) for r in rows])


def test_csv_variants_load_the_same_values(tmp_path, example_campaigns):
    """A byte-order mark, Windows line ends, and an extra non-ASCII text column (kept as text) take the loader's
    other paths (bytes read and checked, text columns); the numeric columns come out equal to the plain file's."""
    name = example_campaigns[0]["records"][0]
    plain = (EXAMPLES / f"{name}.csv").read_bytes()
    ref = load_record(EXAMPLES / f"{name}.json")
    lines = plain.decode().splitlines()
    note = [lines[0] + ",note"] + [f"{ln},{'réglé à 20 °C' if i % 3 else 'ok'}" for i, ln in enumerate(lines[1:])]
    variants = {
        "bom": b"\xef\xbb\xbf" + plain,
        "crlf": plain.replace(b"\n", b"\r\n"),
        "text-column": ("\n".join(note) + "\n").encode(),
    }
    for label, data in variants.items():
        d = tmp_path / label
        d.mkdir()
        (d / f"{name}.csv").write_bytes(data)
        (d / f"{name}.json").write_bytes((EXAMPLES / f"{name}.json").read_bytes())
        got = load_record(d / f"{name}.json")
        for k, v in ref.columns.items():
            np.testing.assert_array_equal(got.columns[k], v, err_msg=label)
        if label == "text-column":
            assert got.columns["note"][1] == "réglé à 20 °C" and got.columns["note"][0] == "ok"


def test_plain_csv_reads_the_same_by_numpy_and_by_pandas(tmp_path, example_campaigns, monkeypatch):
    """A plain all-number CSV is read by numpy below a size and by pandas' parser above it: both give every cell
    bit for bit as Python's ``float()`` of its text (17 significant digits, exponents far from 1, signs), columns
    contiguous."""
    from gyrojax.data import csvfile

    name = example_campaigns[0]["records"][0]
    rec = load_record(EXAMPLES / f"{name}.json")
    header = list(rec.columns)
    rng = np.random.default_rng(5)
    n = 2000
    cells = rng.standard_normal((n, len(header))) * 10.0 ** rng.integers(-15, 15, (n, len(header)))
    text = [",".join(header)] + [",".join(f"{v:.17g}" for v in row) for row in cells]
    (tmp_path / f"{name}.csv").write_text("\n".join(text) + "\n")
    (tmp_path / f"{name}.json").write_bytes((EXAMPLES / f"{name}.json").read_bytes())
    want = np.array([[float(c) for c in line.split(",")] for line in text[1:]])
    for limit in (csvfile.NUMPY_READ_MAX_BYTES, 0):
        monkeypatch.setattr(csvfile, "NUMPY_READ_MAX_BYTES", limit)
        _, cols = csvfile.parse_csv(tmp_path / f"{name}.csv")
        for j, h in enumerate(header):
            assert cols[h].flags.c_contiguous and cols[h].dtype == np.float64
            np.testing.assert_array_equal(cols[h].view(np.int64), want[:, j].view(np.int64), err_msg=f"{limit} {h}")
