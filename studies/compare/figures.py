"""The comparison study's figures: the compared drivers' paths and the held-out errors."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.paper.spline import spline_eval
from drivestyle.studies.plotting import draw_lanes, save_figure

if TYPE_CHECKING:
    from drivestyle.studies.compare.study import HeldoutComparison

__all__ = ["COMPARISON_STYLES", "plot_comparison", "plot_heldout"]

COMPARISON_STYLES = {
    "smpc": ("r--", "SMPC demonstration"),
    "spline": ("b-", "spline reproduction r*_θ"),
    "sb3": ("g-", "SB3 policy on the learned reward"),
}
"""Line format and label per method of :func:`plot_comparison`."""


def plot_comparison(
    demo: Demonstration, trajectories: dict[str, np.ndarray], path: str | Path, title: str = ""
) -> Path:
    """x–y paths and lateral velocity of compared trajectories (``compare.png``).

    Args:
        demo: the reference demonstration (scenario and sample times).
        trajectories: method name → control points at the samples (may be shorter).
        path: output PNG.
        title: figure title.

    Returns:
        The path written.
    """
    sc = demo.scenario
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6))
    draw_lanes(a1, sc)
    a1.plot(demo.tv[:, 0], demo.tv[:, 1], color="0.3", lw=1, label="TV")
    for name, C in trajectories.items():
        line, label = COMPARISON_STYLES.get(name, ("k-", name))
        t = demo.t[: C.shape[0]]
        tt = np.linspace(t[0], t[-1], 10 * (t.size - 1) + 1)
        pos = spline_eval(C, t, tt, 0)
        vel = spline_eval(C, t, tt, 1)
        a1.plot(pos[:, 0], pos[:, 1], line, lw=1.6, label=label)
        a2.plot(tt, vel[:, 1], line, lw=1.6, label=label)
    a1.set_xlabel("x [m]")
    a1.set_ylabel("y [m]")
    a1.set_ylim(0, sc.road_width)
    a1.legend(fontsize=8, loc="upper left", ncol=2)
    a2.set_xlabel("t [s]")
    a2.set_ylabel("lateral velocity [m/s]")
    a2.grid(alpha=0.3)
    return save_figure(fig, path, title, dpi=120)


def plot_heldout(result: HeldoutComparison, path: str | Path) -> Path:
    """rmse_y against SMPC(p) per method over the held-out scenarios (``heldout.png``)."""
    names = list(result.summary)[1:]  # the SMPC is the reference (0 by definition)
    data = [
        [
            s["methods"][n]["rmse_y_m"]
            for s in result.per_scenario
            if s["methods"][n]["rmse_y_m"] is not None
        ]
        for n in names
    ]
    fig, ax = plt.subplots(figsize=(6, 3.8))
    ax.boxplot(data, tick_labels=names)
    ax.set_ylabel("rmse_y against SMPC(p) [m]")
    ax.set_title(f"{result.summary[names[0]].n} held-out scenarios")
    ax.grid(alpha=0.3)
    return save_figure(fig, path, dpi=120)
