"""Two runs of a command into one output, run as a user runs them (``python -m drivestyle``).

The first run is caught while it holds its output (its lock file names its pid) and, for
the refusal, stopped there with SIGSTOP: however fast its work, the second run starts while
the first one writes. Which command does not matter (every command takes its lock where
it checks its output, ``tests/scripts/test_cli.py``): ``simulate-population`` writes a
folder with a worker pool in about a second.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from drivestyle.common.output_lock import lock_file

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGSTOP"), reason="POSIX signals")

ENV = {**os.environ, "MPLBACKEND": "Agg", "SDL_VIDEODRIVER": "dummy"}
ENV.pop("DRIVESTYLE_TRACEBACK", None)


def _command(out: Path, vehicles: int, seed: int, workers: int = 2) -> list[str]:
    args = ["--vehicles", vehicles, "--seed", seed, "--workers", workers, "--out", out]
    return [sys.executable, "-m", "drivestyle", "simulate-population", *map(str, args)]


def _start_holding(out: Path, vehicles: int = 3, workers: int = 2) -> subprocess.Popen:
    """Start a run into ``out``; return once it holds ``out``'s lock (its work is next)."""
    proc = subprocess.Popen(
        _command(out, vehicles, 0, workers),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while True:
        try:
            if lock_file(out).read_text().split()[:1] == [str(proc.pid)]:
                return proc
        except OSError:
            pass
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            _, err = proc.communicate()
            pytest.fail(f"the run never held {out} (exit {proc.returncode}):\n{err[-2000:]}")
        time.sleep(0.005)


def _run(out: Path, vehicles: int, seed: int) -> subprocess.CompletedProcess:
    return subprocess.run(
        _command(out, vehicles, seed, workers=1), capture_output=True, text=True, env=ENV,
        timeout=300,
    )  # fmt: skip


def _population(out: Path) -> dict:
    return json.loads((out / "population.json").read_text())


def test_a_second_run_into_a_running_ones_output_is_refused_and_the_first_completes(tmp_path):
    out = tmp_path / "pop"
    first = _start_holding(out)
    os.kill(first.pid, signal.SIGSTOP)  # mid-work for as long as the second run takes
    try:
        second = _run(out, vehicles=2, seed=1)
    finally:
        os.kill(first.pid, signal.SIGCONT)
    assert second.returncode == 2, second.stderr
    assert second.stderr.strip().splitlines() == [
        f"error: --out {out} is in use by another run (pid {first.pid}); wait for it to "
        "finish or choose another --out"
    ]
    _, err = first.communicate(timeout=300)
    assert first.returncode == 0, err[-2000:]
    # the first run's output, whole: its seed, its three vehicles, each demonstration
    population = _population(out)
    assert (population["seed"], population["n"], population["n_ok"]) == (0, 3, 3)
    assert sorted(p.name for p in (out / "demos").iterdir()) == [f"v00000{i}.npz" for i in range(3)]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pop"]  # no lock, no partial


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGKILL"])
def test_a_killed_writer_leaves_the_output_to_the_next_run(tmp_path, sig):
    out = tmp_path / "pop"
    first = _start_holding(out)
    first.send_signal(getattr(signal, sig))
    _, err = first.communicate(timeout=120)
    if sig == "SIGTERM":  # a clean stop: lock released, unfinished output discarded
        assert first.returncode == 143, err[-2000:]
        assert "terminated" in err
        assert list(tmp_path.iterdir()) == []
    else:  # the kernel dropped the flock; the lock file still names the killed run
        assert first.returncode == -signal.SIGKILL
        assert lock_file(out).read_text().split()[0] == str(first.pid)
    rerun = _run(out, vehicles=1, seed=1)
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    notices = [line for line in rerun.stderr.splitlines() if "lock" in line]
    if sig == "SIGTERM":
        assert notices == []
    else:
        assert notices == [
            f"--out {out}: taking over the lock of pid {first.pid}, which ended without "
            "releasing it (killed?)"
        ]
    assert (_population(out)["seed"], _population(out)["n"]) == (1, 1)
    assert not lock_file(out).exists()


def test_a_run_into_a_folder_inside_or_around_a_running_ones_output_is_refused(tmp_path):
    # nested outputs: the outer run replaces its folder as a whole, so a run writing inside
    # it (or around it) would be lost, or make the outer run fail after its work
    out = tmp_path / "nest"
    first = _start_holding(out)
    os.kill(first.pid, signal.SIGSTOP)
    try:
        inner = _run(out / "sub", vehicles=1, seed=1)
        outer = _run(tmp_path, vehicles=1, seed=1)  # the folder holding the running output
        beside = _run(tmp_path / "other", vehicles=1, seed=1)
    finally:
        os.kill(first.pid, signal.SIGCONT)
    assert inner.returncode == 2, inner.stderr
    assert inner.stderr.strip().splitlines() == [
        f"error: --out {out / 'sub'} lies inside {out}, which another run (pid {first.pid}) is "
        "writing and will replace; wait for it to finish or choose another --out"
    ]
    assert outer.returncode == 2, outer.stderr
    assert outer.stderr.strip().splitlines() == [
        f"error: --out {tmp_path} holds {out}, which another run (pid {first.pid}) is writing; "
        "wait for it to finish or choose another --out"
    ]
    assert beside.returncode == 0, beside.stderr[-2000:]  # a sibling is no one's
    _, err = first.communicate(timeout=300)
    assert first.returncode == 0, err[-2000:]
    assert _population(out)["n"] == 3 and not (out / "sub").exists()
    assert not lock_file(out / "sub").exists() and not lock_file(out).exists()
