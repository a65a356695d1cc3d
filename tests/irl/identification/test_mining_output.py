"""The output folder of a mining run: repair on entering, one row per id, fingerprint, lock."""

import dataclasses
import json
import os
import signal
import subprocess
import sys

import pytest

from drivestyle.common.output_lock import lock_file
from drivestyle.irl.identification.library import StyleLibrary
from drivestyle.irl.identification.mined_row import COLUMNS, MinedRow
from drivestyle.irl.identification.mining_output import (
    FINGERPRINT,
    TABLE,
    MiningOutput,
    MiningOutputError,
    RunFingerprint,
    read_rows,
    read_table,
)
from drivestyle.irl.paper.features import FeatureConfig


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


def _ok(i: str) -> MinedRow:
    return MinedRow(i, "pop", "ok", risk_estimate=0.7, risk_lo=0.6, risk_hi=0.8, risk_mean=0.7,
                    theta_normalised=(1.0,))  # fmt: skip


def test_a_row_out_of_range_is_mined_again_on_resume_and_refused_by_a_reader(tmp_path):
    # a posterior mean of 7.5 is no risk: a damaged row, however it got there
    (tmp_path / FINGERPRINT).write_text(json.dumps(FP.to_json()))
    cells = _ok("v1").to_csv() | {"risk_mean": "7.5"}
    header, v2 = _csv(_ok("v2")).splitlines(keepends=True)
    (tmp_path / TABLE).write_text(header + ",".join(f'"{cells[c]}"' for c in COLUMNS) + "\r\n" + v2)
    with pytest.raises(MiningOutputError, match=r"row 1 \(line 2\) \(id v1\): risk_mean 7\.5 "
                       r"is not a risk in \(0, 1\)"):  # fmt: skip
        read_table(tmp_path / TABLE)
    with MiningOutput(tmp_path, FP) as out:  # the resumed run drops it: v1 is mined again
        assert out.repaired == 1 and [r.id for r in out.rows] == ["v2"]
    assert [r.id for r in read_table(tmp_path / TABLE)] == ["v2"]


@pytest.mark.parametrize(
    ("field", "value"),
    [("risk_lo", 0.0), ("risk_hi", 1.0), ("true_risk", 1.5), ("rmse_y_m", -0.1),
     ("kl_nats", float("nan")), ("iterations", -1), ("interval_width_ratio", float("inf"))],
)  # fmt: skip
def test_a_mined_row_refuses_a_number_outside_its_range(field, value):
    with pytest.raises(ValueError, match=f"row v1: {field} "):
        dataclasses.replace(_ok("v1"), **{field: value})


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


_FP_CODE = (
    "import json\n"
    "from drivestyle.irl.identification.mining_output import MiningOutput, RunFingerprint\n"
    f"FP = RunFingerprint.from_json(json.loads({json.dumps(FP.to_json())!r}))"
)
"""Code that makes :data:`FP` in another process."""

_HOLD = """
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT)
fcntl.flock(fd, fcntl.LOCK_EX)
os.ftruncate(fd, 0)
os.pwrite(fd, sys.argv[2].encode(), 0)
print("locked", flush=True)
time.sleep(60)
"""


def _hold_lock(path, record: str) -> subprocess.Popen:
    """A process holding ``path``'s flock with ``record`` in it (as an orphaned worker would)."""
    proc = subprocess.Popen(
        [sys.executable, "-c", _HOLD, str(path), record], stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None and proc.stdout.readline().strip() == "locked"
    return proc


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs /proc")
def test_a_lock_whose_run_is_gone_is_taken_over_with_a_notice(tmp_path, capfd):
    dead = _dead_pid()
    holder = _hold_lock(lock_file(tmp_path), f"{dead} 12345")
    try:
        with MiningOutput(tmp_path, FP) as out:
            out.append(_row("v1"))
            assert (lock_file(tmp_path)).read_text().split()[0] == str(os.getpid())
        err = capfd.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"taking over the lock of pid {dead}" in err[0]
    finally:
        holder.kill()
        holder.wait()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs /proc")
def test_a_lock_whose_pid_now_names_another_process_is_taken_over(tmp_path, capfd):
    # the holder's pid is alive, but its start time is not the one the lock recorded
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        sleeper = _hold_lock(lock_file(tmp_path), f"{holder.pid} 1")
        try:
            with MiningOutput(tmp_path, FP):
                pass
            assert f"taking over the lock of pid {holder.pid}" in capfd.readouterr().err
        finally:
            sleeper.kill()
            sleeper.wait()
    finally:
        holder.kill()
        holder.wait()


def test_a_live_holder_is_refused_naming_its_pid(tmp_path):
    code = (
        "import sys, time\n"
        f"{_FP_CODE}\n"
        "with MiningOutput(sys.argv[1], FP):\n"
        "    print('locked', flush=True)\n"
        "    time.sleep(60)\n"
    )
    holder = subprocess.Popen(
        [sys.executable, "-c", code, str(tmp_path)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "locked"
        with pytest.raises(MiningOutputError, match=rf"in use .* \(pid {holder.pid}\)"):
            MiningOutput(tmp_path, FP).__enter__()
    finally:
        holder.kill()
        holder.wait()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_forked_child_does_not_keep_the_lock_of_a_killed_parent(tmp_path, capfd):
    # the parent takes the lock, forks a worker and dies without releasing it
    code = (
        "import os, sys, time\n"
        f"{_FP_CODE}\n"
        "out = MiningOutput(sys.argv[1], FP).__enter__()\n"
        "child = os.fork()\n"
        "if child == 0:\n"
        "    os.closerange(0, 3)\n"  # the test reads the parent's output to its end
        "    time.sleep(60)\n"
        "    os._exit(0)\n"
        "print(child, flush=True)\n"
        "os._exit(0)\n"
    )
    parent = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, check=True
    )
    child = int(parent.stdout)
    try:
        with MiningOutput(tmp_path, FP):
            pass
        # free: the child had dropped its copy; the notice says the last run was killed
        assert "ended without releasing it" in capfd.readouterr().err
    finally:
        os.kill(child, signal.SIGKILL)


def test_infrastructure_failures_are_retried_and_data_failures_are_final(tmp_path):
    (tmp_path / FINGERPRINT).write_text(json.dumps(FP.to_json()))
    crashed = MinedRow.failed("v2", "pop", "the worker process was killed", kind="infrastructure")
    (tmp_path / TABLE).write_text(_csv(_row("v1"), crashed))
    with MiningOutput(tmp_path, FP) as out:
        assert out.retrying == ["v2"] and out.finished_ids() == {"v1"}
        assert out.append(_row("v2"))
    assert [(r.id, r.failure_kind) for r in read_rows(tmp_path / TABLE)] == [
        ("v1", "data"),
        ("v2", "data"),
    ]


@pytest.mark.parametrize(
    "version", ["before failure_kind", "before the verdict", "before the label"]
)
def test_a_table_of_an_earlier_version_is_read_and_rewritten(tmp_path, version):
    from drivestyle.irl.identification.mined_row import (
        LEGACY_COLUMNS,
        PRE_LABEL_COLUMNS,
        PRE_VERDICT_COLUMNS,
    )

    (tmp_path / FINGERPRINT).write_text(json.dumps(FP.to_json()))
    legacy = {"before failure_kind": LEGACY_COLUMNS, "before the verdict": PRE_VERDICT_COLUMNS,
              "before the label": PRE_LABEL_COLUMNS}[version]  # fmt: skip
    row = _row("v1").to_csv()
    (tmp_path / TABLE).write_text(
        ",".join(legacy) + "\r\n" + ",".join(row[c] for c in legacy) + "\r\n"
    )
    with MiningOutput(tmp_path, FP) as out:
        assert [(r.id, r.failure_kind) for r in out.rows] == [("v1", "data")]
        out.append(_row("v2"))
    assert (tmp_path / TABLE).read_text().splitlines()[0] == ",".join(COLUMNS)
    assert [r.id for r in read_rows(tmp_path / TABLE)] == ["v1", "v2"]
