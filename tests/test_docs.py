"""The design document's sections run in order and every "DESIGN §n" citation exists."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DESIGN = ROOT / "docs" / "DESIGN.md"


def _sections() -> list[int]:
    return [int(m) for m in re.findall(r"(?m)^## (\d+)\. ", DESIGN.read_text())]


def test_design_sections_are_numbered_one_to_n_in_order():
    numbers = _sections()
    assert numbers == list(range(1, len(numbers) + 1)), numbers


def test_every_design_citation_names_an_existing_section():
    existing = set(_sections())
    cite = re.compile(r"DESIGN(?:\.md)? *§ *(\d+)")
    files = [ROOT / "README.md", *(ROOT / "docs").glob("*.md")]
    folders = (
        "drivestyle", "envs", "recorded", "planning", "irl", "prediction", "agents", "studies",
        "scripts", "tests",
    )  # fmt: skip
    for folder in folders:
        files += sorted((ROOT / folder).rglob("*.py"))
    missing = [
        f"{path.relative_to(ROOT)}: §{n}"
        for path in files
        for n in map(int, cite.findall(path.read_text()))
        if n not in existing
    ]
    assert not missing, missing


def test_the_readme_layout_table_names_every_module_and_only_existing_ones():
    readme = (ROOT / "README.md").read_text()
    table = [line for line in readme.splitlines() if line.startswith("| `")]
    named = {m for line in table for m in re.findall(r"`((?:\w+/)+\w+\.py)`", line.split("|")[1])}
    missing = sorted(m for m in named if not (ROOT / m).is_file())
    assert not missing, f"README names modules that do not exist: {missing}"
    folders = (
        "drivestyle", "envs", "recorded", "planning", "irl", "prediction", "agents", "studies"
    )  # fmt: skip
    modules = {
        str(path.relative_to(ROOT))
        for folder in folders
        for path in (ROOT / folder).rglob("*.py")
        if path.name not in ("__init__.py", "__main__.py")
    }
    unlisted = sorted(modules - named)
    assert not unlisted, f"modules missing from the README's layout table: {unlisted}"
