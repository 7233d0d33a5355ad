"""Damaged and inconsistent result files: ``SimulationResult.load`` raises one ResultFileError
naming the file (never a raw zipfile/json/numpy/pyarrow error), and never returns data that
differ from what was saved."""

from __future__ import annotations

import io
import json
import random

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from armlab.errors import ResultFileError
from armlab.simulation.results import FORMATS, SimulationResult
from synthetic_results import assert_same, synthetic_result

ORIGINAL = synthetic_result(3, rows=300, status="diverged")


def _must_refuse(path):
    with pytest.raises(ResultFileError) as caught:
        SimulationResult.load(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: ") and "\n" not in message, message
    return message


def _refused_or_intact(path):
    """A damaged copy either raises ResultFileError or loads exactly the saved data (a flip
    in bytes the reader never uses, such as padding)."""
    try:
        loaded = SimulationResult.load(path)
    except ResultFileError as error:
        assert str(error).startswith(f"{path}: ") and "\n" not in str(error)
        return "refused"
    assert_same(loaded, ORIGINAL)
    return "intact"


@pytest.fixture(params=FORMATS)
def saved(request, tmp_path):
    return ORIGINAL.save(tmp_path / f"good{request.param}")


def test_truncated_files_are_refused(saved):
    data = saved.read_bytes()
    cuts = {0, 1, 7, 64, len(data) // 3, len(data) // 2, len(data) - 200, len(data) - 9, len(data) - 1}
    for cut in sorted(cuts):
        damaged = saved.with_name(f"cut{cut}{saved.suffix}")
        damaged.write_bytes(data[:cut])
        _must_refuse(damaged)


def test_flipped_bytes_never_load_wrong_data(saved):
    data = saved.read_bytes()
    rng = random.Random(43)
    positions = sorted({*range(0, len(data), max(1, len(data) // 60)), *rng.sample(range(len(data)), 40)})
    outcomes = []
    for position in positions:
        damaged = saved.with_name(f"flip{position}{saved.suffix}")
        damaged.write_bytes(data[:position] + bytes([data[position] ^ 0x5A]) + data[position + 1:])
        outcomes.append(_refused_or_intact(damaged))
    assert outcomes.count("refused") > len(outcomes) // 2


def test_a_file_of_another_kind_is_refused(tmp_path):
    for suffix in FORMATS:
        path = tmp_path / f"other{suffix}"
        path.write_bytes(b"\xff\xfe not a result \x00\x01" * 20)
        _must_refuse(path)
    np.savez(tmp_path / "plain.npz", a=np.zeros(3))
    assert "not an armlab result" in _must_refuse(tmp_path / "plain.npz")
    pq.write_table(pa.table({"t": [0.0, 1.0]}), tmp_path / "plain.parquet")
    assert "not an armlab result" in _must_refuse(tmp_path / "plain.parquet")
    (tmp_path / "plain.csv").write_text("t,q\n0,1\n")
    assert "not an armlab result" in _must_refuse(tmp_path / "plain.csv")
    _must_refuse(tmp_path / "absent.npz")
    (tmp_path / "folder.csv").mkdir()
    _must_refuse(tmp_path / "folder.csv")


# ------------------------------------------------------------------- inconsistent NPZ files

def _npz_parts(path):
    with np.load(path) as data:
        return json.loads(str(data["header"])), {k: data[k] for k in data.files if k != "header"}


def _write_npz(path, header, arrays):
    with open(path, "wb") as handle:
        np.savez(handle, header=np.array(json.dumps(header)), **arrays)
    return path


@pytest.mark.parametrize("edit, expected", [
    (lambda h, a: a.pop("g_q_err"), "missing"),
    (lambda h, a: a.update(g_extra=np.zeros((300, 1))), "not in the header"),
    (lambda h, a: a.update(g_q_err=a["g_q_err"][:5]), "shape"),
    (lambda h, a: a.update(t=np.stack([a["t"], a["t"]], axis=1)), "t:"),
    (lambda h, a: a.update(t=a["t"][::-1].copy()), "increasing"),
    (lambda h, a: a.update(g_q=a["g_q"].astype(np.int64)), "floats"),
    (lambda h, a: a.update(g_q=a["g_q"][:, :2]), "shape"),
    (lambda h, a: h["layout"][1][1].pop(), "labels"),
    (lambda h, a: h["layout"].pop(0), "layout"),
    (lambda h, a: h["layout"].append(h["layout"][0]), "twice"),
    (lambda h, a: h.update(status="fine"), "status"),
    (lambda h, a: h.pop("diagnosis"), "diagnosis"),
    (lambda h, a: h.pop("crc32"), "crc32"),
    (lambda h, a: h["meta"].update(dt=2e-3), "checksum"),
    (lambda h, a: a["g_tau"].__setitem__((10, 1), 0.5), "checksum"),
    (lambda h, a: h.update(layout="q"), "layout"),
])
def test_inconsistent_npz_files_are_refused(tmp_path, edit, expected):
    header, arrays = _npz_parts(ORIGINAL.save(tmp_path / "good.npz"))
    edit(header, arrays)
    assert expected in _must_refuse(_write_npz(tmp_path / "bad.npz", header, arrays))


def test_npz_with_a_header_that_is_not_json_or_an_object_is_refused(tmp_path):
    _, arrays = _npz_parts(ORIGINAL.save(tmp_path / "good.npz"))
    for text in ("{not json", "[1, 2]", ""):
        path = tmp_path / "bad.npz"
        with open(path, "wb") as handle:
            np.savez(handle, header=np.array(text), **arrays)
        _must_refuse(path)
    np.savez(tmp_path / "pickled.npz", header=np.array([{"a": 1}], dtype=object), t=np.zeros(2))
    _must_refuse(tmp_path / "pickled.npz")


# ------------------------------------------------------------------- inconsistent CSV files

def _csv_lines(path):
    return path.read_text(encoding="utf-8").splitlines(keepends=True)


def test_csv_with_a_dropped_or_reordered_column_is_refused(tmp_path):
    lines = _csv_lines(ORIGINAL.save(tmp_path / "good.csv"))

    def without_column(line, k):
        cells = line.rstrip("\n").split(",")
        return ",".join(cells[:k] + cells[k + 1:]) + "\n"

    dropped = [lines[0]] + [without_column(line, 5) for line in lines[1:]]
    (tmp_path / "dropped.csv").write_text("".join(dropped))
    assert "missing" in _must_refuse(tmp_path / "dropped.csv")
    data_only = [lines[0], lines[1]] + [without_column(line, 5) for line in lines[2:]]
    (tmp_path / "short_rows.csv").write_text("".join(data_only))
    _must_refuse(tmp_path / "short_rows.csv")
    names = lines[1].rstrip("\n").split(",")
    names[1], names[2] = names[2], names[1]
    (tmp_path / "swapped.csv").write_text("".join([lines[0], ",".join(names) + "\n"] + lines[2:]))
    assert "order" in _must_refuse(tmp_path / "swapped.csv")


def test_csv_with_edited_values_rows_or_meta_is_refused(tmp_path):
    lines = _csv_lines(ORIGINAL.save(tmp_path / "good.csv"))
    cases = {
        "row_removed": lines[:100] + lines[101:],
        "last_row_removed": lines[:-1],
        "value_edited": lines[:50] + [lines[50].replace(",", ",1", 1)] + lines[51:],
        "meta_edited": [lines[0].replace('"seed": 3', '"seed": 4')] + lines[1:],
        "header_not_json": ["# armlab {oops\n"] + lines[1:],
        "no_newline_at_end": lines[:-1] + [lines[-1].rstrip("\n")],
    }
    for name, content in cases.items():
        assert "".join(content) != "".join(lines), name
        (tmp_path / f"{name}.csv").write_text("".join(content))
        _must_refuse(tmp_path / f"{name}.csv")
    (tmp_path / "latin1.csv").write_bytes("".join(lines).encode("utf-8") + "é,1\n".encode("latin-1"))
    _must_refuse(tmp_path / "latin1.csv")


# --------------------------------------------------------------- inconsistent Parquet files

def test_parquet_with_dropped_columns_or_edited_metadata_is_refused(tmp_path):
    table = pq.read_table(ORIGINAL.save(tmp_path / "good.parquet"))
    pq.write_table(table.drop_columns(["q.theta2"]), tmp_path / "dropped.parquet")
    assert "missing" in _must_refuse(tmp_path / "dropped.parquet")
    header = json.loads(table.schema.metadata[b"armlab"])
    header["status"] = "ok"
    pq.write_table(table.replace_schema_metadata({"armlab": json.dumps(header)}), tmp_path / "meta.parquet")
    assert "checksum" in _must_refuse(tmp_path / "meta.parquet")
    column = table.column("tau.d1").to_numpy().copy()
    column[3] += 1.0
    edited = table.set_column(table.column_names.index("tau.d1"), "tau.d1", pa.array(column))
    pq.write_table(edited, tmp_path / "value.parquet")
    assert "checksum" in _must_refuse(tmp_path / "value.parquet")
    texts = table.set_column(0, "t", pa.array([str(x) for x in table.column("t").to_pylist()]))
    pq.write_table(texts, tmp_path / "strings.parquet")
    _must_refuse(tmp_path / "strings.parquet")
    buffer = io.BytesIO()
    pq.write_table(table.slice(0, 100), buffer)
    (tmp_path / "rows.parquet").write_bytes(buffer.getvalue())
    assert "checksum" in _must_refuse(tmp_path / "rows.parquet")


def test_intact_files_load_exactly(tmp_path):
    for suffix in FORMATS:
        assert_same(SimulationResult.load(ORIGINAL.save(tmp_path / f"r{suffix}")), ORIGINAL)
