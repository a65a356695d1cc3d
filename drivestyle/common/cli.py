"""What every command-line script shares: clear one-line errors, Ctrl-C, checked arguments.

:func:`run_cli` wraps a script's ``main``: a bad input (a missing or malformed file, an
invalid value, a solver that cannot start) ends with one line ``error: …`` naming the
problem and exit status 2; Ctrl-C ends with exit status 130 after the script's atomic
writes (:mod:`drivestyle.common.io`) have discarded the unfinished output; anything
unexpected ends with one line and exit status 1 (``DRIVESTYLE_TRACEBACK=1`` shows the
traceback).

The ``argparse`` types below reject out-of-range values at parse time, so a script never
starts long work on an argument it would ignore or misread.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable
from typing import Any

__all__ = [
    "EXIT_INTERRUPTED",
    "EXIT_UNEXPECTED",
    "EXIT_USER_ERROR",
    "USER_ERRORS",
    "finite_float",
    "float_list",
    "nonnegative_int",
    "positive_float",
    "positive_int",
    "risk_list",
    "risk_value",
    "run_cli",
]

EXIT_USER_ERROR = 2
"""Exit status of a bad input or environment (as ``argparse`` exits on a bad option)."""
EXIT_UNEXPECTED = 1
"""Exit status of an unexpected error (a bug)."""
EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT, the shell's convention)."""

USER_ERRORS: tuple[type[BaseException], ...] = (
    OSError,  # missing, unreadable or unwritable files and folders
    ValueError,  # includes DemonstrationError, StyleError, LibraryError, OutputPathError
    RuntimeError,  # solver failures that the library reports with a message
)
"""Exceptions that mean "bad input or environment" and carry a message for the user."""


def run_cli(main: Callable[[list[str] | None], Any], argv: list[str] | None = None) -> None:
    """Run a script's ``main`` with the project's error and interrupt handling.

    Args:
        main: the script's entry point (parses ``argv`` itself).
        argv: arguments (default: ``sys.argv[1:]``).
    """
    try:
        main(argv)
    except KeyboardInterrupt:
        print("\ninterrupted: unfinished output was discarded", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    except SystemExit:
        raise
    except USER_ERRORS as exc:
        if os.environ.get("DRIVESTYLE_TRACEBACK"):
            raise
        # not sys.exit(message): that exits with status 1, the status of an unexpected error
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(EXIT_USER_ERROR)
    except Exception as exc:  # last resort: one line, not a traceback
        if os.environ.get("DRIVESTYLE_TRACEBACK"):
            raise
        print(
            f"error: unexpected {type(exc).__name__}: {exc} "
            "(set DRIVESTYLE_TRACEBACK=1 to see where)",
            file=sys.stderr,
        )
        sys.exit(EXIT_UNEXPECTED)


def _number(text: str, kind: type, what: str) -> Any:
    try:
        return kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None


def positive_int(text: str) -> int:
    """An integer ≥ 1."""
    value = _number(text, int, "an integer")
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def nonnegative_int(text: str) -> int:
    """An integer ≥ 0."""
    value = _number(text, int, "an integer")
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def positive_float(text: str) -> float:
    """A finite number > 0."""
    value = _number(text, float, "a number")
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def finite_float(text: str) -> float:
    """Any finite number."""
    value = _number(text, float, "a number")
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
    return value


def risk_value(text: str) -> float:
    """A risk level p in (0, 1)."""
    value = _number(text, float, "a number")
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"a risk must lie in (0, 1), got {text}")
    return value


def float_list(text: str) -> list[float]:
    """Comma-separated numbers, e.g. ``0.5,0.6``."""
    values = [_number(v, float, "a number") for v in text.split(",") if v.strip()]
    if not values:
        raise argparse.ArgumentTypeError("expected comma-separated numbers, got none")
    return values


def risk_list(text: str) -> list[float]:
    """Comma-separated distinct risks in (0, 1), returned sorted."""
    values = float_list(text)
    bad = [p for p in values if not 0 < p < 1]
    if bad:
        raise argparse.ArgumentTypeError(f"risks must lie in (0, 1), got {bad}")
    if len(set(values)) != len(values):
        raise argparse.ArgumentTypeError(f"risks must be distinct, got {values}")
    return sorted(values)
