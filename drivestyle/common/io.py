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

One writer at a time: an output has a lock (:mod:`drivestyle.common.output_lock`), taken by
the checks above in a command and by :func:`atomic_output_dir` outside one. The rules of an
output's path (its name, a writable folder, no input overwritten, scratch names) live in
:mod:`drivestyle.common.output_paths`.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import shlex
import shutil
import sys
from collections.abc import Iterable, Iterator
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.output_lock import lock_for_command, output_lock
from drivestyle.common.output_paths import (
    OUTPUT_MARKER,
    OutputPathError,
    check_name,
    os_error_reason,
    probe_writable,
    refuse_inputs,
    scratch,
)

__all__ = [
    "atomic_output_dir",
    "atomic_output_file",
    "check_output_dir",
    "check_output_file",
    "command_line",
    "fmt",
    "read_json",
    "write_json",
    "write_text",
]


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


def check_output_file(
    path: str | Path, option: str = "--out", *, inputs: Iterable[str | Path | None] = ()
) -> Path:
    """Check, before the work, that a result file can be written at ``path``.

    In a command (:func:`~drivestyle.common.output_lock.command_outputs`), the file is then
    locked until the command ends (its missing parent folders are created for the lock file,
    and removed again if the command leaves them empty).

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
    check_name(path, option)
    if path.is_dir():
        raise OutputPathError(f"{option} {path} is a folder (expected a file name)")
    probe_writable(path.absolute().parent, path, option)
    refuse_inputs(path, inputs, option)
    lock_for_command(path, option)
    return path


def check_output_dir(
    path: str | Path,
    option: str = "--out",
    *,
    replace: bool = True,
    inputs: Iterable[str | Path | None] = (),
) -> Path:
    """Check, before the work, that ``path`` can be an output folder.

    In a command (:func:`~drivestyle.common.output_lock.command_outputs`), the folder is
    locked until the command ends (as :func:`check_output_file` locks a file) before its
    content is judged.

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
    check_name(path, option)
    if path.exists() and not path.is_dir():
        raise OutputPathError(f"{option} {path} exists and is not a folder")
    final = path.resolve()
    probe_writable(final.parent, path, option)  # the temporary folder is made there
    if final.is_dir():
        probe_writable(final, path, option)  # its old files are deleted or new ones moved in
    refuse_inputs(path, inputs, option, replace=replace)
    # before judging the folder's content, which another writer may be about to replace
    lock_for_command(path, option)
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
        raise OutputPathError(f"cannot write {path}: {os_error_reason(exc)}") from None
    # removed on leaving: only still there when something failed
    with scratch(
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
            raise OutputPathError(f"cannot write {path}: {os_error_reason(exc)}") from None


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
    throughout: the running command's
    (:func:`~drivestyle.common.output_lock.command_outputs`), else one for the block.

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
                f"{option} {path}: cannot create files in {final.parent} ({os_error_reason(exc)})"
            ) from None
        # removed on leaving: only still there when something failed
        with scratch(final.parent, f".{final.name}.", ".partial", f"{option} {path}", True) as tmp:
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
                    f"({os_error_reason(exc)})"
                    + ("; some files may be the previous run's" if merge else "")
                ) from None
