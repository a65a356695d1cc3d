"""Fixtures of the command tests."""

from collections.abc import Callable

import pytest
from cli_runner import run_command


@pytest.fixture()
def refused(tmp_path) -> Callable[..., str]:
    """Run a command that must refuse its input: exit 2, one line ``error: …``, no traceback
    (``note:`` and ``warning:`` lines may precede it).

    Returns the error line (without ``error: ``); ``--out`` (when given) must not exist after.
    """

    def run(command: str, *args) -> str:
        done = run_command(tmp_path, command, *args)
        assert done.returncode == 2, f"exit {done.returncode}\n{done.stderr[-3000:]}"
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        assert lines and lines[-1].startswith("error: "), done.stderr[-3000:]
        assert "Traceback" not in done.stderr, done.stderr[-3000:]
        # notes and warnings about the inputs (e.g. the shipped samples' overlapping vehicles)
        # may come first; the refusal itself is one line
        notes = [line for line in lines[:-1] if not line.startswith(("note: ", "warning: "))]
        assert not notes, f"more than the error line:\n{done.stderr[-3000:]}"
        listed = [str(a) for a in args]
        if "--out" in listed:
            assert not (tmp_path / listed[listed.index("--out") + 1]).exists(), "output written"
        return lines[-1].removeprefix("error: ")

    return run


@pytest.fixture()
def refused_option(tmp_path) -> Callable[..., str]:
    """Run a command whose option its parser refuses: exit 2 and the usage, then one line
    ``<prog>: error: argument <option>: …``; returns what follows ``argument``."""

    def run(command: str, *args) -> str:
        done = run_command(tmp_path, command, *args)
        assert done.returncode == 2, f"exit {done.returncode}\n{done.stderr[-3000:]}"
        last = done.stderr.strip().splitlines()[-1]
        prefix = f"drivestyle {command}: error: argument "
        assert last.startswith(prefix) and "Traceback" not in done.stderr, done.stderr[-3000:]
        return last.removeprefix(prefix)

    return run
