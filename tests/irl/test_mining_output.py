"""The output folder of a mining run: repair on entering, one row per id, fingerprint, lock."""

import json

import pytest

from drivestyle.irl.features import FeatureConfig
from drivestyle.irl.library import StyleLibrary
from drivestyle.irl.mining import COLUMNS, MinedRow
from drivestyle.irl.mining_output import (
    FINGERPRINT,
    TABLE,
    MiningOutput,
    MiningOutputError,
    RunFingerprint,
    read_rows,
)


def _library(risks=(0.5, 0.9)) -> StyleLibrary:
    fc = FeatureConfig()
    one = (1.0,) * len(fc.names)
    scenario = {"ev_speed": 20.0, "tv_speed": 18.0, "tv_gap": 20.0}
    members = tuple((one,) * 5 for _ in risks)
    return StyleLibrary(
        fc.feature_set, tuple(risks), tuple(one for _ in risks), fc, {}, members, (scenario,) * 5
    )


FP = RunFingerprint.of("/data/pop", "/libs/a", _library())


def _row(i: str) -> MinedRow:
    return MinedRow.failed(i, "pop", f"DemonstrationError: {i}.npz: not readable")


def _csv(*rows: MinedRow) -> str:
    lines = [COLUMNS, *([r.to_csv()[c] for c in COLUMNS] for r in rows)]
    return "".join(",".join(cells) + "\r\n" for cells in lines)


def test_a_torn_last_row_and_repeated_rows_are_dropped_on_entering(tmp_path):
    (tmp_path / FINGERPRINT).write_text(json.dumps(FP.to_json()))
    text = _csv(_row("v1"), _row("v1"), _row("v2")) + "v3,pop,fai"  # v3 killed mid-write
    (tmp_path / TABLE).write_text(text)
    with MiningOutput(tmp_path, FP) as out:
        assert out.repaired == 2
        assert [r.id for r in out.rows] == ["v1", "v2"]
        assert out.append(_row("v3")) and not out.append(_row("v1"))
    assert [r.id for r in read_rows(tmp_path / TABLE)] == ["v1", "v2", "v3"]
    assert (tmp_path / TABLE).read_text().count("\n") == 4  # header + 3 rows, none glued


def test_read_rows_skips_a_torn_last_row_without_repairing(tmp_path):
    (tmp_path / TABLE).write_text(_csv(_row("v1")) + "v2,pop")
    assert [r.id for r in read_rows(tmp_path / TABLE)] == ["v1"]
    assert (tmp_path / TABLE).read_text().endswith("v2,pop")
    (tmp_path / "other.csv").write_text("a,b\n1,2\n")
    with pytest.raises(MiningOutputError, match=r"not a styles\.csv"):
        read_rows(tmp_path / "other.csv")


def test_the_fingerprint_is_the_input_and_the_library_content():
    moved = RunFingerprint.of("/data/pop", "/elsewhere/a", _library())
    assert FP.same_run(moved)  # a moved copy of the same library
    assert not FP.same_run(RunFingerprint.of("/data/other", "/libs/a", _library()))
    assert not FP.same_run(RunFingerprint.of("/data/pop", "/libs/a", _library((0.5, 0.8))))
    assert RunFingerprint.from_json(json.loads(json.dumps(FP.to_json()))) == FP
    with pytest.raises(ValueError, match="fingerprint"):
        RunFingerprint.from_json({"input": "/data/pop"})


def test_force_deletes_only_the_earlier_runs_results(tmp_path):
    with MiningOutput(tmp_path, FP) as out:
        out.append(_row("v1"))
    (tmp_path / "notes.txt").write_text("mine")
    other = RunFingerprint.of("/data/other", "/libs/a", _library())
    with pytest.raises(MiningOutputError, match="another run"):
        MiningOutput(tmp_path, other).__enter__()
    with MiningOutput(tmp_path, other, force=True) as out:
        assert out.rows == []
    assert (tmp_path / "notes.txt").read_text() == "mine"
    assert json.loads((tmp_path / FINGERPRINT).read_text())["input"] == "/data/other"


def test_the_lock_is_held_inside_the_with_block_only(tmp_path):
    with MiningOutput(tmp_path, FP):
        with pytest.raises(MiningOutputError, match="in use by another mining run"):
            MiningOutput(tmp_path, FP).__enter__()
    with MiningOutput(tmp_path, FP) as out:
        out.append(_row("v1"))
    with pytest.raises(RuntimeError, match="outside"):
        out.append(_row("v2"))
