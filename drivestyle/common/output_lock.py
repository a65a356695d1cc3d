"""One writer per output: the lock of an output folder or file, and a command's locks.

One writer at a time: two runs into the same output would both report success while one
run's output silently replaced the other's. So an output has a lock (:class:`OutputLock`:
``flock`` on the file :func:`lock_file`, ``.NAME.drivestyle-lock`` *beside* the output, so
that replacing the folder never drops it), and a second writer is refused with a message
naming the output and the holder's pid:

- a command (:func:`~drivestyle.common.cli.run_cli` runs its ``main`` inside
  :func:`command_outputs`) takes the lock where
  :func:`~drivestyle.common.io.check_output_dir` or
  :func:`~drivestyle.common.io.check_output_file` accepts its output, before any work, and
  holds it until it ends: on return, an error, Ctrl-C or SIGTERM (turned into
  ``SystemExit(143)`` for the command's duration) the lock is released and its file removed;
- outside a command, :func:`~drivestyle.common.io.atomic_output_dir` holds the lock for its
  block (so does the mining output,
  :class:`~drivestyle.irl.identification.mining_output.MiningOutput`); inside one it uses the
  command's;
- the kernel releases the ``flock`` of a process that dies (``kill -9``); its record (pid,
  start time, host) stays in the file, and the next writer takes over with a one-line
  notice naming the dead pid. A lock still held by a process other than the one recorded,
  whose recorded holder is gone (a leftover child of it), is taken over likewise;
- nested outputs are one writer's too: a run whose output lies inside a folder another
  live run is writing (an ancestor's lock file is held), or holds one (a lock file inside
  it is held), is refused likewise: the outer run replaces its folder whole;
- forked worker processes drop their copy of the lock's descriptor (a worker outliving a
  killed parent must not keep the output locked) and are no command of their own; Ray's
  workers are started by Ray, never forked from the command, and inherit nothing.

The checks and atomic writes that take these locks are :mod:`drivestyle.common.io`'s.
"""

from __future__ import annotations

import contextlib
import os
import socket
import sys
import time
from collections.abc import Iterator
from pathlib import Path

from drivestyle.common.output_paths import OutputPathError, os_error_reason
from drivestyle.common.parallel import sigterm_stops_the_job

try:  # POSIX; elsewhere outputs are not locked
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

__all__ = [
    "LOCK_SUFFIX",
    "OutputInUseError",
    "OutputLock",
    "command_outputs",
    "lock_file",
    "lock_for_command",
    "output_lock",
]

LOCK_SUFFIX = ".drivestyle-lock"
"""Suffix of an output's lock file (:func:`lock_file`)."""


class OutputInUseError(OutputPathError):
    """Another run is writing this output: it holds the output's lock."""

    def __init__(self, message: str, pid: int | None) -> None:
        super().__init__(message)
        self.pid = pid
        """The holder's pid (None: its record was unreadable)."""


def lock_file(path: str | Path) -> Path:
    """The lock file of the output folder or file ``path``: ``.NAME.drivestyle-lock`` beside it.

    Beside, not inside: a folder is replaced whole at the end of a run, and a lock inside
    it would go with it. The resolved path names it, so two spellings share one lock.
    """
    final = Path(path).resolve()
    return final.parent / f".{final.name}{LOCK_SUFFIX}"


def _proc_stat(pid: int) -> list[str] | None:
    """The fields of ``/proc/<pid>/stat`` after the command name (state first), else None."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat.rpartition(")")[2].split()  # the command name may hold spaces


def _holder_record() -> str:
    """This process's lock record: ``pid start-time host``.

    The start time (``/proc/<pid>/stat`` field 22) tells a reused pid apart; the host tells
    a pid of another machine (an output on a shared file system) from a dead one here.
    """
    fields = _proc_stat(os.getpid())
    started = fields[19] if fields and len(fields) > 19 else "-"
    return f"{os.getpid()} {started} {socket.gethostname()}"


def _parse_holder(record: str) -> tuple[int | None, str | None, str | None]:
    """(pid, start time, host) of a lock record; an older version's lacks the last two."""
    parts = record.split()
    if not parts or not parts[0].isdigit():
        return None, None, None
    started = parts[1] if len(parts) > 1 and parts[1] != "-" else None
    return int(parts[0]), started, parts[2] if len(parts) > 2 else None


def _holder_gone(pid: int | None, started: str | None, host: str | None) -> bool:
    """Whether the process that wrote a lock record has ended (unknown: it has not).

    Ended: its pid is dead or a zombie, or now names another process (another start time).
    A holder on another host cannot be seen from here: it is taken to be running.
    """
    if pid is None or (host is not None and host != socket.gethostname()):
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:  # alive, another user's
        pass
    fields = _proc_stat(pid)
    if not fields:  # no /proc here (or it just ended): trust the pid
        return not os.path.exists(f"/proc/{pid}") and sys.platform.startswith("linux")
    if fields[0] in ("Z", "X"):
        return True
    return started is not None and len(fields) > 19 and fields[19] != started


def _same_file(fd: int, path: Path) -> bool:
    """Whether ``path`` is still the file open as ``fd`` (not removed or replaced since)."""
    try:
        now = os.stat(path)
    except OSError:
        return False
    held = os.fstat(fd)
    return (now.st_dev, now.st_ino) == (held.st_dev, held.st_ino)


@contextlib.contextmanager
def _folder_guard(folder: Path) -> Iterator[None]:
    """Serialise the lock-taking of the outputs in ``folder`` (a ``flock`` on the folder).

    Held for microseconds, while a lock file is opened, judged and written or removed: two
    runs then never both take over one stale lock. Best effort: where the folder cannot be
    locked (NFS refuses ``flock`` on a folder) or stays locked for a second (its holder is
    stopped), the lock file's own checks (:func:`_same_file`) still keep one holder, but for
    races of microseconds.
    """
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        yield
        return
    try:
        for _ in range(100):
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                time.sleep(0.01)
            except OSError:
                break
        yield
    finally:
        os.close(fd)  # releases the flock


def _unlock(fd: int, file: Path) -> None:
    """Remove the lock file held as ``fd`` and close it, which releases its ``flock``."""
    try:
        if _same_file(fd, file):  # never another run's newer lock file
            file.unlink()
    except OSError:
        with contextlib.suppress(OSError):
            os.ftruncate(fd, 0)  # left in place: an empty record is a released lock
    os.close(fd)


def _live_holder(file: Path) -> int | None:
    """The pid of another process holding the lock file ``file``, else None.

    None: no one holds it, or this process does; 0: a holder whose record is unreadable.

    A lock file left by a killed run is not held (the kernel released its ``flock``); this
    process's own locks (:data:`_HELD`) do not count.
    """
    if not os.path.lexists(file):  # the usual case: no guard taken
        return None
    with _folder_guard(file.parent):  # never while a run takes it (its flock would fail)
        try:
            fd = os.open(file, os.O_RDONLY)
        except OSError:
            return None
        try:
            return _other_holder(fd)
        finally:
            os.close(fd)  # releases a shared flock taken


def _other_holder(fd: int) -> int | None:
    """:func:`_live_holder` of the open lock file ``fd``."""
    held = os.fstat(fd)
    for lock in _HELD:
        if lock._fd is not None:
            mine = os.fstat(lock._fd)
            if (mine.st_dev, mine.st_ino) == (held.st_dev, held.st_ino):
                return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        pid, started, host = _parse_holder(os.pread(fd, 256, 0).decode(errors="replace"))
        if pid is not None and _holder_gone(pid, started, host):
            return None
        return pid if pid is not None else 0
    except OSError:
        return None
    return None


def _notice(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


_HELD: set[OutputLock] = set()
"""The locks this process holds (a forked child drops them)."""

_COMMAND: dict[Path, OutputLock] | None = None
"""The running command's locks by lock file (:func:`command_outputs`); None: no command."""


def _forget_locks_in_child() -> None:
    # a forked worker must not keep its parent's lock (a killed parent, an orphaned worker:
    # the output locked forever), nor ever unlock it (its copy shares the parent's flock);
    # and it is no command: an output it checked would not be the command's
    global _COMMAND
    for lock in list(_HELD):
        lock._forget()
    _HELD.clear()
    _COMMAND = None


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_locks_in_child)


class OutputLock:
    """The lock of one output folder or file: one writer at a time, across processes.

    ``flock`` on :func:`lock_file`, which records the holder (``pid start-time host``). A
    second writer is refused (:class:`OutputInUseError`, naming the output and the pid).
    A record left by a holder that died without releasing (``kill -9``: the kernel released
    its ``flock``) is taken over with a notice on stderr, as is a lock still held by a
    leftover process of a holder that is gone. Releasing removes the lock file, and the
    folders that taking it created when they are still empty. Not re-entrant: a second
    :class:`OutputLock` on the same output in this process is refused too. A context
    manager; does nothing where ``fcntl`` is missing.

    Args:
        path: the output folder or file (as the user gave it: messages name it).
        option: the command-line option that named it, for messages.
    """

    def __init__(self, path: str | Path, option: str = "--out") -> None:
        self.path = Path(path)
        self.option = option
        self.file = lock_file(path)
        self._fd: int | None = None
        self._made: list[Path] = []

    @property
    def held(self) -> bool:
        """Whether this object holds the lock now."""
        return self._fd is not None

    def __enter__(self) -> OutputLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()

    def acquire(self) -> OutputLock:
        """Take the lock (creating the output's missing parent folders).

        Returns:
            self.

        Raises:
            OutputInUseError: another run holds it.
            OutputPathError: the lock file cannot be created.
        """
        if self._fd is not None:
            raise RuntimeError(f"{self.file} is already held by this OutputLock")
        if fcntl is None:  # pragma: no cover - no flock on this platform
            return self
        folder = self.file.parent
        for _ in range(20):  # each retry follows a change by another process
            try:
                self._made += self._make_folder()
                with _folder_guard(folder):
                    fd = os.open(self.file, os.O_RDWR | os.O_CREAT, 0o644)
                    if not self._take(fd):
                        continue
                    # held from here on: Ctrl-C or SIGTERM once the record names this
                    # process finds the lock to release
                    self._fd = fd
                    _HELD.add(self)
                    try:
                        os.ftruncate(fd, 0)
                        os.pwrite(fd, _holder_record().encode(), 0)
                    except BaseException:
                        self._fd = None
                        _HELD.discard(self)
                        _unlock(fd, self.file)
                        raise
                # taken first, judged second: of two runs nesting at once one sees the other
                try:
                    self._refuse_nested()
                except BaseException:
                    self.release()
                    raise
                return self
            except FileNotFoundError as exc:
                if not folder.is_dir():  # removed by a run that had made it: make it again
                    continue
                self._remove_made()
                raise OutputPathError(
                    f"{self.option} {self.path}: cannot lock it "
                    f"({self.file}: {os_error_reason(exc)})"
                ) from None
            except OutputPathError:
                self._remove_made()
                raise
            except OSError as exc:
                self._remove_made()
                raise OutputPathError(
                    f"{self.option} {self.path}: cannot lock it "
                    f"({self.file}: {os_error_reason(exc)})"
                ) from None
        self._remove_made()
        raise OutputPathError(
            f"{self.option} {self.path}: cannot lock it ({self.file} keeps being replaced)"
        )

    def _take(self, fd: int) -> bool:
        """Lock the open lock file ``fd`` (its record is the caller's to write).

        Returns:
            True: locked. False (``fd`` closed): the file was replaced, try again.

        Raises:
            OutputInUseError: a running holder has it (``fd`` closed).
        """
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid, started, host = _parse_holder(os.pread(fd, 256, 0).decode(errors="replace"))
            if not _holder_gone(pid, started, host):
                os.close(fd)
                where = f" on {host}" if host and host != socket.gethostname() else ""
                raise OutputInUseError(
                    f"{self.option} {self.path} is in use by another run (pid "
                    f"{pid if pid is not None else 'unknown'}{where}); wait for it to finish "
                    f"or choose another {self.option}",
                    pid,
                ) from None
            # the run recorded is gone, yet its lock is held: by a process that inherited
            # it (an older version's orphaned worker); a new lock file is ours
            if _same_file(fd, self.file):
                _notice(
                    f"{self.option} {self.path}: taking over the lock of pid {pid}, which is "
                    "no longer running (a leftover process of it still held the lock)"
                )
                self.file.unlink()
            os.close(fd)
            return False
        if not _same_file(fd, self.file):  # released and removed between open and flock
            os.close(fd)
            return False
        pid, _, _ = _parse_holder(os.pread(fd, 256, 0).decode(errors="replace"))
        if pid is not None:  # a release removes the record: its holder was killed
            _notice(
                f"{self.option} {self.path}: taking over the lock of pid {pid}, which ended "
                "without releasing it (killed?)"
            )
        return True

    def _refuse_nested(self) -> None:
        """Refuse when another live run writes a folder holding this output, or one inside it.

        A run replaces its output folder as a whole: a run writing inside it would lose its
        output, or make the outer run fail after its work (its folder then "holds files not
        written by drivestyle"). The lock files of the output's ancestors, and those anywhere
        inside an existing output folder, are looked at; one held by another process (not
        this one's own locks) refuses this run.

        Raises:
            OutputInUseError: such a run is writing.
        """
        final = self.file.parent / self.file.name.removeprefix(".").removesuffix(LOCK_SUFFIX)
        for ancestor in final.parents:
            if ancestor == ancestor.parent:
                break
            pid = _live_holder(lock_file(ancestor))
            if pid is not None:
                raise OutputInUseError(
                    f"{self.option} {self.path} lies inside {ancestor}, which another run "
                    f"(pid {pid or 'unknown'}) is writing and will replace; wait for it to "
                    f"finish or choose another {self.option}",
                    pid,
                )
        if not final.is_dir():
            return
        for root, _, names in os.walk(final):
            for name in names:
                if name.startswith(".") and name.endswith(LOCK_SUFFIX):
                    pid = _live_holder(Path(root) / name)
                    if pid is not None:
                        inner = Path(root) / name.removeprefix(".").removesuffix(LOCK_SUFFIX)
                        raise OutputInUseError(
                            f"{self.option} {self.path} holds {inner}, which another run "
                            f"(pid {pid or 'unknown'}) is writing; wait for it to finish or "
                            f"choose another {self.option}",
                            pid,
                        )

    def _make_folder(self) -> list[Path]:
        """Create the lock file's folder and its missing parents; those made, innermost first.

        Raises:
            FileNotFoundError: a parent was removed meanwhile (by a run that had made it).
            OutputPathError: a folder cannot be created.
        """
        missing = []
        folder = self.file.parent
        while not folder.exists() and folder != folder.parent:
            missing.append(folder)
            folder = folder.parent
        for made in reversed(missing):
            try:
                made.mkdir(exist_ok=True)
            except FileNotFoundError:
                raise
            except OSError as exc:
                raise OutputPathError(
                    f"{self.option} {self.path}: cannot create files in {made.parent} "
                    f"({os_error_reason(exc)})"
                ) from None
        return missing

    def _remove_made(self) -> None:
        """Remove the folders taking the lock created, as far as they are empty."""
        for folder in self._made:
            try:
                folder.rmdir()
            except OSError:
                break
        self._made = []

    def release(self) -> None:
        """Release the lock and remove its file (nothing if not held)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        _HELD.discard(self)
        with _folder_guard(self.file.parent):
            _unlock(fd, self.file)
        self._remove_made()

    def _forget(self) -> None:
        """In a forked child: close this copy of the descriptor without unlocking."""
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
        self._fd = None
        self._made = []


@contextlib.contextmanager
def command_outputs() -> Iterator[None]:
    """Run one command in the block: the outputs it checks stay locked until the block ends.

    :func:`~drivestyle.common.io.check_output_dir` and
    :func:`~drivestyle.common.io.check_output_file` lock the outputs they accept for the rest
    of the block; on leaving it (a return, an error, Ctrl-C) the locks are
    released. SIGTERM raises ``SystemExit(143)`` in the block (where SIGTERM had its default
    action), so a terminated command releases its locks and discards its unfinished output
    as on Ctrl-C. Nested blocks are the outer command's.
    """
    global _COMMAND
    if _COMMAND is not None:
        yield
        return
    locks: dict[Path, OutputLock] = {}
    _COMMAND = locks
    try:
        with sigterm_stops_the_job():
            yield
    finally:
        _COMMAND = None
        for lock in locks.values():
            lock.release()


def lock_for_command(path: Path, option: str) -> None:
    """Lock ``path`` until the running command ends (nothing outside :func:`command_outputs`).

    Raises:
        OutputInUseError: another run writes ``path``.
    """
    if _COMMAND is None:
        return
    key = lock_file(path)
    if key in _COMMAND:
        return
    # registered before it is taken: an interrupt meanwhile still finds it to release
    lock = _COMMAND[key] = OutputLock(path, option)
    try:
        lock.acquire()
    except BaseException:
        lock.release()
        del _COMMAND[key]
        raise


@contextlib.contextmanager
def output_lock(path: str | Path, option: str = "--out") -> Iterator[None]:
    """Hold ``path``'s lock in the block: the running command's if it holds it, else its own.

    Raises:
        OutputInUseError: another run (or another holder in this process) writes ``path``.
    """
    if _COMMAND is not None and lock_file(path) in _COMMAND:
        yield
        return
    with OutputLock(path, option):
        yield
