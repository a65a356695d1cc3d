"""The package layering envs ← irl ← agents ← scripts, checked on every import statement."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("envs", "irl", "agents")
"""Lowest first: a package may import only itself and the packages before it."""


def _imported_packages(path: Path) -> set[tuple[int, str]]:
    """(line, top-level package) of every import in a module, nested ones included."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {(node.lineno, a.name.split(".")[0]) for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add((node.lineno, node.module.split(".")[0]))
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module":
            arg = node.args[0] if node.args else None
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                found.add((node.lineno, arg.value.split(".")[0]))
    return found


@pytest.mark.parametrize("package", LAYERS)
def test_lower_packages_never_import_higher_ones(package):
    higher = set(LAYERS[LAYERS.index(package) + 1 :]) | {"scripts"}
    offenders = [
        f"{path.relative_to(ROOT)}:{line} imports {pkg}"
        for path in sorted((ROOT / package).rglob("*.py"))
        for line, pkg in _imported_packages(path)
        if pkg in higher
    ]
    assert not offenders, offenders


def test_the_checker_sees_nested_imports(tmp_path):
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from agents.smpc import SMPCExpert\n    import irl.spline\n")
    assert {pkg for _, pkg in _imported_packages(module)} == {"agents", "irl"}


def test_code_cites_only_documents_in_the_repository():
    # the external spec is not shipped; code cites docs/DESIGN.md instead
    pattern = re.compile(r"\bSPEC\s*§")
    offenders = [
        str(path.relative_to(ROOT))
        for folder in (*LAYERS, "scripts", "tests")
        for path in sorted((ROOT / folder).rglob("*.py"))
        if pattern.search(path.read_text())
    ]
    assert not offenders, offenders
    assert (ROOT / "docs" / "DESIGN.md").is_file()
