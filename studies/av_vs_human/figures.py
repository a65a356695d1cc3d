"""The AV-against-humans study's figure: each quantity's lane changes, medians, intervals."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from drivestyle.studies.av_vs_human.study import GROUPS, QUANTITIES
from drivestyle.studies.plotting import save_figure

if TYPE_CHECKING:
    from drivestyle.studies.av_vs_human.study import AVHumanComparison

__all__ = ["plot_av_human"]


def plot_av_human(comparison: AVHumanComparison, path: str | Path) -> Path:
    """Each quantity's lane changes per group (dots), medians and 95 % intervals (bars)."""
    shown = [q for q in QUANTITIES if any(s.n for s in comparison.stats if s.quantity == q)]
    cols = 3
    rows = max(1, -(-len(shown) // cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.2 * rows), squeeze=False)
    jitter = np.random.default_rng(0)
    for ax, q in zip(axes.ravel(), shown, strict=False):
        for i, g in enumerate(GROUPS):
            x = [e.values[q] for e in comparison.episodes if e.group == g]
            x = [v for v in x if v is not None]
            ax.scatter(i + jitter.uniform(-0.15, 0.15, len(x)), x, s=10, alpha=0.5, color="0.4")
            s = next(s for s in comparison.stats if s.quantity == q and s.group == g)
            if s.median is not None and s.lo is not None and s.hi is not None:
                ax.errorbar(i, s.median, yerr=[[s.median - s.lo], [s.hi - s.median]], fmt="o",
                            color="C3", capsize=4, lw=2)  # fmt: skip
        ax.set_xticks(range(len(GROUPS)), [g.replace(", ", ",\n") for g in GROUPS], fontsize=8)
        ax.set_title(QUANTITIES[q], fontsize=8)
    for ax in axes.ravel()[len(shown) :]:
        ax.set_visible(False)
    return save_figure(fig, path, "CATS: the automated car (AV) against human drivers")
