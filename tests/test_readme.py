"""The README's commands run in order on a fresh clone: every input is written before.

Every ``runs/…`` path a command block or a Python example reads must be written by an
earlier command (its ``--out`` folder or ``--video`` file), and a path *inside* such a
folder must be one the command is known to write (:data:`WRITES`, each entry checked
against the code that writes it). The commands' durations the README states are checked
against docs/RESULTS.md's measurements elsewhere; this file checks order and paths only.
"""

import fnmatch
import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"

WRITES = {
    "reproduce-paper": ("demo/demo.npz", "reactive/style.json", "base/style.json"),
    "build-style-library": ("demos/p*_s*.npz", "library.json"),
}
"""Files inside its --out folder that a command writes and the README reads."""
WRITTEN_BY = {
    "reproduce-paper": ("agents/studies/paper.py", ('"demo" / "demo.npz"', '"style.json"')),
    "build-style-library": ("scripts/build_style_library.py", ('f"p{p:g}_s{i}.npz"',)),
}
"""Where the code writes :data:`WRITES` (the test fails if the code stops writing them)."""
OUTPUT_OPTIONS = ("--out", "--video")


def _blocks(language: str) -> list[str]:
    return re.findall(rf"(?ms)^```{language}\n(.*?)^```", README.read_text())


def _commands() -> list[list[str]]:
    commands = []
    for block in _blocks("bash"):
        for line in block.splitlines():
            line = line.split(" #", 1)[0].strip()
            if not line or line.startswith("#"):
                continue
            for part in line.split("&&"):
                commands.append(shlex.split(part))
    return commands


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


def _missing_inputs() -> list[str]:
    written: dict[str, str] = {}
    missing = []
    for tokens in _commands():
        if tokens[:1] != ["drivestyle"]:
            continue
        command = tokens[1]
        missing += [
            f"`{shlex.join(tokens)}` reads {p}" for p in _inputs(tokens) if not _written(p, written)
        ]
        for out in _outputs(tokens):
            written[out] = command
    for block in _blocks("python"):
        for path in re.findall(r"\"(runs/[^\"]+)\"", block):
            if not _written(path, written):
                missing.append(f"a Python example reads {path}")
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


@pytest.mark.parametrize("command", sorted(WRITTEN_BY))
def test_the_files_the_readme_reads_inside_an_output_folder_are_written_by_the_code(command):
    source, snippets = WRITTEN_BY[command]
    text = (ROOT / source).read_text()
    assert all(s in text for s in snippets), (command, source, snippets)
