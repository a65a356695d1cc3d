"""Fixtures of the studies' tests."""

import importlib
from pathlib import Path

import pytest

STUDIES = Path(__file__).resolve().parents[2] / "studies"


def _figure_modules() -> list[str]:
    """Every figure module of the studies: plotting.py and each (study's) figures.py."""
    paths = [STUDIES / "plotting.py", *STUDIES.rglob("figures.py")]
    return ["drivestyle." + ".".join(p.relative_to(STUDIES.parent).with_suffix("").parts)
            for p in paths]  # fmt: skip


@pytest.fixture
def drawn(monkeypatch):
    """The figures drawn, kept open instead of saved."""
    import matplotlib.pyplot as plt

    kept = []

    def keep(fig, path, title=None, dpi=130):
        kept.append(fig)
        return path

    for name in _figure_modules():
        module = importlib.import_module(name)
        if hasattr(module, "save_figure"):
            monkeypatch.setattr(module, "save_figure", keep)
    yield kept
    for fig in kept:
        plt.close(fig)
