"""Layers common ← envs ← recorded ← planning ← irl ← prediction ← agents ← studies ← scripts.

Checked on every import, nested ones included.
"""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = {
    "common": ROOT / "drivestyle" / "common",
    "envs": ROOT / "envs",
    "recorded": ROOT / "recorded",
    "planning": ROOT / "planning",
    "irl": ROOT / "irl",
    "prediction": ROOT / "prediction",
    "agents": ROOT / "agents",
    "studies": ROOT / "studies",
    "scripts": ROOT / "scripts",
}
"""Lowest first: a layer may import only itself and the layers before it."""
GENERIC = {
    "envs", "recorded", "planning", "irl", "prediction", "agents", "studies", "scripts", "common"
}  # fmt: skip
"""Top-level names that must never be imported bare: the library is ``drivestyle.*``."""


def _imported_modules(path: Path) -> set[tuple[int, str]]:
    """(line, absolute module) of every import in a module, nested ones included."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {(node.lineno, a.name) for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add((node.lineno, node.module))
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module":
            arg = node.args[0] if node.args else None
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                found.add((node.lineno, arg.value))
    return found


def _layer(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] == "drivestyle" and len(parts) > 1 and parts[1] in LAYERS:
        return parts[1]
    return None


@pytest.mark.parametrize("layer", list(LAYERS))
def test_lower_layers_never_import_higher_ones(layer):
    names = list(LAYERS)
    higher = set(names[names.index(layer) + 1 :])
    offenders = [
        f"{path.relative_to(ROOT)}:{line} imports {module}"
        for path in sorted(LAYERS[layer].rglob("*.py"))
        for line, module in _imported_modules(path)
        if _layer(module) in higher
    ]
    assert not offenders, offenders


@pytest.mark.parametrize("folder", ["drivestyle", *LAYERS, "tests"])
def test_nothing_imports_a_generic_top_level_name(folder):
    offenders = [
        f"{path.relative_to(ROOT)}:{line} imports {module}"
        for path in sorted((ROOT / folder).rglob("*.py"))
        for line, module in _imported_modules(path)
        if module.split(".")[0] in GENERIC
    ]
    assert not offenders, offenders


def test_the_checker_sees_nested_imports(tmp_path):
    module = tmp_path / "m.py"
    module.write_text(
        "def f():\n    from drivestyle.agents.smpc import SMPCExpert\n"
        "    import drivestyle.irl.paper.spline\n    import envs\n"
    )
    found = {m for _, m in _imported_modules(module)}
    assert found == {"drivestyle.agents.smpc", "drivestyle.irl.paper.spline", "envs"}
    assert {_layer(m) for m in found} == {"agents", "irl", None}


def test_code_cites_only_documents_in_the_repository():
    # the external spec is not shipped; code cites docs/DESIGN.md instead
    pattern = re.compile(r"\bSPEC\s*§")
    offenders = [
        str(path.relative_to(ROOT))
        for folder in ("drivestyle", *LAYERS, "tests")
        for path in sorted((ROOT / folder).rglob("*.py"))
        if pattern.search(path.read_text())
    ]
    assert not offenders, offenders
    assert (ROOT / "docs" / "DESIGN.md").is_file()
