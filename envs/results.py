"""Writing result files: JSON with the command that produced it."""

from __future__ import annotations

import json
import shlex
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["command_line", "fmt", "read_json", "write_json"]


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
        error: the file is not valid JSON.
    """
    path = Path(path)
    if path.is_dir():
        path = path / default_name
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    try:
        return path, json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise error(f"{path}: not valid JSON ({exc})") from None


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


def write_json(path: str | Path, payload: dict[str, Any], argv: list[str] | None = None) -> Path:
    """Write ``payload`` as indented JSON, adding ``command`` and ``created_utc``.

    Args:
        path: output file; parent folders are created.
        payload: JSON-ready dict (numpy scalars and arrays are converted).
        argv: command to record (default: ``sys.argv``).

    Returns:
        The path written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = {
        **payload,
        "command": command_line(argv),
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    path.write_text(json.dumps(out, indent=2, default=_default) + "\n")
    return path
