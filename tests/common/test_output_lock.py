"""One writer per output (drivestyle.common.output_lock): refused, released, taken over."""

import os
import signal
import socket
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import drivestyle.common.output_lock as locks
from drivestyle.common.io import atomic_output_dir, check_output_dir, check_output_file
from drivestyle.common.output_lock import (
    OutputInUseError,
    OutputLock,
    command_outputs,
    lock_file,
    output_lock,
)
from drivestyle.common.output_paths import OutputPathError
from drivestyle.common.parallel import parallel_map

pytestmark = pytest.mark.skipif(locks.fcntl is None, reason="outputs are locked with flock")

_HOLDER = """
import sys, time
from drivestyle.common.output_lock import OutputLock
OutputLock(sys.argv[1]).acquire()
print("locked", flush=True)
time.sleep(60)
"""

_RAW_HOLDER = """
import fcntl, os, sys, time
fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT)
fcntl.flock(fd, fcntl.LOCK_EX)
os.pwrite(fd, sys.argv[2].encode(), 0)
print("locked", flush=True)
time.sleep(60)
"""
"""Holds the lock file's flock with any record (as a leftover child of a holder would)."""


def _start(code: str, *args) -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-c", code, *map(str, args)], stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None and proc.stdout.readline().strip() == "locked"
    return proc


def _stop(proc: subprocess.Popen) -> None:
    proc.kill()
    proc.wait()


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_the_lock_file_lies_beside_the_output(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert lock_file(tmp_path / "runs" / "demo") == tmp_path / "runs" / ".demo.drivestyle-lock"
    assert lock_file("runs/demo/") == lock_file(tmp_path / "runs" / "demo")  # one per output
    assert lock_file("b.json") == tmp_path / ".b.json.drivestyle-lock"


def test_a_second_writer_is_refused_naming_the_holder_until_it_releases(tmp_path):
    out = tmp_path / "out"
    first = OutputLock(out).acquire()
    assert first.held and lock_file(out).read_text().split()[0] == str(os.getpid())
    with pytest.raises(
        OutputInUseError, match=rf"^--out {out} is in use by another run \(pid {os.getpid()}\)"
    ) as info:
        OutputLock(out).acquire()
    assert info.value.pid == os.getpid()
    first.release()
    assert not first.held and not lock_file(out).exists()  # a release leaves nothing
    with OutputLock(out) as second:
        assert second.held
    assert sorted(tmp_path.iterdir()) == []


def test_a_holder_in_another_process_is_named_and_its_kill_is_taken_over(tmp_path, capfd):
    out = tmp_path / "out"
    holder = _start(_HOLDER, out)
    try:
        with pytest.raises(OutputInUseError, match=rf"\(pid {holder.pid}\)"):
            OutputLock(out).acquire()
    finally:
        _stop(holder)  # kill -9: the kernel drops its flock, its record stays
    assert lock_file(out).read_text().split()[0] == str(holder.pid)
    capfd.readouterr()
    with OutputLock(out):
        assert lock_file(out).read_text().split()[0] == str(os.getpid())
    err = capfd.readouterr().err.strip().splitlines()
    assert err == [
        f"--out {out}: taking over the lock of pid {holder.pid}, which ended without "
        "releasing it (killed?)"
    ]


def test_a_lock_held_by_a_leftover_of_a_dead_holder_is_taken_over(tmp_path, capfd):
    out = tmp_path / "out"
    dead = _dead_pid()
    leftover = _start(_RAW_HOLDER, lock_file(out), f"{dead} 12345 {socket.gethostname()}")
    try:
        with OutputLock(out):
            assert lock_file(out).read_text().split()[0] == str(os.getpid())
        assert f"taking over the lock of pid {dead}, which is no longer running" in (
            capfd.readouterr().err
        )
    finally:
        _stop(leftover)


def test_a_holder_on_another_host_is_not_judged_from_here(tmp_path):
    # a pid of another machine (an output on a shared file system) says nothing here
    out = tmp_path / "out"
    dead = _dead_pid()
    holder = _start(_RAW_HOLDER, lock_file(out), f"{dead} 12345 another-host")
    try:
        with pytest.raises(OutputInUseError, match=rf"\(pid {dead} on another-host\)"):
            OutputLock(out).acquire()
    finally:
        _stop(holder)


def test_a_lock_file_released_between_open_and_flock_is_not_held(tmp_path, monkeypatch):
    # another run released (removed) the file this one had opened: a flock on the removed
    # file would lock nothing that a third run could see
    out = tmp_path / "out"
    fcntl = locks.fcntl
    replaced = []

    class Fcntl:
        LOCK_EX, LOCK_NB, LOCK_UN = fcntl.LOCK_EX, fcntl.LOCK_NB, fcntl.LOCK_UN

        @staticmethod
        def flock(fd, op):
            if not replaced and not stat.S_ISDIR(os.fstat(fd).st_mode):
                replaced.append(fd)
                lock_file(out).unlink()
                lock_file(out).touch()
            return fcntl.flock(fd, op)

    monkeypatch.setattr(locks, "fcntl", Fcntl)
    with OutputLock(out) as lock:
        assert replaced
        assert os.fstat(lock._fd).st_ino == os.stat(lock_file(out)).st_ino


def test_a_command_holds_what_it_checked_until_it_ends(tmp_path):
    out, summary = tmp_path / "out", tmp_path / "b.json"
    check_output_dir(out)  # outside a command a check locks nothing
    assert not lock_file(out).exists()
    with command_outputs():
        check_output_dir(out)
        check_output_file(summary)
        for path in (out, summary):
            with pytest.raises(OutputInUseError, match=f"{path} is in use"):
                OutputLock(path).acquire()
        with atomic_output_dir(out) as tmp:  # the command's lock, not a second one
            (tmp / "a.json").write_text("{}")
        with pytest.raises(OutputInUseError):
            OutputLock(out).acquire()  # still the command's: it has not ended
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    with OutputLock(out), OutputLock(summary):
        pass


def test_a_command_that_fails_releases_its_locks(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt), command_outputs():
        check_output_dir(out)
        raise KeyboardInterrupt
    with OutputLock(out):
        pass


def test_a_refused_output_is_left_as_it_was(tmp_path):
    out = tmp_path / "out"
    with atomic_output_dir(out) as tmp:
        (tmp / "a.json").write_text("old")
    ran = []
    with OutputLock(out):
        with pytest.raises(OutputInUseError), atomic_output_dir(out) as tmp:
            ran.append(tmp)
        with pytest.raises(OutputInUseError), command_outputs():
            check_output_dir(out)
            ran.append(out)
    assert ran == [] and (out / "a.json").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_atomic_output_dir_outside_a_command_locks_its_block(tmp_path):
    out = tmp_path / "out"
    with atomic_output_dir(out):
        with pytest.raises(OutputInUseError):
            OutputLock(out).acquire()
    with OutputLock(out):
        pass


def test_the_folders_made_for_a_lock_are_removed_when_left_empty(tmp_path):
    with command_outputs():
        check_output_dir(tmp_path / "a" / "b" / "out")
        assert lock_file(tmp_path / "a" / "b" / "out").is_file()
    assert list(tmp_path.iterdir()) == []  # the command wrote nothing there
    with command_outputs():
        with atomic_output_dir(tmp_path / "a" / "b" / "out") as tmp:
            (tmp / "x").write_text("x")
    assert (tmp_path / "a" / "b" / "out" / "x").is_file()


def _enter_from_worker(path: str) -> int | str:
    """In a worker: try to hold ``path``; the holder's pid when refused."""
    try:
        with output_lock(path):
            return "entered"
    except OutputInUseError as exc:
        return exc.pid if exc.pid is not None else "unknown"


def test_a_forked_worker_neither_holds_nor_releases_the_commands_lock(tmp_path):
    out = tmp_path / "out"
    with command_outputs():
        check_output_dir(out)
        # a worker is no part of the command: its output_lock is its own, and refused
        results = parallel_map(_enter_from_worker, [(str(out),), (str(out),)], workers=2)
        assert results == [os.getpid(), os.getpid()]
        # its exit did not unlock the command's lock
        with pytest.raises(OutputInUseError):
            OutputLock(out).acquire()


_KILLED_WITH_WORKER = """
import os, sys, time
from drivestyle.common.output_lock import OutputLock
OutputLock(sys.argv[1]).acquire()
child = os.fork()
if child == 0:
    os.closerange(0, 3)  # the test reads the parent's output to its end
    time.sleep(60)
    os._exit(0)
print(child, flush=True)
os.kill(os.getpid(), 9)
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_a_forked_child_does_not_keep_a_killed_parents_lock(tmp_path, capfd):
    out = tmp_path / "out"
    parent = subprocess.run(
        [sys.executable, "-c", _KILLED_WITH_WORKER, str(out)], capture_output=True, text=True
    )
    assert parent.returncode == -signal.SIGKILL
    child = int(parent.stdout)
    try:
        with OutputLock(out):  # free: the child dropped its copy of the descriptor
            pass
        assert "ended without releasing it" in capfd.readouterr().err
    finally:
        os.kill(child, signal.SIGKILL)


def test_a_lock_file_that_cannot_be_created_is_an_output_error():
    unwritable = Path("/sys")  # sysfs refuses new entries, root's too
    if os.access(unwritable, os.W_OK) and not os.path.ismount(unwritable):
        pytest.skip(f"{unwritable} is no sysfs here")
    with pytest.raises(OutputPathError, match=f"^--out {unwritable}/out: cannot lock it"):
        OutputLock(unwritable / "out").acquire()
