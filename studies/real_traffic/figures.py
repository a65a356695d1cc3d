"""The recorded-traffic study's figures: one episode's reproductions; driver vs paper model."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.studies.plotting import draw_lanes, save_figure

if TYPE_CHECKING:
    from drivestyle.studies.real_traffic.driver_study import DriverTrafficStudy
    from drivestyle.studies.real_traffic.study import RealTrafficStudy

__all__ = ["EPISODE_STYLES", "plot_driver_traffic", "plot_episode"]

EPISODE_STYLES = {
    "personal reactive": {"color": "C0", "ls": "-", "lw": 2.6, "alpha": 0.8},
    "personal base": {"color": "C1", "ls": "--", "lw": 1.6},
    "general (leave-one-out)": {"color": "C2", "ls": "-.", "lw": 1.4},
    "constant velocity": {"color": "C3", "ls": ":", "lw": 1.4},
}
"""Line style per reproduction in :func:`plot_episode` (the names of the recorded-traffic study)."""


EPISODE_STYLES_FALLBACK = (
    {"color": "C4", "ls": "-", "lw": 2.0},
    {"color": "C5", "ls": "--", "lw": 1.4},
    {"color": "C6", "ls": "-.", "lw": 1.4},
    {"color": "C7", "ls": ":", "lw": 1.4},
)


def plot_episode(
    demo: Demonstration, paths: dict[str, np.ndarray], path: str | Path, title: str = ""
) -> Path:
    """Recorded vs reproduced lateral path (over x) and lateral speed (over t).

    Args:
        demo: the recorded episode.
        paths: method name → positions at the samples, shape (n, 2).
        path: output PNG.
        title: figure title.

    Returns:
        The path written.
    """
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5.5))
    a1.plot(demo.ev[:, 0], demo.ev[:, 1], "k-", lw=2.2, label="recorded", zorder=2)
    a2.plot(demo.t, np.gradient(demo.ev[:, 1], demo.t), "k-", lw=2.2, label="recorded", zorder=2)
    if np.abs(demo.tv[:, 0] - demo.ev[:, 0]).min() < 500:
        a1.plot(demo.tv[:, 0], demo.tv[:, 1], color="0.6", lw=1, label="target vehicle")
    for k, (name, xy) in enumerate(paths.items()):
        # reproductions often coincide (personal reactive and base): each its own
        # line style, later ones thinner and on top, so none hides another
        fallback = EPISODE_STYLES_FALLBACK[k % len(EPISODE_STYLES_FALLBACK)]
        line = {**EPISODE_STYLES.get(name, fallback), "zorder": 3 + k, "label": name}
        a1.plot(xy[:, 0], xy[:, 1], **line)
        a2.plot(demo.t, np.gradient(xy[:, 1], demo.t), **line)
    draw_lanes(a1, demo.scenario)
    a1.set_ylim(-0.5, 2.5 * demo.scenario.lane_width)
    a1.set_xlabel("x [m]")
    a1.set_ylabel("y [m] (lane change to +y)")
    a2.set_xlabel("t [s]")
    a2.set_ylabel("lateral speed [m/s]")
    a1.legend(fontsize=7, ncol=3)
    a2.grid(alpha=0.3)
    return save_figure(fig, path, title, dpi=110)


def plot_driver_traffic(
    study: DriverTrafficStudy, paper: RealTrafficStudy | None, path: str | Path
) -> Path:
    """Per recorded episode: rmse_y and rmse_xy, driver model beside paper model.

    The driver model's personal reproduction and, where a vehicle has several episodes, its
    leave-one-out own and general styles; the paper model's personal reactive and general.

    Args:
        study: the driver-model study.
        paper: the paper-model study of the same episodes (None: not run).
        path: output PNG.

    Returns:
        The path written.
    """
    ids = [r["episode_id"] for r in study.episodes]
    series: dict[str, list[dict | None]] = {
        f"driver {m}": [r.get(m) for r in study.episodes]
        for m in ("personal", "own_loo", "general_loo")
        if any(m in r for r in study.episodes)
    }
    if paper is not None:
        rows = {r["episode_id"]: r for r in paper.episodes if "methods" in r}
        for m in ("personal_reactive", "general"):
            series[f"paper {m}"] = [rows.get(i, {}).get("methods", {}).get(m) for i in ids]
    fig, axes = plt.subplots(2, 1, figsize=(max(7.0, 0.55 * len(ids) + 2), 6.5), sharex=True)
    width = 0.8 / len(series)
    pos = np.arange(len(ids))
    for ax, key in zip(axes, ("rmse_y_m", "rmse_xy_m"), strict=True):
        for k, (name, vals) in enumerate(series.items()):
            h = [np.nan if v is None else v[key] for v in vals]
            ax.bar(pos + (k - (len(series) - 1) / 2) * width, h, width, label=name)
        ax.set_ylabel(key.replace("_m", " [m]"))
        ax.set_yscale("log")
        ax.grid(alpha=0.3, axis="y")
    axes[0].legend(fontsize=7, ncol=3)
    axes[1].set_xticks(pos, [i[:18] for i in ids], rotation=60, ha="right", fontsize=7)
    return save_figure(fig, path, f"{study.dataset}: driver model vs paper model", dpi=110)
