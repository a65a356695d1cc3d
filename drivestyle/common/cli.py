"""What every command-line script shares: clear one-line errors, Ctrl-C, checked arguments.

:func:`run_cli` wraps a script's ``main``: a bad input (a missing or malformed file, an
invalid value, a solver that cannot start, an output another run is writing) ends with one
line ``error: …`` naming the problem and exit status 2; Ctrl-C ends with exit status 130
and SIGTERM with 143 after the script's atomic writes (:mod:`drivestyle.common.io`) have
discarded the unfinished output (a script that keeps some, e.g. a resumable run's finished
rows, says what with :class:`Interrupted`); anything unexpected ends with one line and exit
status 1 (``DRIVESTYLE_TRACEBACK=1`` shows the traceback). The outputs the script checks
stay locked while it runs (:func:`~drivestyle.common.output_lock.command_outputs`): a second run
into them is refused.

The ``argparse`` types below reject out-of-range values at parse time, so a script never
starts long work on an argument it would ignore or misread: every ``--seed`` is a
:func:`seed`, every ``--workers`` a :func:`workers`, and every number of simulated things
(scenes, vehicles, scenarios, steps) a :func:`count` bounded where the work would take days
or the memory run out — the error says the bound and what it would cost.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Hashable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

from drivestyle.common.output_lock import command_outputs

_T = TypeVar("_T", bound=Hashable)

__all__ = [
    "EXIT_INTERRUPTED",
    "EXIT_UNEXPECTED",
    "EXIT_USER_ERROR",
    "INTERRUPTED",
    "SEED_MAX",
    "USER_ERRORS",
    "HelpFormatter",
    "Interrupted",
    "count",
    "distinct",
    "finite_float",
    "float_list",
    "for_option",
    "fraction",
    "nonnegative_int",
    "nonnegative_list",
    "positive_float",
    "positive_int",
    "positive_list",
    "risk_list",
    "risk_value",
    "run_cli",
    "seed",
    "workers",
]

EXIT_USER_ERROR = 2
"""Exit status of a bad input or environment (as ``argparse`` exits on a bad option)."""
EXIT_UNEXPECTED = 1
"""Exit status of an unexpected error (a bug)."""
EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT, the shell's convention)."""
SEED_MAX = 2**32 - 1
"""Largest seed: numpy's legacy ``np.random.seed`` (which SB3 and gymnasium's spaces call)
takes seeds in [0, 2³² − 1]; ``default_rng`` refuses negative ones."""
WORKERS_PER_CPU = 4
"""``--workers`` beyond this many per core only add processes (each with its own solvers,
≈ 0.2 GB) competing for the same cores."""

USER_ERRORS: tuple[type[BaseException], ...] = (
    OSError,  # missing, unreadable or unwritable files and folders
    ValueError,  # includes DemonstrationError, StyleError, LibraryError, OutputPathError
    RuntimeError,  # solver failures that the library reports with a message
)
"""Exceptions that mean "bad input or environment" and carry a message for the user."""


INTERRUPTED = "unfinished output was discarded"
"""What Ctrl-C leaves of a command that writes its output atomically (most of them)."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C, with what a command keeps of its work (:func:`run_cli` says it).

    A command whose output is not discarded on Ctrl-C (mine-styles keeps its finished rows
    for the resume) raises this from the ``KeyboardInterrupt`` with the true words.
    """


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help that shows each option's default once.

    ``ArgumentDefaultsHelpFormatter`` appends ``(default: X)`` to every option, also where
    the help already says its default in words (``(default: all)`` then came twice) and
    where there is nothing to show (``(default: None)``, ``(default: False)``). This one
    appends it only where the help is silent about the default and the default is a value.
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if "default" in text.lower() or action.default in (None, False, argparse.SUPPRESS):
            return text
        return super()._get_help_string(action)


def run_cli(main: Callable[[list[str] | None], Any], argv: list[str] | None = None) -> None:
    """Run a script's ``main`` with the project's error and interrupt handling.

    Args:
        main: the script's entry point (parses ``argv`` itself).
        argv: arguments (default: ``sys.argv[1:]``).
    """
    try:
        try:
            with command_outputs():
                main(argv)
        except SystemError as exc:
            # a C extension (CasADi's function call) that saw a signal handler raise returns
            # its result anyway, and Python wraps the handler's exception: Ctrl-C or SIGTERM
            if isinstance(exc.__cause__, (KeyboardInterrupt, SystemExit)):
                raise exc.__cause__ from None
            raise
    except KeyboardInterrupt as exc:
        said = str(exc) if isinstance(exc, Interrupted) and str(exc) else INTERRUPTED
        print(f"\ninterrupted: {said}", file=sys.stderr)
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


def fraction(text: str) -> float:
    """A number in [0, 1] (a share of something: 0 none, 1 all of it)."""
    value = _number(text, float, "a number")
    if not 0 <= value <= 1:
        raise argparse.ArgumentTypeError(f"must lie in [0, 1], got {text}")
    return value


def risk_value(text: str) -> float:
    """A risk level p in (0, 1)."""
    value = _number(text, float, "a number")
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"a risk must lie in (0, 1), got {text}")
    return value


def float_list(text: str) -> list[float]:
    """Comma-separated numbers, e.g. ``0.5,0.6``; an empty field is refused, never dropped.

    ``0,,7.5`` is a slip (a number left out), and dropping the field silently would read
    two numbers where three were meant.
    """
    fields = text.split(",")
    if not text.strip():
        raise argparse.ArgumentTypeError("expected comma-separated numbers, got none")
    empty = [k for k, v in enumerate(fields) if not v.strip()]
    if empty:
        raise argparse.ArgumentTypeError(
            f"{text!r} has an empty field (number {empty[0] + 1} of {len(fields)}): give the "
            "numbers separated by single commas, e.g. 0,3.75,7.5"
        )
    return [_number(v, float, "a number") for v in fields]


def _said(values: Sequence[float]) -> str:
    """Numbers as a user writes them (``1``, ``0.95``), comma-separated."""
    return ", ".join(f"{v:g}" for v in values)


def positive_list(text: str) -> list[float]:
    """Comma-separated finite numbers > 0 (factors, scales)."""
    values = float_list(text)
    bad = [v for v in values if not (math.isfinite(v) and v > 0)]
    if bad:
        raise argparse.ArgumentTypeError(f"must be finite numbers > 0, got {_said(bad)}")
    return values


def nonnegative_list(text: str) -> list[float]:
    """Comma-separated finite numbers >= 0 (noise levels: 0 is none)."""
    values = float_list(text)
    bad = [v for v in values if not (math.isfinite(v) and v >= 0)]
    if bad:
        raise argparse.ArgumentTypeError(f"must be finite numbers >= 0, got {_said(bad)}")
    return values


def risk_list(text: str) -> list[float]:
    """Comma-separated distinct risks in (0, 1), returned sorted.

    Each value's range is checked before the list's (repeats here; how many a command needs
    in its ``main``, where a narrower range of its own comes first too): a risk of 1 is
    said to be out of range, never to be too few.
    """
    values = float_list(text)
    bad = [p for p in values if not 0 < p < 1]
    if bad:
        raise argparse.ArgumentTypeError(f"risks must lie in (0, 1), got {_said(bad)}")
    if len(set(values)) != len(values):
        raise argparse.ArgumentTypeError(f"risks must be distinct, got {_said(values)}")
    return sorted(values)


def seed(text: str) -> int:
    """A random seed: an integer in [0, :data:`SEED_MAX`] (numpy refuses negative seeds)."""
    value = _number(text, int, "an integer")
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(
            f"a seed is an integer in [0, {SEED_MAX}] (numpy takes no other), got {value}"
        )
    return value


def workers(text: str) -> int:
    """A number of worker processes: 1 … :data:`WORKERS_PER_CPU` × the machine's cores."""
    value = positive_int(text)
    cores = os.cpu_count() or 1
    limit = WORKERS_PER_CPU * cores
    if value > limit:
        raise argparse.ArgumentTypeError(
            f"at most {limit} worker processes on this machine ({WORKERS_PER_CPU} per core, "
            f"{cores} cores: more only add processes of ≈ 0.2 GB each), got {value}"
        )
    return value


def _duration(seconds: float) -> str:
    units = (("days", 86400.0), ("hours", 3600.0), ("minutes", 60.0), ("s", 1.0), ("ms", 1e-3))
    for unit, size in units:
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds / 1e-6:.3g} µs"


def _bytes(n: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.3g} bytes"


def count(
    limit: int, seconds_each: float, what: str, bytes_each: float = 0.0, least: int = 1
) -> Callable[[str], int]:
    """An argparse type: how many of something, an integer in [``least``, ``limit``].

    Args:
        limit: the largest number a run may ask for (where the work takes days or more, or
            the memory runs out).
        seconds_each: the rough cost of one on one core [s], said in the error.
        what: what is counted, plural ("scenes"), said in the error.
        bytes_each: the rough memory one holds at once with all the others [bytes] (0:
            the count costs time, not memory), said in the error.
        least: the smallest number (0 where none of it is a choice, e.g. no scenarios).

    Returns:
        The type function (its error names the bound and the time, and memory, the bound
        already takes).
    """

    def parse(text: str) -> int:
        value = _number(text, int, "an integer")
        if value < least:
            raise argparse.ArgumentTypeError(f"must be >= {least}, got {value}")
        if value > limit:
            memory = f" and ≈ {_bytes(limit * bytes_each)} of memory" if bytes_each > 0 else ""
            each = f"{_duration(seconds_each)}" + (
                f" and {_bytes(bytes_each)}" if bytes_each > 0 else ""
            )
            raise argparse.ArgumentTypeError(
                f"at most {limit:,} {what} (≈ {each} each: the bound alone is "
                f"≈ {_duration(limit * seconds_each)} of work on one core{memory}), got {value:,}"
            )
        return value

    parse.__name__ = f"count of {what}"  # argparse names the type in some messages
    return parse


@contextmanager
def for_option(option: str) -> Iterator[None]:
    """Errors of reading an option's file, said as the option's: ``--physics FILE: …``.

    The readers name the file first (``FILE: no such file``); the option in front tells the
    user which of their words it was. A missing file stays a ``FileNotFoundError``, other
    ``OSError`` and ``ValueError`` keep their kind (:data:`USER_ERRORS`: one line, exit 2).
    """
    try:
        yield
    except FileNotFoundError as exc:
        raise FileNotFoundError(f"{option} {exc}") from None
    except OSError as exc:
        raise OSError(f"{option} {exc}") from None
    except ValueError as exc:
        raise ValueError(f"{option} {exc}") from None


def distinct(values: Sequence[_T]) -> tuple[list[_T], list[_T]]:
    """``values`` without repeats (first occurrences, in order) and the repeated values.

    For options and arguments that list things to count once: the caller says which were
    given twice (a value counted twice would weigh twice in a summary or a posterior).
    """
    seen: set[_T] = set()
    kept: list[_T] = []
    repeated: list[_T] = []
    for v in values:
        if v in seen:
            if v not in repeated:
                repeated.append(v)
            continue
        seen.add(v)
        kept.append(v)
    return kept, repeated
