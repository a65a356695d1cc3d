"""Output paths: what an output may be named, where it can be written, and its scratch names.

The checks every command's output goes through before any work
(:func:`drivestyle.common.io.check_output_dir` and :func:`~drivestyle.common.io.check_output_file`
call them): a name the file system can hold with :data:`NAME_ROOM` bytes to spare for the names
made of it (:func:`check_name`), a folder files can be created in (:func:`probe_writable`, a
real probe), and never one of the run's own inputs (:func:`refuse_inputs`, the one rule). A
temporary file or folder gets its name before it is made (:func:`scratch`), so an interrupt
always finds it to remove. :data:`OUTPUT_MARKER` marks the folders drivestyle wrote.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
from collections.abc import Iterable, Iterator
from pathlib import Path

__all__ = [
    "NAME_ROOM",
    "OUTPUT_MARKER",
    "OutputPathError",
    "check_name",
    "os_error_reason",
    "probe_writable",
    "refuse_inputs",
    "scratch",
]

OUTPUT_MARKER = ".drivestyle-output"
"""File in every output folder drivestyle writes: such a folder may be replaced by a new run."""


class OutputPathError(ValueError):
    """An output path cannot be used (a file where a folder is asked for, not writable, …)."""


def os_error_reason(exc: OSError) -> str:
    """An OS error's reason in words, lower case (for messages naming the path)."""
    return (exc.strerror or str(exc)).lower()


NAME_ROOM = 32
"""Bytes an output's name leaves for the names drivestyle makes of it: its lock file
(``.NAME.drivestyle-lock``), its temporary folder or file (``.NAME.<pid>-<hex>.partial``) and
the previous output while it is swapped out (``.NAME.<pid>-<hex>.old``)."""


def _short(name: str) -> str:
    return name if len(name) <= 40 else f"{name[:20]}…{name[-12:]}"


def check_name(path: Path, option: str) -> None:
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


def probe_writable(folder: Path, user: Path, option: str) -> None:
    """Check that files can be created in ``folder`` (or where its missing parents would be).

    A real probe (a temporary folder made and removed at once) rather than ``os.access``:
    it also sees read-only file systems, ACLs and, for root, folders no one can write.
    """
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise OutputPathError(f"{option} {user}: {existing} is not a folder")
    with scratch(existing, ".drivestyle-probe.", "", f"{option} {user}", folder=True):
        pass


@contextlib.contextmanager
def scratch(parent: Path, prefix: str, suffix: str, what: str, folder: bool) -> Iterator[Path]:
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
                f"{what}: cannot create files in {parent} ({os_error_reason(exc)})"
            ) from None
        yield tmp
    finally:
        if folder:
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                tmp.unlink()


def refuse_inputs(
    path: str | Path,
    inputs: Iterable[str | Path | None],
    option: str = "--out",
    *,
    replace: bool = True,
) -> None:
    """Refuse an output that is, holds or lies inside one of the run's inputs.

    The one rule of every command that reads files and writes an output (called by
    :func:`~drivestyle.common.io.check_output_dir` and
    :func:`~drivestyle.common.io.check_output_file`, before any work):

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
        raise OutputPathError(f"{option} {path}: {os_error_reason(exc)}") from None
