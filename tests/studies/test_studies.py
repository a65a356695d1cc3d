"""The studies' rooms: each study writes its Markdown in a report module and draws its
figures in a figure module; matplotlib is imported by figure modules only."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LIBRARY = ("drivestyle", "envs", "recorded", "planning", "irl", "prediction", "agents", "studies")


def _is_report(path: str) -> bool:
    parts = path.split("/")
    return parts[0] == "studies" and (parts[-1] == "report.py" and len(parts) == 3)


def _is_figures(path: str) -> bool:
    parts = path.split("/")
    return parts[0] == "studies" and (
        (parts[-1] == "figures.py" and len(parts) == 3) or path == "studies/plotting.py"
    )


def test_every_markdown_writer_lives_in_a_report_module():
    writers = []
    for folder in LIBRARY:
        for path in (ROOT / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.FunctionDef) and "markdown" in node.name:
                    writers.append((str(path.relative_to(ROOT)), node.name))
    assert writers and all(_is_report(path) for path, _ in writers), writers


def test_only_figure_modules_import_matplotlib():
    importers = []
    for folder in (*LIBRARY, "scripts"):
        for path in (ROOT / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                names = (
                    [a.name for a in node.names]
                    if isinstance(node, ast.Import)
                    else [node.module or ""]
                    if isinstance(node, ast.ImportFrom)
                    else []
                )
                if any(n.split(".")[0] == "matplotlib" for n in names):
                    importers.append(str(path.relative_to(ROOT)))
                    break
    assert "studies/plotting.py" in importers  # the one that selects the backend
    assert all(_is_figures(path) for path in importers), importers
