"""Fixtures of the studies' tests."""

import importlib

import pytest

FIGURE_MODULES = (
    "drivestyle.studies.plotting",
    "drivestyle.studies.figures",
    "drivestyle.studies.paper.figures",
    "drivestyle.studies.compare.figures",
    "drivestyle.studies.identification.figures",
    "drivestyle.studies.real_traffic.figures",
    "drivestyle.studies.cut_in.figures",
    "drivestyle.studies.av_vs_human.figures",
)
"""Every module that saves a figure through ``save_figure``."""


@pytest.fixture
def drawn(monkeypatch):
    """The figures drawn, kept open instead of saved."""
    import matplotlib.pyplot as plt

    kept = []

    def keep(fig, path, title=None, dpi=130):
        kept.append(fig)
        return path

    for name in FIGURE_MODULES:
        monkeypatch.setattr(importlib.import_module(name), "save_figure", keep)
    yield kept
    for fig in kept:
        plt.close(fig)
