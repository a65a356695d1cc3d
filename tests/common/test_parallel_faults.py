"""parallel_map under faults: workers die with their parent; a crashed worker is one task's."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from drivestyle.common.parallel import EXIT_TERMINATED, WorkerCrashError, parallel_map

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="prctl is Linux's")

_JOB = """
import os, sys, time
from pathlib import Path
from drivestyle.common.parallel import parallel_map

def task(folder):
    Path(folder, str(os.getpid())).touch()
    time.sleep(120)

parallel_map(task, [(sys.argv[1],)] * 4, workers=2)
"""


def _gone(pid: int) -> bool:
    """Whether ``pid`` is dead (a zombie nobody reaps counts: it runs nothing, holds nothing)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return True
    return stat.rpartition(")")[2].split()[0] in ("Z", "X")


def _start_job(tmp_path: Path) -> tuple[subprocess.Popen, list[int]]:
    script = tmp_path / "job.py"
    script.write_text(_JOB)
    pids = tmp_path / "pids"
    pids.mkdir()
    job = subprocess.Popen(
        [sys.executable, str(script), str(pids)], stderr=subprocess.PIPE, text=True
    )
    deadline = time.monotonic() + 30
    while len(os.listdir(pids)) < 2:
        assert job.poll() is None, job.stderr.read() if job.stderr else ""
        assert time.monotonic() < deadline, "the workers did not start"
        time.sleep(0.05)
    return job, [int(p) for p in os.listdir(pids)]


def _wait_gone(pids: list[int], seconds: float = 5.0) -> list[int]:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        alive = [p for p in pids if not _gone(p)]
        if not alive:
            return []
        time.sleep(0.05)
    return alive


@linux_only
def test_workers_die_when_their_parent_is_killed_with_sigkill(tmp_path):
    job, workers = _start_job(tmp_path)
    try:
        os.kill(job.pid, signal.SIGKILL)
        job.wait(10)
        assert _wait_gone(workers) == []
    finally:
        for pid in workers:  # never leave the test's own orphans behind
            if not _gone(pid):
                os.kill(pid, signal.SIGKILL)


@linux_only
def test_sigterm_stops_the_job_as_ctrl_c_does(tmp_path):
    job, workers = _start_job(tmp_path)
    try:
        os.kill(job.pid, signal.SIGTERM)
        assert job.wait(10) == EXIT_TERMINATED
        assert "terminated" in (job.stderr.read() if job.stderr else "")
        assert _wait_gone(workers) == []
    finally:
        for pid in workers:
            if not _gone(pid):
                os.kill(pid, signal.SIGKILL)


def _exit_on(x: int) -> int:
    if x == 3:
        os._exit(7)  # a crash, not an exception: the worker process dies
    return x * x


def test_a_task_that_kills_its_worker_is_that_tasks_failure_only():
    crashes: list[tuple[int, str]] = []
    seen: list[int] = []

    def on_crash(i: int, cause: str) -> str:
        crashes.append((i, cause))
        return f"crashed: {cause}"

    out = parallel_map(
        _exit_on, [(x,) for x in range(6)], 2, lambda i, _: seen.append(i), on_crash=on_crash
    )
    assert crashes == [(3, "the worker process exited with status 7 while running it")]
    assert out == [0, 1, 4, "crashed: the worker process exited with status 7 while running it",
                   16, 25]  # fmt: skip
    assert sorted(seen) == list(range(6))  # every task reported once


def test_without_on_crash_a_crash_is_one_error_naming_the_task():
    with pytest.raises(WorkerCrashError, match=r"task 3: the worker process exited with status 7"):
        parallel_map(_exit_on, [(x,) for x in range(5)], 2)


def _raise_on(x: int) -> int:
    if x == 1:
        raise ValueError("bad task")
    return x


def test_an_exception_in_a_task_still_propagates():
    with pytest.raises(ValueError, match="bad task"):
        parallel_map(_raise_on, [(x,) for x in range(4)], 2)
