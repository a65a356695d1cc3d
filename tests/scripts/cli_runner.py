"""Running a command as a user runs it: ``python -m drivestyle <command> …`` in a fresh process."""

import os
import subprocess
import sys
from pathlib import Path

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
"""The recorded samples beside the checkout (``../shared/data``)."""


def run_command(
    cwd: Path, command: str, *args, timeout: float = 600
) -> subprocess.CompletedProcess:
    """``python -m drivestyle COMMAND ARGS`` in ``cwd`` (no traceback switch, no display)."""
    env = {**os.environ, "MPLBACKEND": "Agg", "SDL_VIDEODRIVER": "dummy"}
    env.pop("DRIVESTYLE_TRACEBACK", None)
    return subprocess.run(
        [sys.executable, "-m", "drivestyle", command, *map(str, args)],
        cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env,
    )  # fmt: skip
