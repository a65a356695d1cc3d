"""mine_styles.py: one bad file never ends the job, and an output folder belongs to one run.

Fast: the inputs here are files that cannot be mined (each a failed row in milliseconds) and
the library is a valid stand-in, so the resume, fingerprint, repair and lock logic runs
without a solver. Mining real demonstrations is in
``tests/irl/identification/test_mining.py`` (slow).
"""

import csv
import json
import os
import socket
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from drivestyle.agents import generate_demonstration
from drivestyle.common.io import write_json
from drivestyle.common.output_lock import lock_file
from drivestyle.envs.demonstration import save_demonstration
from drivestyle.irl.identification.library import StyleLibrary
from drivestyle.irl.identification.mined_row import COLUMNS
from drivestyle.irl.identification.mining import Miner
from drivestyle.irl.identification.mining_output import (
    MiningOutput,
    MiningOutputError,
    RunFingerprint,
)
from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.scripts.mine_styles import main

ROOT = Path(__file__).resolve().parents[2]


def _library(risks=(0.5, 0.9)) -> StyleLibrary:
    """A valid library whose styles are placeholders (nothing here gets as far as scoring)."""
    fc = FeatureConfig()
    one = (1.0,) * len(fc.names)
    scenario = {"ev_speed": 20.0, "tv_speed": 18.0, "tv_gap": 20.0}
    return StyleLibrary(
        fc.feature_set,
        tuple(risks),
        tuple(one for _ in risks),
        fc,
        {},
        tuple((one,) * 5 for _ in risks),
        (scenario,) * 5,
    )


@pytest.fixture()
def lib(tmp_path) -> Path:
    path = tmp_path / "lib"
    write_json(path / "library.json", _library().to_json())
    return path


def _unminable(folder: Path, names) -> Path:
    """Files that load_demonstration rejects cleanly (a failed row each), each its own bytes
    (a byte copy would be mined once)."""
    folder.mkdir(parents=True, exist_ok=True)
    for n in names:
        (folder / f"{n}.npz").write_bytes(b"not a demonstration " + str(folder / n).encode())
    return folder


def _table(out: Path) -> list[dict]:
    with (out / "styles.csv").open(newline="") as fh:
        return list(csv.DictReader(fh))


def _mine(inp: Path, lib: Path, out: Path, *extra: str) -> dict:
    return main([str(inp), "--library", str(lib), "--out", str(out), "--workers", "1", *extra])


@pytest.fixture(scope="module")
def corrupt(tmp_path_factory) -> Path:
    """Files whose loading raised exceptions that escaped the failed-row path."""
    d = tmp_path_factory.mktemp("corrupt")
    demo = generate_demonstration(0.7, "paper")[0]
    save_demonstration(demo, d / "good.npz")
    raw = (d / "good.npz").read_bytes()
    (d / "good.npz").unlink()
    (d / "truncated.npz").write_bytes(raw[: len(raw) // 2])  # BadZipFile
    (d / "empty.npz").write_bytes(b"")  # EOFError
    return d


def test_corrupt_files_become_failed_rows_naming_the_file(corrupt, lib, tmp_path):
    out = tmp_path / "mined"
    payload = _mine(corrupt, lib, out)
    rows = {r["id"]: r for r in _table(out)}
    assert sorted(rows) == ["empty", "truncated"]
    for name, row in rows.items():
        assert row["status"] == "failed"
        assert str(corrupt / f"{name}.npz") in row["error"] and "\n" not in row["error"]
    assert payload["n_failed"] == 2
    # the failed rows are listed in summary.json, each with its error
    summary = json.loads((out / "summary.json").read_text())
    assert sorted(f["id"] for f in summary["failed"]) == ["empty", "truncated"]
    assert all(f["error"] == rows[f["id"]]["error"] for f in summary["failed"])
    # a rerun does not crash either: it skips the finished rows
    assert _mine(corrupt, lib, out)["n_this_run"] == 0


def test_another_input_or_library_is_refused_unless_forced(lib, tmp_path):
    a = _unminable(tmp_path / "a", ["v1", "v2"])
    b = _unminable(tmp_path / "b", ["v1", "v2", "v3"])  # same stems, other files
    out = tmp_path / "mined"
    _mine(a, lib, out)
    with pytest.raises(MiningOutputError, match=r"--force") as info:
        _mine(b, lib, out)
    assert str(a.resolve()) in str(info.value) and "\n" not in str(info.value)
    other = tmp_path / "lib2"
    write_json(other / "library.json", _library((0.5, 0.8)).to_json())
    with pytest.raises(MiningOutputError, match=r"library"):
        _mine(a, other, out)
    assert len(_table(out)) == 2  # nothing was written by the refused runs
    # --force starts over: only b's rows, credited to b
    payload = _mine(b, lib, out, "--force")
    rows = _table(out)
    assert sorted(r["id"] for r in rows) == ["v1", "v2", "v3"]
    assert {r["source"] for r in rows} == {str(b)}
    assert payload["n"] == 3 and payload["n_this_run"] == 3
    assert json.loads((out / "summary.json").read_text())["input"] == str(b.resolve())


def test_an_output_folder_of_an_older_version_is_refused(lib, tmp_path):
    a = _unminable(tmp_path / "a", ["v1"])
    out = tmp_path / "mined"
    out.mkdir()
    old_row = ["v0", "x", "failed", "DemonstrationError: v0.npz"] + [""] * (len(COLUMNS) - 4)
    (out / "styles.csv").write_text(",".join(COLUMNS) + "\n" + ",".join(old_row) + "\n")
    with pytest.raises(MiningOutputError, match=r"--force"):
        _mine(a, lib, out)
    assert _mine(a, lib, out, "--force")["n"] == 1


def test_a_torn_last_row_is_dropped_and_mined_again(lib, tmp_path):
    a = _unminable(tmp_path / "a", ["v1", "v2", "v3"])
    out = tmp_path / "mined"
    _mine(a, lib, out)
    text = (out / "styles.csv").read_text()
    # killed while writing the last row: a prefix of it, without its line end
    (out / "styles.csv").write_text(text[: text.rstrip().rfind("\n") + 12])
    payload = _mine(a, lib, out)
    rows = _table(out)
    assert sorted(r["id"] for r in rows) == ["v1", "v2", "v3"]
    assert all(r["status"] == "failed" and None not in r for r in rows)
    assert payload["n_this_run"] == 1 and payload["n"] == 3


def test_duplicate_rows_in_the_table_count_once(lib, tmp_path):
    a = _unminable(tmp_path / "a", ["v1", "v2"])
    out = tmp_path / "mined"
    _mine(a, lib, out)
    lines = (out / "styles.csv").read_text().splitlines(keepends=True)
    (out / "styles.csv").write_text("".join([*lines, lines[1]]))  # a row written twice
    payload = _mine(a, lib, out)
    assert payload["n"] == 2 and payload["n_this_run"] == 0
    assert sorted(r["id"] for r in _table(out)) == ["v1", "v2"]


def test_a_running_job_locks_its_output_folder(lib, tmp_path):
    a = _unminable(tmp_path / "a", ["v1"])
    out = tmp_path / "mined"
    _mine(a, lib, out)
    fingerprint = RunFingerprint.from_json(json.loads((out / "fingerprint.json").read_text()))
    with MiningOutput(out, fingerprint):
        with pytest.raises(MiningOutputError, match=r"another mining run") as info:
            _mine(a, lib, out)
        assert str(os.getpid()) in str(info.value)
    # a lock left by a process that was killed while holding it is no obstacle
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import json, sys, time\n"
            "from drivestyle.irl.identification.mining_output import MiningOutput, RunFingerprint\n"
            "fp = RunFingerprint.from_json(json.loads(open(sys.argv[2]).read()))\n"
            "with MiningOutput(sys.argv[1], fp):\n"
            "    print('locked', flush=True)\n"
            "    time.sleep(60)\n",
            str(out),
            str(out / "fingerprint.json"),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(MiningOutputError, match=rf"pid {holder.pid}\b"):
            _mine(a, lib, out)
    finally:
        holder.kill()
        holder.wait()
    # stale: its holder is dead (a released lock has no record)
    assert lock_file(out).read_text().split()[0] == str(holder.pid)
    assert _mine(a, lib, out)["n"] == 1


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_an_unreachable_ray_head_is_one_error_line(lib, tmp_path):
    pytest.importorskip("ray")
    a = _unminable(tmp_path / "a", ["v1"])
    address = f"127.0.0.1:{_free_port()}"  # nothing listens there
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "MPLBACKEND": "Agg"}
    env.pop("DRIVESTYLE_TRACEBACK", None)
    env.pop("RAY_ADDRESS", None)
    args = [str(a), "--library", str(lib), "--out", str(tmp_path / "o"), "--engine", "ray"]
    run = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "mine_styles.py"), *args, "--address", address],
        capture_output=True,
        text=True,
        timeout=60,  # before the fix, Ray retried for minutes
        env=env,
    )
    assert run.returncode == 2, run.stderr
    lines = [line for line in run.stderr.splitlines() if line.strip()]
    assert lines[-1].startswith("error: ") and address in lines[-1], run.stderr
    assert "Traceback" not in run.stderr


def _crash_on_boom(self, demo_id, source, demo):
    """Miner.mine of a test: the worker process dies on demonstration "boom"."""
    if demo_id == "boom":
        os._exit(3)
    return _REAL_MINE(self, demo_id, source, demo)


_REAL_MINE = Miner.mine


def test_a_crashed_worker_is_a_row_retried_on_resume(lib, tmp_path, monkeypatch, capsys):
    inp = _unminable(tmp_path / "in", ["a", "b", "boom"])
    out = tmp_path / "mined"
    monkeypatch.setattr(Miner, "mine", _crash_on_boom)
    first = _mine(inp, lib, out, "--workers", "2")
    rows = {r["id"]: r for r in _table(out)}
    assert sorted(rows) == ["a", "b", "boom"]  # before: the job died, no rows
    assert rows["boom"]["failure_kind"] == "infrastructure"
    assert "exited with status 3" in rows["boom"]["error"]
    assert rows["a"]["failure_kind"] == "data"
    assert first["n_failed_infrastructure"] == 1
    # the resumed run mines only the infrastructure failure again; data failures are final
    monkeypatch.setattr(Miner, "mine", _REAL_MINE)
    capsys.readouterr()
    second = _mine(inp, lib, out, "--workers", "2")
    assert "retrying 1 row(s)" in capsys.readouterr().out
    assert second["n_this_run"] == 1 and second["n"] == 3
    rows = {r["id"]: r for r in _table(out)}
    assert rows["boom"]["failure_kind"] == "data" and len(_table(out)) == 3


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_ids_do_not_change_when_a_same_named_file_comes_and_goes(lib, tmp_path):
    inp = _unminable(tmp_path / "in", [f"v{i}" for i in range(10)])
    out = tmp_path / "mined"
    assert _mine(inp, lib, out)["n"] == 10
    _unminable(inp / "sub", ["v3"])  # the same file name in a sub-folder
    second = _mine(inp, lib, out)
    # before: every id switched from stem to path, 21 rows for 11 demonstrations
    assert second["n"] == 11 and second["n_this_run"] == 1
    assert sorted(r["id"] for r in _table(out)) == sorted([f"v{i}" for i in range(10)] + ["sub/v3"])
    (inp / "sub" / "v3.npz").unlink()
    third = _mine(inp, lib, out)
    assert third["n"] == 10 and third["n_this_run"] == 0 and len(_table(out)) == 10


def test_rows_of_the_earlier_stem_ids_are_mapped_or_mined_again(lib, tmp_path, capsys):
    inp = tmp_path / "in"
    _unminable(inp / "a", ["v1"])
    _unminable(inp / "b", ["v2"])
    out = tmp_path / "mined"
    _mine(inp, lib, out)
    # make it an earlier version's folder: stem ids, a fingerprint without id_scheme
    fp = json.loads((out / "fingerprint.json").read_text())
    del fp["id_scheme"]
    (out / "fingerprint.json").write_text(json.dumps(fp))
    text = (out / "styles.csv").read_text()
    (out / "styles.csv").write_text(text.replace("a/v1,", "v1,").replace("b/v2,", "v2,"))
    assert sorted(r["id"] for r in _table(out)) == ["v1", "v2"]
    _unminable(inp / "c", ["v1"])  # now "v1" could be a/v1 or c/v1
    capsys.readouterr()
    payload = _mine(inp, lib, out)
    said = capsys.readouterr().out
    assert "1 row(s) of an earlier version renamed" in said
    assert "whose id names several demonstrations now (v1)" in said
    assert sorted(r["id"] for r in _table(out)) == ["a/v1", "b/v2", "c/v1"]  # no duplicates
    assert payload["n"] == 3 and payload["n_this_run"] == 2
    assert json.loads((out / "fingerprint.json").read_text())["id_scheme"] == "path"


@pytest.mark.parametrize(
    "dataset",
    ["ngsim", pytest.param("cats", marks=pytest.mark.slow)],  # cats: 88 changes, 10 s
)
def test_a_recorded_sample_is_mined_through_the_extraction(dataset):
    data = Path(__file__).resolve().parents[2].parent / "shared" / "data"
    folder = data / ("ngsim" if dataset == "ngsim" else "cats-av-lanechange")
    if not folder.is_dir():
        pytest.skip("../shared/data not beside the checkout")
    from drivestyle.recorded.episodes import ExtractionConfig, extract_episodes
    from drivestyle.recorded.readers import read_sample
    from drivestyle.scripts import mine_styles

    args = mine_styles.parse_args(["--dataset", dataset, "--data", str(folder), "--library", "x"])
    tasks, source = mine_styles._tasks(args)
    usable = [e for e in extract_episodes(read_sample(folder), ExtractionConfig()) if e.usable]
    assert [t[0] for t in tasks] == [e.episode_id for e in usable] and source.startswith(dataset)
    other = "cats" if dataset == "ngsim" else "ngsim"
    wrong = mine_styles.parse_args(["--dataset", other, "--data", str(folder), "--library", "x"])
    with pytest.raises(ValueError, match=f"holds the {dataset} sample"):
        mine_styles._tasks(wrong)


def test_a_byte_copy_is_mined_once_and_said(lib, tmp_path):
    # before: a copy under another name was a second row, counted twice in the summary
    from cli_runner import run_command

    inp = _unminable(tmp_path / "in", ["a", "c"])
    (inp / "sub").mkdir()
    (inp / "sub" / "b.npz").write_bytes((inp / "a.npz").read_bytes())  # the same content
    run = run_command(tmp_path, "mine-styles", inp, "--library", lib, "--out", "mined",
                      "--workers", "1")  # fmt: skip
    assert run.returncode == 0, run.stderr
    notes = [line for line in run.stderr.splitlines() if line.startswith("note: ")]
    assert notes == [
        f"note: each demonstration counts once: {inp / 'sub' / 'b.npz'} has the content of "
        f"{inp / 'a.npz'}"
    ]
    assert sorted(r["id"] for r in _table(tmp_path / "mined")) == ["a", "c"]
    summary = json.loads((tmp_path / "mined" / "summary.json").read_text())
    assert summary["n"] == 2


@pytest.mark.slow  # a command in its own process (≈ 2 s)
def test_a_linked_demonstration_names_both_files(lib, tmp_path):
    # before: "a.npz given 2 times", b.npz (a link to it) never named
    from cli_runner import run_command

    inp = _unminable(tmp_path / "in", ["a"])
    (inp / "b.npz").symlink_to("a.npz")
    run = run_command(tmp_path, "mine-styles", inp, "--library", lib, "--out", "mined",
                      "--workers", "1")  # fmt: skip
    assert run.returncode == 0, run.stderr
    notes = [line for line in run.stderr.splitlines() if line.startswith("note: ")]
    assert notes == [
        f"note: each demonstration counts once: {inp / 'a.npz'} and {inp / 'b.npz'} are one "
        "file (a link)"
    ]
    assert [r["id"] for r in _table(tmp_path / "mined")] == ["a"]


def test_ctrl_c_keeps_the_finished_rows_and_says_how_to_resume(tmp_path, paper_demo):
    # before: "interrupted: unfinished output was discarded", while the rows were kept
    import signal
    import time

    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary

    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    write_json(tmp_path / "lib" / "library.json", lib.to_json())
    inp = _unminable(tmp_path / "in", ["a"])  # a failed row in milliseconds
    for i in range(6):  # then demonstrations of ≈ 1 s each (each its own bytes)
        save_demonstration(replace(paper_demo, meta={**paper_demo.meta, "copy": i}),
                           inp / f"b{i}.npz")  # fmt: skip
    env = {**os.environ, "MPLBACKEND": "Agg"}
    job = subprocess.Popen(
        [sys.executable, "-m", "drivestyle", "mine-styles", str(inp), "--library",
         str(tmp_path / "lib"), "--out", str(tmp_path / "mined")],  # two worker processes
        stderr=subprocess.PIPE, text=True, env=env, start_new_session=True,
        # as from a terminal's shell: a test runner's worker (xdist) or a background job
        # ignores SIGINT, and its children inherit that
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    table = tmp_path / "mined" / "styles.csv"
    try:
        deadline = time.monotonic() + 120
        while not (table.is_file() and len(table.read_text().splitlines()) >= 2):
            assert job.poll() is None and time.monotonic() < deadline, "no first row"
            time.sleep(0.05)
        os.killpg(job.pid, signal.SIGINT)  # Ctrl-C at a terminal: the whole group
        _, err = job.communicate(timeout=60)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
            job.wait()
    assert job.returncode == 130, err
    kept = len(_table(tmp_path / "mined"))
    assert 1 <= kept < 7
    assert err.strip().splitlines()[-1] == (
        f"interrupted: {kept} finished row(s) kept in {table} ({kept} of this run); rerun the "
        f"same command to resume: it mines the other {7 - kept} demonstration(s) (summary.json "
        "and population.png are written when a run completes)"
    )
    assert "discarded" not in err
