"""The cut-in study's figure: per scene, the ego's braking and distance by predictor."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from drivestyle.studies.plotting import EV_RED, TV_BLUE, save_figure

if TYPE_CHECKING:
    from drivestyle.studies.cut_in.study import PlanningStudy

__all__ = ["PREDICTOR_COLOURS", "plot_planning"]

PREDICTOR_COLOURS = {"cv": "#6b7280", "style": EV_RED, "oracle": TV_BLUE}
"""Colours of the cut-in study's predictors."""


def plot_planning(study: PlanningStudy, path: str | Path) -> Path:
    """The cut-in study: per scene, the ego's hardest braking and least distance by predictor.

    Left: hardest braking of the style-aware and oracle egos against the CV ego's (below
    the diagonal: gentler). Right: least centre distance likewise (above: farther).
    """
    by = {(r.seed, r.method): r for r in study.runs}
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.4))
    for ax, attr, label in (
        (axes[0], "hardest_braking", "hardest braking [m/s²]"),
        (axes[1], "min_distance_m", "least distance to the cutter [m]"),
    ):
        cv = np.array([getattr(by[s, "cv"], attr) for s in study.seeds])
        for method in ("style", "oracle"):
            other = np.array([getattr(by[s, method], attr) for s in study.seeds])
            ax.scatter(cv, other, s=14, alpha=0.7, color=PREDICTOR_COLOURS[method],
                       label=f"{method} (mean {other.mean():.2f})")  # fmt: skip
        lo = min(ax.get_xlim()[0], ax.get_ylim()[0])
        hi = max(ax.get_xlim()[1], ax.get_ylim()[1])
        ax.plot([lo, hi], [lo, hi], color="black", lw=0.8, ls="--")
        ax.set_xlabel(f"CV ego: {label} (mean {cv.mean():.2f})")
        ax.set_ylabel(label)
        ax.legend(loc="best", fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(f"Cut-in: the ego's prediction of the lane changer ({len(study.seeds)} scenes)")
    return save_figure(fig, path)
