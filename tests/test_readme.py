"""The README's commands run in order on a fresh clone: every input is written before.

Every ``runs/…`` path a command block or a Python example reads must be written by an
earlier command (its ``--out`` folder or ``--video`` file), and a path *inside* such a
folder must be one the command is known to write (:data:`WRITES`, each entry checked
against the code that writes it). The commands' durations the README states are checked
against docs/RESULTS.md's measurements elsewhere; this file checks order and paths only.
"""

import fnmatch
import json
import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

WRITES = {
    "reproduce-paper": ("demo/demo.npz", "reactive/style.json", "base/style.json"),
    "build-style-library": ("demos/p*_s*.npz", "library.json"),
    "extract-episodes": ("*.npz", "episodes.csv"),
    "build-posterior": ("posterior.npz",),
}
"""Files inside its --out folder that a command writes and the README reads."""
WRITTEN_BY = {
    "reproduce-paper": ("studies/paper/study.py", ('"demo" / "demo.npz"', '"style.json"')),
    "build-style-library": ("scripts/build_style_library.py", ('f"p{p:g}_s{i}.npz"',)),
    "extract-episodes": ("recorded/episode_files.py", ('return f"{name}.npz"', "episodes.csv")),
    "build-posterior": ("scripts/build_posterior.py", ('"posterior.npz"',)),
}
"""Where the code writes :data:`WRITES` (the test fails if the code stops writing them)."""
OUTPUT_OPTIONS = ("--out", "--video")


def _steps() -> list[tuple[str, object]]:
    """The README's code in document order: ("bash", tokens) per command, ("python", text)."""
    steps: list[tuple[str, object]] = []
    for language, block in re.findall(r"(?ms)^```(bash|python)\n(.*?)^```", README.read_text()):
        if language == "python":
            steps.append(("python", block))
            continue
        for line in block.splitlines():
            line = line.split(" #", 1)[0].strip()
            if not line or line.startswith("#"):
                continue
            for part in line.split("&&"):
                steps.append(("bash", shlex.split(part)))
    return steps


def _commands() -> list[list[str]]:
    return [tokens for language, tokens in _steps() if language == "bash"]  # type: ignore[misc]


def _outputs(tokens: list[str]) -> list[str]:
    return [tokens[i + 1] for i, t in enumerate(tokens[:-1]) if t in OUTPUT_OPTIONS]


def _inputs(tokens: list[str]) -> list[str]:
    outs = set(_outputs(tokens))
    return [t for t in tokens if t.startswith("runs/") and t not in outs]


def _written(path: str, written: dict[str, str]) -> bool:
    """Whether ``path`` (maybe a glob) was written by an earlier command."""
    for out, command in written.items():
        if path == out:
            return True
        if path.startswith(out + "/"):
            inner = path[len(out) + 1 :]
            known = WRITES.get(command, ())
            if any(fnmatch.fnmatch(inner, k) or fnmatch.fnmatch(k, inner) for k in known):
                return True
    return False


PYTHON_WRITES = re.compile(r"to_csv\(\s*\"(runs/[^\"]+)\"")
"""A path a Python example writes (its other ``runs/…`` strings are read)."""
PYTHON_WRITE_TABLE = re.compile(r"write_table\((?:[^()]|\([^()]*\))*\)")
"""A ``write_table(recording, csv, lanes)`` call: both ``runs/…`` paths in it are written."""


def _python_writes(block: str) -> set[str]:
    """The ``runs/…`` paths a Python example writes (:data:`PYTHON_WRITES`, write_table)."""
    calls = PYTHON_WRITE_TABLE.findall(block)
    return {*PYTHON_WRITES.findall(block)} | {
        path for call in calls for path in re.findall(r"\"(runs/[^\"]+)\"", call)
    }


def _missing_inputs() -> list[str]:
    written: dict[str, str] = {}
    missing = []
    for language, step in _steps():
        if language == "python":
            outs = _python_writes(step)
            for path in re.findall(r"\"(runs/[^\"]+)\"", step):
                if path not in outs and not _written(path, written):
                    missing.append(f"a Python example reads {path}")
            written.update(dict.fromkeys(outs, "python"))
            continue
        tokens = step
        if tokens[:1] != ["drivestyle"]:
            continue
        command = tokens[1]
        missing += [
            f"`{shlex.join(tokens)}` reads {p}" for p in _inputs(tokens) if not _written(p, written)
        ]
        for out in _outputs(tokens):
            written[out] = command
    return missing


def test_every_path_a_readme_command_reads_is_written_by_an_earlier_command():
    assert _commands(), "the README has no command blocks"
    missing = _missing_inputs()
    assert not missing, missing


def test_the_checker_finds_a_path_no_command_writes(monkeypatch):
    text = "```bash\ndrivestyle identify-style runs/demo/demo.npz --out runs/x\n```\n"
    monkeypatch.setattr(Path, "read_text", lambda self, *a, **k: text)
    assert _missing_inputs() == [
        "`drivestyle identify-style runs/demo/demo.npz --out runs/x` reads runs/demo/demo.npz"
    ]


def test_the_checker_reads_what_write_table_writes():
    block = 'write_table(read_sample("x"), "runs/a.csv", "runs/a.json")\nload("runs/b.npz")'
    assert _python_writes(block) == {"runs/a.csv", "runs/a.json"}


@pytest.mark.parametrize("command", sorted(WRITTEN_BY))
def test_the_files_the_readme_reads_inside_an_output_folder_are_written_by_the_code(command):
    source, snippets = WRITTEN_BY[command]
    text = (ROOT / source).read_text()
    assert all(s in text for s in snippets), (command, source, snippets)


@pytest.mark.slow
def test_the_your_own_data_example_runs_as_written(tmp_path):
    """The README's own-data blocks, verbatim, in a folder with a (smaller) library.

    The library's p = 0.6 demonstration of scenario 0 is the same file whatever the
    library's size, so the example's episode name and answer hold.
    """
    import subprocess
    import sys

    text = README.read_text()
    section = text[text.index("### Your own data") :]
    python = re.search(r"(?ms)^```python\n(.*?)^```", section).group(1)
    bash = re.search(r"(?ms)^```bash\n(.*?)^```", section).group(1)
    build = ["drivestyle", "build-style-library", "--risks", "0.5,0.6", "--scenarios", "1",
             "--calibration", "2", "--out", "runs/library"]  # fmt: skip
    run = subprocess.run(build, cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    run = subprocess.run(
        [sys.executable, "-c", python], cwd=tmp_path, capture_output=True, text=True
    )
    assert run.returncode == 0, run.stderr
    for line in bash.strip().splitlines():
        run = subprocess.run(shlex.split(line), cwd=tmp_path, capture_output=True, text=True)
        assert run.returncode == 0, (line, run.stderr)
    identified = json.loads((tmp_path / "runs" / "identify_own" / "identify.json").read_text())
    assert identified["risk_estimate"] == pytest.approx(0.6, abs=0.05)
