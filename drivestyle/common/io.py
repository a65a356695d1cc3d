"""Result files: JSON with the command that produced it, atomic writes and output folders.

Every file a script writes goes through here, so that an interrupted or failed run (Ctrl-C,
a crash, a full disk) leaves either the previous complete output or none, never a
half-written file, and never a temporary file or folder behind:

- :func:`check_output_dir` and :func:`check_output_file` are called by every script first
  thing after parsing: an output location that cannot be written, or that another run is
  writing (below), is reported (naming the user's path) before any work starts;
- :func:`write_json`, :func:`write_text` and :func:`atomic_output_file` write to a temporary
  file beside the target and rename it into place (``os.replace`` is atomic on POSIX);
- :func:`atomic_output_dir` builds a whole output folder under a temporary name beside it
  and swaps it in only when the work completed: a new run replaces the folder as a whole, so
  files of an earlier run (a figure it drew, a file it wrote) never sit beside the new ones.

Because a replaced folder is deleted, only folders that drivestyle wrote (they hold the
marker file :data:`OUTPUT_MARKER`), empty folders and absent ones are replaced; a folder
with other files is refused with a message, as is the working folder. An output is never
one of the run's own inputs, nor lies inside an input folder drivestyle wrote, nor (when
replaced whole) holds an input: :func:`refuse_inputs`, the one rule every command's
output check applies. A name the file system cannot hold is refused naming the option.
Outputs get ordinary permissions (files 0666, folders 0777, less the umask: 0644 and 0755
with the usual umask 022).

One writer at a time: two runs into the same output would both report success while one
run's output silently replaced the other's. So an output has a lock (:class:`OutputLock`:
``flock`` on the file :func:`lock_file`, ``.NAME.drivestyle-lock`` *beside* the output, so
that replacing the folder never drops it), and a second writer is refused with a message
naming the output and the holder's pid:

- a command (:func:`~drivestyle.common.cli.run_cli` runs its ``main`` inside
  :func:`command_outputs`) takes the lock where :func:`check_output_dir` or
  :func:`check_output_file` accepts its output, before any work, and holds it until it
  ends: on return, an error, Ctrl-C or SIGTERM (turned into ``SystemExit(143)`` for the
  command's duration) the lock is released and its file removed;
- outside a command, :func:`atomic_output_dir` holds the lock for its block (so does the
  mining output, :class:`~drivestyle.irl.identification.mining_output.MiningOutput`); inside one it
  uses the command's;
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
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import shlex
import shutil
import socket
import sys
import time
from collections.abc import Iterable, Iterator
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.parallel import sigterm_stops_the_job

try:  # POSIX; elsewhere outputs are not locked
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

__all__ = [
    "LOCK_SUFFIX",
    "OUTPUT_MARKER",
    "OutputInUseError",
    "OutputLock",
    "OutputPathError",
    "atomic_output_dir",
    "atomic_output_file",
    "check_output_dir",
    "check_output_file",
    "command_line",
    "command_outputs",
    "fmt",
    "lock_file",
    "output_lock",
    "read_json",
    "refuse_inputs",
    "write_json",
    "write_text",
]

OUTPUT_MARKER = ".drivestyle-output"
"""File in every output folder drivestyle writes: such a folder may be replaced by a new run."""


LOCK_SUFFIX = ".drivestyle-lock"
"""Suffix of an output's lock file (:func:`lock_file`)."""


class OutputPathError(ValueError):
    """An output path cannot be used (a file where a folder is asked for, not writable, …)."""


class OutputInUseError(OutputPathError):
    """Another run is writing this output: it holds the output's lock."""

    def __init__(self, message: str, pid: int | None) -> None:
        super().__init__(message)
        self.pid = pid
        """The holder's pid (None: its record was unreadable)."""


def read_json(
    path: str | Path, default_name: str, error: type[Exception], what: str
) -> tuple[Path, dict[str, Any]]:
    """Read a JSON result file (or ``default_name`` inside a folder) with clear errors.

    Args:
        path: the file or its folder.
        default_name: file name to look for inside a folder.
        error: exception class for malformed content.
        what: what the file is, for messages ("style library", …).

    Returns:
        (resolved path, parsed object).

    Raises:
        FileNotFoundError: no such file.
        error: the file is not valid JSON or not a JSON object.
    """
    path = Path(path)
    if path.is_dir():
        path = path / default_name
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    try:
        raw = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise error(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(raw, dict):
        raise error(f"{path}: expected a JSON object, got {type(raw).__name__}")
    return path, raw


def fmt(value: Any, digits: int = 3) -> str:
    """A number for a Markdown table ('—' for None)."""
    if value is None:
        return "—"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def command_line(argv: list[str] | None = None) -> str:
    """The invoking command as it can be rerun, shell-quoted.

    ``drivestyle <command> …`` for the installed command (whose dispatcher sets
    ``sys.argv[0]`` to ``"drivestyle <command>"``: quoting that as one word gave the
    un-runnable ``python 'drivestyle reproduce-paper' …``), else ``python scripts/x.py …``.
    """
    argv = list(sys.argv if argv is None else argv)
    if argv and argv[0].startswith("drivestyle "):
        return shlex.join([*argv[0].split(), *argv[1:]])
    return "python " + shlex.join(argv)


def _default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON-serialisable: {type(obj).__name__}")


def _reason(exc: OSError) -> str:
    return (exc.strerror or str(exc)).lower()


NAME_ROOM = 32
"""Bytes an output's name leaves for the names drivestyle makes of it: its lock file
(``.NAME.drivestyle-lock``), its temporary folder or file (``.NAME.<pid>-<hex>.partial``) and
the previous output while it is swapped out (``.NAME.<pid>-<hex>.old``)."""


def _short(name: str) -> str:
    return name if len(name) <= 40 else f"{name[:20]}…{name[-12:]}"


def _check_name(path: Path, option: str) -> None:
    """Refuse an output path the file system cannot hold, before any system call fails on it.

    A name longer than the file system takes failed as a raw ``[Errno 36] File name too
    long`` on the first ``stat``; the output's own name must also leave :data:`NAME_ROOM`
    bytes for its lock file and temporary names.
    """
    absolute = Path(os.path.abspath(path))
    limit = 255
    with contextlib.suppress(OSError, ValueError):
        existing = absolute
        while not os.path.isdir(existing) and existing != existing.parent:
            existing = existing.parent
        limit = os.pathconf(existing, "PC_NAME_MAX")
    for part in absolute.parts[1:]:
        size = len(os.fsencode(part))
        own = part == absolute.name
        if size > limit - (NAME_ROOM if own else 0):
            most = (
                f"an output's name may be at most {limit - NAME_ROOM} (the file system's "
                f"{limit} less {NAME_ROOM} for its lock and temporary files)"
                if own
                else f"the file system takes at most {limit}"
            )
            raise OutputPathError(
                f"{option} {_short(str(path))}: the name {_short(part)!r} is {size} bytes "
                f"long; {most}"
            )
    if len(os.fsencode(str(absolute))) + NAME_ROOM > 4096:
        raise OutputPathError(f"{option} {_short(str(path))}: the path is too long")


def _probe(folder: Path, user: Path, option: str) -> None:
    """Check that files can be created in ``folder`` (or where its missing parents would be).

    A real probe (a temporary folder made and removed at once) rather than ``os.access``:
    it also sees read-only file systems, ACLs and, for root, folders no one can write.
    """
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise OutputPathError(f"{option} {user}: {existing} is not a folder")
    with _scratch(existing, ".drivestyle-probe.", "", f"{option} {user}", folder=True):
        pass


@contextlib.contextmanager
def _scratch(parent: Path, prefix: str, suffix: str, what: str, folder: bool) -> Iterator[Path]:
    """A new, empty file or folder under a fresh name in ``parent``; gone after the block.

    The name (``prefix``, this process's pid, random hex, ``suffix``) is chosen before the
    file is made, so an interrupt between making it and the block still finds it to remove:
    ``mkstemp``/``mkdtemp`` return the name only after making it, and a SIGTERM between the
    two left the file behind. Made with ``open``'s ordinary modes (the umask applies).

    Args:
        parent: the folder to make it in (must exist).
        prefix: the name's start (a dot: hidden).
        suffix: the name's end (a file keeps its output's suffix: writers pick the format).
        what: the option and path to name in the error.
        folder: make a folder (else a file).

    Raises:
        OutputPathError: it cannot be made in ``parent``.
    """
    tmp = parent / f"{prefix}{os.getpid()}-{secrets.token_hex(4)}{suffix}"
    try:
        try:
            if folder:
                os.mkdir(tmp)
            else:
                os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
        except OSError as exc:
            raise OutputPathError(
                f"{what}: cannot create files in {parent} ({_reason(exc)})"
            ) from None
        yield tmp
    finally:
        if folder:
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                tmp.unlink()


# ------------------------------------------------------------ one writer per output
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
                    f"{self.option} {self.path}: cannot lock it ({self.file}: {_reason(exc)})"
                ) from None
            except OutputPathError:
                self._remove_made()
                raise
            except OSError as exc:
                self._remove_made()
                raise OutputPathError(
                    f"{self.option} {self.path}: cannot lock it ({self.file}: {_reason(exc)})"
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
                    f"({_reason(exc)})"
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

    :func:`check_output_dir` and :func:`check_output_file` lock the outputs they accept
    for the rest of the block; on leaving it (a return, an error, Ctrl-C) the locks are
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


def _lock_for_command(path: Path, option: str) -> None:
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


def check_output_file(
    path: str | Path, option: str = "--out", *, inputs: Iterable[str | Path | None] = ()
) -> Path:
    """Check, before the work, that a result file can be written at ``path``.

    In a command (:func:`command_outputs`), the file is then locked until the command ends
    (its missing parent folders are created for the lock file, and removed again if the
    command leaves them empty).

    Args:
        path: the output file (its missing parent folders will be created).
        option: the command-line option that named it, for messages.
        inputs: the run's input files or folders (None entries are skipped): ``path`` must
            not be one of them nor lie inside one (:func:`refuse_inputs`).

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        OutputInUseError: in a command, another run writes ``path``.
        OutputPathError: ``path`` is a folder, an input or inside one, or its folder cannot
            be written.
    """
    path = Path(path)
    _check_name(path, option)
    if path.is_dir():
        raise OutputPathError(f"{option} {path} is a folder (expected a file name)")
    _probe(path.absolute().parent, path, option)
    refuse_inputs(path, inputs, option)
    _lock_for_command(path, option)
    return path


def refuse_inputs(
    path: str | Path,
    inputs: Iterable[str | Path | None],
    option: str = "--out",
    *,
    replace: bool = True,
) -> None:
    """Refuse an output that is, holds or lies inside one of the run's inputs.

    The one rule of every command that reads files and writes an output (called by
    :func:`check_output_dir` and :func:`check_output_file`, before any work):

    - the output *is* an input: writing it would overwrite what the run reads;
    - the output folder *holds* an input: a run that replaces its folder as a whole
      (``replace``) would delete it (a run that only adds its files, ``replace=False``,
      may write beside its inputs: a style beside its demonstration);
    - the output *lies inside* an input folder that a drivestyle run wrote, or the one that
      holds an input file (it holds :data:`OUTPUT_MARKER`: episodes, demonstrations, a
      library, a mining run): the run
      would write into what it reads, and the run that wrote the folder replaces it whole,
      output and all. A folder of the user's own (a library folder that also holds the
      runs made with it, the working folder) may hold outputs.

    Paths are compared resolved (symbolic links, ``..``), so no spelling slips past.

    Args:
        path: the output file or folder, as the user gave it.
        inputs: the run's input files and folders (None entries are skipped).
        option: the command-line option that named the output, for messages.
        replace: the run replaces the output folder as a whole.

    Raises:
        OutputPathError: the output and an input overlap.
    """
    final = _resolved(Path(path), option)
    for item in inputs:
        if item is None:
            continue
        source = _resolved(Path(item), option)
        if source == final:
            raise OutputPathError(
                f"{option} {path} is the input {item}: the run would write over what it "
                f"reads; choose another {option}"
            )
        if final in source.parents and replace:
            raise OutputPathError(
                f"{option} {path} holds the input {item}, which the run would replace; "
                f"choose another {option}"
            )
        written = _written_folder(source)
        if written is not None and written in final.parents:
            what = f"the input {item}" if written == source else f"{written}, which holds {item}"
            raise OutputPathError(
                f"{option} {path} lies inside {what}, which the run reads (and the run that "
                f"wrote it replaces whole); choose an {option} outside it"
            )


def _written_folder(source: Path) -> Path | None:
    """The folder a drivestyle run wrote that is or holds ``source`` (nearest first), if any."""
    for folder in (source, *source.parents):
        if (folder / OUTPUT_MARKER).is_file():
            return folder
    return None


def _resolved(path: Path, option: str) -> Path:
    """``path`` resolved; a path the system cannot resolve (a name too long) is refused."""
    try:
        return path.resolve()
    except OSError as exc:
        raise OutputPathError(f"{option} {path}: {_reason(exc)}") from None


def check_output_dir(
    path: str | Path,
    option: str = "--out",
    *,
    replace: bool = True,
    inputs: Iterable[str | Path | None] = (),
) -> Path:
    """Check, before the work, that ``path`` can be an output folder.

    In a command (:func:`command_outputs`), the folder is locked until the command ends
    (as :func:`check_output_file` locks a file) before its content is judged.

    Args:
        path: the output folder (absent, or an existing folder).
        option: the command-line option that named it, for messages.
        replace: the run replaces the folder as a whole (:func:`atomic_output_dir`); False:
            it writes files into it and keeps the others.
        inputs: the run's input files or folders (None entries are skipped): ``path`` must
            not be one of them, lie inside one, nor (``replace``) hold one
            (:func:`refuse_inputs`).

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        OutputInUseError: in a command, another run writes ``path``.
        OutputPathError: ``path`` is a file, cannot be written, is or lies inside an input,
            or (``replace``) holds files not written by drivestyle, the working folder or an
            input.
    """
    path = Path(path)
    _check_name(path, option)
    if path.exists() and not path.is_dir():
        raise OutputPathError(f"{option} {path} exists and is not a folder")
    final = path.resolve()
    _probe(final.parent, path, option)  # the temporary folder is made there
    if final.is_dir():
        _probe(final, path, option)  # its old files are deleted or new ones moved in
    refuse_inputs(path, inputs, option, replace=replace)
    # before judging the folder's content, which another writer may be about to replace
    _lock_for_command(path, option)
    if not replace or not final.is_dir():
        return path
    here = Path.cwd().resolve()
    if here == final or final in here.parents:
        raise OutputPathError(
            f"{option} {path} holds the working folder, which the run would replace; "
            "choose a subfolder"
        )
    if any(final.iterdir()) and not (final / OUTPUT_MARKER).is_file():
        raise OutputPathError(
            f"{option} {path} holds files not written by drivestyle, which the run would "
            "replace as a whole; choose a new folder or empty this one"
        )
    return path


@contextlib.contextmanager
def atomic_output_file(path: str | Path, option: str = "--out") -> Iterator[Path]:
    """Write one file under a temporary name beside ``path``; rename it into place on success.

    Yields the temporary path, which keeps ``path``'s suffix (writers such as imageio pick
    the format by it). When the block completes, the file gets ordinary permissions and
    replaces ``path``; when the block or the rename fails, the temporary file is removed.

    Args:
        path: the output file; missing parent folders are created.
        option: the command-line option that named it, for messages.

    Raises:
        OutputPathError: ``path`` is a folder, or the file cannot be created or moved.
    """
    path = Path(path)
    if path.is_dir():
        raise OutputPathError(f"{option} {path} is a folder (expected a file name)")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"cannot write {path}: {_reason(exc)}") from None
    # removed on leaving: only still there when something failed
    with _scratch(
        path.absolute().parent,
        f".{path.stem}.",
        f".partial{path.suffix}",
        f"{option} {path}",
        folder=False,
    ) as tmp:
        yield tmp
        try:
            os.replace(tmp, path)
        except OSError as exc:
            raise OutputPathError(f"cannot write {path}: {_reason(exc)}") from None


def write_text(path: str | Path, text: str) -> Path:
    """Write a text file atomically (temporary file in the same folder, then rename).

    Args:
        path: output file; parent folders are created.
        text: the content.

    Returns:
        The path written.

    Raises:
        OutputPathError: ``path`` is an existing folder, or it cannot be written.
    """
    path = Path(path)
    with atomic_output_file(path) as tmp:
        tmp.write_text(text)
    return path


def write_json(path: str | Path, payload: dict[str, Any], argv: list[str] | None = None) -> Path:
    """Write ``payload`` as indented JSON (atomically), adding ``command`` and ``created_utc``.

    Args:
        path: output file; parent folders are created.
        payload: JSON-ready dict (numpy scalars and arrays are converted).
        argv: command to record (default: ``sys.argv``).

    Returns:
        The path written.
    """
    out = {
        **payload,
        "command": command_line(argv),
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    return write_text(path, json.dumps(out, indent=2, default=_default) + "\n")


def _swap(tmp: Path, final: Path) -> None:
    """Put the folder ``tmp`` at ``final``; an old ``final`` is deleted (restored on failure)."""
    old = None
    if final.exists():
        old = final.with_name(f".{final.name}.{os.getpid()}-{secrets.token_hex(4)}.old")
        os.replace(final, old)
    try:
        os.replace(tmp, final)
    except BaseException:
        if old is not None and not final.exists():
            os.replace(old, final)  # the previous complete output stays
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _merge(tmp: Path, final: Path) -> None:
    """Move the files of ``tmp`` into the existing folder ``final``, one by one."""
    for item in sorted(tmp.rglob("*")):
        if item.is_file() and item.name != OUTPUT_MARKER:  # a user's folder stays unmarked
            target = final / item.relative_to(tmp)
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(item, target)


@contextlib.contextmanager
def atomic_output_dir(
    path: str | Path, replace: bool = True, option: str = "--out"
) -> Iterator[Path]:
    """Build an output folder under a temporary name beside it; swap it in only on success.

    Yields a fresh temporary folder next to ``path``. When the block completes, an existing
    ``path`` is replaced as a whole by the new folder (``replace=True``: files of the old
    folder are not mixed with new ones), or the new files are moved into it one by one
    (``replace=False``: for a style written next to its demonstration). When the block or
    the final move fails (including ``KeyboardInterrupt``), the temporary folder is removed
    and ``path`` keeps its previous content (or stays absent). ``path``'s lock is held
    throughout: the running command's (:func:`command_outputs`), else one for the block.

    Args:
        path: the final output folder; missing parent folders are created.
        replace: replace the folder as a whole (True) or merge the new files into it.
        option: the command-line option that named it, for messages.

    Raises:
        OutputInUseError: another run writes ``path``.
        OutputPathError: ``path`` cannot be used (see :func:`check_output_dir`) or the
            finished output cannot be moved into place.
    """
    path = check_output_dir(path, option, replace=replace)
    with output_lock(path, option):  # outside a command: for this block
        final = path.resolve()
        try:
            final.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputPathError(
                f"{option} {path}: cannot create files in {final.parent} ({_reason(exc)})"
            ) from None
        # removed on leaving: only still there when something failed
        with _scratch(final.parent, f".{final.name}.", ".partial", f"{option} {path}", True) as tmp:
            yield tmp
            merge = not replace and final.exists()
            if not merge:
                (tmp / OUTPUT_MARKER).write_text(
                    "written by drivestyle; a new run replaces this folder as a whole\n"
                )
            try:
                if merge:
                    _merge(tmp, final)
                else:
                    _swap(tmp, final)
            except OSError as exc:
                raise OutputPathError(
                    f"{option} {path}: could not move the finished output into place "
                    f"({_reason(exc)})"
                    + ("; some files may be the previous run's" if merge else "")
                ) from None
