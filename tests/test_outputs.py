"""Traces and tables round-trip through Parquet with units and provenance intact."""

import dataclasses
import importlib.metadata
import json

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from pih.__main__ import main
from pih.records import provenance
from pih.records.outputs import (
    TRACE_COLUMNS,
    provenance_index,
    read_provenance,
    read_trace,
    read_units,
    write_table,
    write_text,
    write_trace,
)
from pih.records.provenance import file_sha256, input_sha256
from pih.scene.trace import RobotTrajectory

RECORD = provenance.record("job", config={"a": 1})


@pytest.fixture(scope="module")
def trace(scene):
    t = np.arange(0.0, 0.4, 0.002)
    q0 = scene.peg_top_from_bottom([-0.001, scene.config.hole.top_y_m + 0.0005, 0.0])
    poses = q0 + np.outer(t, [0.0, -0.005, 0.0])
    return scene.rollout(RobotTrajectory(t, poses))


def test_trace_round_trip_with_provenance(tmp_path, trace, scene, capsys):
    record = provenance.record(
        "unit_test",
        point={"offset_mm": 1.0},
        seeds={"noise": 7},
        config={"a": 1},
        simulator=scene.config.simulator_settings(),
    )
    path = tmp_path / "trace.parquet"
    write_trace(trace, path, record)
    back = read_trace(path)
    scalars = ("status", "reason", "time_step_s")
    arrays = [f.name for f in dataclasses.fields(trace) if f.name not in scalars]
    assert len(arrays) == 11
    for name in arrays:
        assert np.array_equal(getattr(back, name), getattr(trace, name)), name
    assert [getattr(back, name) for name in scalars] == [getattr(trace, name) for name in scalars]
    stored = read_provenance(path)
    assert stored == json.loads(json.dumps(record))
    assert stored["run_id"] == "unit_test/offset_mm=1.0"
    assert stored["simulator"]["discrete_contact_approximation"] == "lagged"
    assert stored["packages"]["drake"] == importlib.metadata.version("drake")
    units = read_units(path)
    assert units["contact_fx_n"] == "N" and units["spring_energy_j"] == "J"
    assert set(units) == set(TRACE_COLUMNS)
    # pandas' own schema metadata survives next to ours.
    assert b"pandas" in pq.read_schema(path).metadata
    # Stored losslessly smaller than Parquet's default: zstd, floats byte-stream split.
    column = pq.ParquetFile(path).metadata.row_group(0).column(1)
    assert column.compression == "ZSTD" and "BYTE_STREAM_SPLIT" in column.encodings
    assert main(["provenance", str(path), "--key", "seeds"]) == 0
    assert '"noise": 7' in capsys.readouterr().out


def test_failed_write_leaves_existing_file_untouched(tmp_path, trace):
    path = tmp_path / "trace.parquet"
    write_trace(trace, path, provenance.record("first"))
    before = path.read_bytes()
    with pytest.raises(TypeError):
        write_trace(trace, path, {"not_serialisable": object()})
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["trace.parquet"]


def test_provenance_cli_reports_missing_record(tmp_path, capsys):
    import pandas as pd

    path = tmp_path / "plain.parquet"
    pd.DataFrame({"a": [1]}).to_parquet(path)
    assert main(["provenance", str(path)]) == 1
    assert "no pih.provenance record" in capsys.readouterr().err


def test_input_hash_covers_the_data_not_the_provenance(tmp_path):
    frame = pd.DataFrame({"x_m": [0.0, 1.0]})
    columns = {"x_m": ("m", "position")}
    first, second, other = (tmp_path / f"{n}.parquet" for n in ("a", "b", "c"))
    write_table(frame, first, {"run_id": "a", "created_utc": "2026-01-01"}, columns)
    write_table(frame, second, {"run_id": "a", "created_utc": "2026-02-02"}, columns)
    write_table(frame.assign(x_m=[0.0, 2.0]), other, {"run_id": "a"}, columns)
    assert file_sha256(first) != file_sha256(second)
    assert input_sha256(first) == input_sha256(second)
    assert input_sha256(first) != input_sha256(other)


def test_every_kind_of_output_is_listed_with_a_record(tmp_path):
    table = tmp_path / "t.parquet"
    write_table(pd.DataFrame({"x_m": [0.0]}), table, RECORD, {"x_m": ("m", "x")})
    markdown = tmp_path / "t.md"
    write_text(markdown, "| a |\n|---|\n| 1 |", RECORD)
    csv = tmp_path / "t.csv"
    write_text(csv, "a\n1\n")
    index = provenance_index([table, markdown, csv], {str(csv): str(table)})
    assert index["run_id"].tolist() == ["job", "job", "job"]
    assert index["record_in"].tolist() == ["itself", "itself", str(table)]
    assert markdown.read_text().startswith("| a |")  # the record is a closing comment
    with pytest.raises(ValueError, match="only markdown"):
        write_text(csv, "a\n", RECORD)
