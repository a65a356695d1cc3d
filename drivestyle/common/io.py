"""Result files: JSON with the command that produced it, atomic writes and output folders.

Every file a script writes goes through here, so that an interrupted run (Ctrl-C, a
crash) leaves either the previous complete output or none, never a half-written file:

- :func:`write_json` and :func:`write_text` write to a temporary file beside the target
  and rename it into place (``os.replace`` is atomic on POSIX and Windows);
- :func:`atomic_output_dir` builds a whole output folder under a temporary name and swaps
  it in only when the work completed.
"""

from __future__ import annotations

import contextlib
import json
import os
import shlex
import shutil
import sys
import tempfile
from collections.abc import Iterator
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "OutputPathError",
    "atomic_output_dir",
    "check_output_dir",
    "command_line",
    "fmt",
    "read_json",
    "write_json",
    "write_text",
]


class OutputPathError(ValueError):
    """An output path cannot be used (e.g. a folder was asked for and a file is there)."""


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
    """The invoking command, shell-quoted (``python scripts/x.py --flag …``)."""
    argv = sys.argv if argv is None else argv
    return "python " + " ".join(shlex.quote(a) for a in argv)


def _default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON-serialisable: {type(obj).__name__}")


def write_text(path: str | Path, text: str) -> Path:
    """Write a text file atomically (temporary file in the same folder, then rename).

    Args:
        path: output file; parent folders are created.
        text: the content.

    Returns:
        The path written.

    Raises:
        OutputPathError: ``path`` is an existing folder.
    """
    path = Path(path)
    if path.is_dir():
        raise OutputPathError(f"cannot write {path}: it is a folder")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
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


def check_output_dir(path: str | Path) -> Path:
    """Check that ``path`` can be an output folder (absent, or an existing folder).

    Raises:
        OutputPathError: ``path`` exists and is not a folder.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputPathError(f"--out {path} exists and is not a folder")
    return path


@contextlib.contextmanager
def atomic_output_dir(path: str | Path, replace: bool = True) -> Iterator[Path]:
    """Build an output folder under a temporary name; swap it in only on success.

    Yields a fresh temporary folder next to ``path``. When the block completes, an existing
    ``path`` is replaced as a whole by the new folder (``replace=True``: files of the old
    folder are not mixed with new ones), or the new files are moved into it one by one
    (``replace=False``: for scripts whose outputs share a folder with other files, e.g. a
    style written next to its demonstration). When the block raises (including
    ``KeyboardInterrupt``), the temporary folder is removed and ``path`` keeps its previous
    content (or stays absent).

    Args:
        path: the final output folder.
        replace: replace the folder as a whole (True) or merge the new files into it.

    Raises:
        OutputPathError: ``path`` exists and is not a folder.
    """
    path = check_output_dir(path).resolve()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".partial", dir=path.parent))
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o777 & ~umask)  # mkdtemp makes it private; the output is an ordinary folder
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if not replace and path.exists():
        for item in sorted(tmp.rglob("*")):
            if item.is_file():
                target = path / item.relative_to(tmp)
                target.parent.mkdir(parents=True, exist_ok=True)
                os.replace(item, target)
        shutil.rmtree(tmp, ignore_errors=True)
        return
    old = None
    if path.exists():
        old = path.with_name(f".{path.name}.old-{os.getpid()}")
        os.replace(path, old)
    os.replace(tmp, path)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
