"""The prediction study's figures, and the figure of one prediction.

:func:`plot_prediction` draws one vehicle's observed path, its true future and every
method's prediction to scale (``example_prediction.png`` of ``evaluate-prediction``,
``prediction.png`` of ``predict-trajectory``); :func:`plot_prediction_errors` the mean FDE of
every method against t_obs (``fde_by_method.png``); :func:`plot_fde_by_kind` the recorded
episodes' FDE median per kind and method with its 95 % interval (``fde_by_kind.png``);
:func:`plot_joint_scene` one scene's joint prediction with its regions
(``joint_scene.png``); :func:`plot_posterior_over_time` the online posterior of a few vehicles
(``posterior_over_time.png``). Colours, lanes and saving
are :mod:`drivestyle.studies.plotting`'s.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Circle, Polygon

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import vehicle_corners
from drivestyle.prediction.joint import JointPrediction
from drivestyle.prediction.methods import METHODS, Prediction
from drivestyle.recorded.kinds import ALL_KINDS, STOP_AND_GO
from drivestyle.studies.formatting import seconds
from drivestyle.studies.plotting import (
    EV_RED,
    SCALED_ORANGE,
    TV_BLUE,
    draw_lanes,
    save_figure,
)
from drivestyle.studies.prediction.study import PredictionStudy
from drivestyle.studies.prediction.summaries import report_set, shown_kinds
from drivestyle.studies.prediction.tracking import TrackingRecord

__all__ = [
    "METHOD_STYLES",
    "plot_fde_by_kind",
    "plot_joint_scene",
    "plot_posterior_over_time",
    "plot_prediction",
    "plot_prediction_errors",
]


METHOD_STYLES: dict[str, dict[str, Any]] = {
    "cv": {"color": "#6b7280", "ls": "--", "lw": 1.4},
    "ca": {"color": "#a3a3a3", "ls": ":", "lw": 1.4},
    "physics": {"color": "#7c3aed", "ls": "-", "lw": 1.4},
    "joint_physics": {"color": "#c026d3", "ls": "--", "lw": 1.4},
    "population": {"color": "#16a34a", "ls": "-.", "lw": 1.4},
    "mode": {"color": EV_RED, "ls": "-", "lw": 1.8},
    "mixture": {"color": SCALED_ORANGE, "ls": "--", "lw": 1.6},
    "style_alone": {"color": "#0891b2", "ls": "--", "lw": 1.6},
    "style_joint": {"color": "#0e7490", "ls": "-", "lw": 2.0},
    "oracle": {"color": TV_BLUE, "ls": ":", "lw": 2.0},
}
"""Line style per prediction method: one entry for every name of
:data:`drivestyle.prediction.methods.METHODS` (a test checks it)."""


def plot_prediction(
    prediction: Prediction, demo: Demonstration, path: str | Path, title: str = ""
) -> Path:
    """One vehicle's observed path, its true future and every method's prediction, to scale.

    The road panel has equal axes (as
    :func:`~drivestyle.studies.plotting.plot_demonstration`): lanes, the surrounding vehicles'
    paths over the predicted time, the vehicle and its neighbours at t_obs as rectangles. The
    x range follows the truth; a prediction that leaves it is cut.

    Args:
        prediction: :func:`drivestyle.prediction.methods.predict`'s result.
        demo: the demonstration predicted (its scenario draws the road).
        path: output PNG.
        title: figure title.
    """
    sc = demo.scenario
    k = len(prediction.observed) - 1
    xy_all = np.vstack([prediction.observed, prediction.actual])
    x_lo = float(xy_all[:, 0].min()) - sc.vehicle_length * 2
    x_hi = float(xy_all[:, 0].max()) + sc.vehicle_length * 2
    y_lo, y_hi = -0.5, sc.road_width + 0.5
    width = 11.0
    road_h = max(width * 0.9 * (y_hi - y_lo) / (x_hi - x_lo), 1.2)
    fig, ax = plt.subplots(figsize=(width, road_h + 1.9))
    draw_lanes(ax, sc)
    others = demo.vehicles[k:]
    for j in range(others.shape[1]):
        ax.plot(others[:, j, 0], others[:, j, 1], "-", color="0.6", lw=1.0,
                label="other vehicles (truth)" if j == 0 else None)  # fmt: skip
    for state in demo.vehicles[k]:
        corners = vehicle_corners(state, sc.vehicle_length, sc.vehicle_width)
        ax.add_patch(Polygon(corners, closed=True, fc="0.6", ec="k", lw=0.5, alpha=0.7))
    corners = vehicle_corners(demo.ev[k], sc.vehicle_length, sc.vehicle_width)
    ax.add_patch(Polygon(corners, closed=True, fc=EV_RED, ec="k", lw=0.5, alpha=0.8))
    ax.plot(*prediction.observed.T, "-", color="k", lw=2.4,
            label=f"observed ({seconds(prediction.t_obs)})")  # fmt: skip
    ax.plot(*prediction.actual.T, "-", color="k", lw=1.2, alpha=0.5, label="truth")
    for name in METHODS:
        m = prediction.methods.get(name)
        if m is None:
            continue
        risk = "" if m.risk is None else f", p={m.risk:.2f}"
        ax.plot(*m.xy.T, **METHOD_STYLES[name], label=f"{name} (FDE {m.fde_m:.2f} m{risk})")
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m] (to scale)")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.35), fontsize=8, ncol=4, frameon=False)
    return save_figure(fig, path, title or None)


def plot_joint_scene(
    scene: JointPrediction,
    view: Demonstration,
    k: int,
    path: str | Path,
    title: str = "",
    cv_final: np.ndarray | None = None,
) -> Path:
    """One scene's joint prediction: every vehicle's point path, its draws and 90 % region.

    To scale: lanes, each vehicle's observed path (thick), its true future (thin grey), the
    point prediction (each vehicle's colour; dashed where it kept its velocity, not being
    driven), the draws (faint) and the disc holding 90 % of the draws' final positions; the
    vehicles at t_obs as rectangles, the predicted one red.

    Args:
        scene: :meth:`~drivestyle.prediction.joint.JointStyle.predict_scene`'s result.
        view: the demonstration the scene was observed in (its vehicles in the scene's order:
            the EV, then its ``vehicles``; its scenario draws the road).
        k: the last observed sample.
        path: output PNG.
        title: figure title.
        cv_final: the predicted vehicle's final position at constant velocity, drawn as a
            cross (None: not drawn).
    """
    sc = view.scenario
    truth = np.concatenate([view.ev[:, None], view.vehicles], axis=1)  # (n, V_all, 4)
    n_v = scene.paths.shape[2]
    shown = truth[:, :n_v]
    colours = [EV_RED, TV_BLUE, SCALED_ORANGE, "#16a34a", "#7c3aed", "#0891b2"]
    pts = np.concatenate([shown[:, :, :2].reshape(-1, 2), scene.point.reshape(-1, 2)])
    x_lo, x_hi = float(pts[:, 0].min()) - 8.0, float(pts[:, 0].max()) + 8.0
    y_lo, y_hi = -0.5, sc.road_width + 0.5
    width = 12.0
    road_h = max(width * 0.9 * (y_hi - y_lo) / (x_hi - x_lo), 1.4)
    fig, ax = plt.subplots(figsize=(width, road_h + 2.8))
    draw_lanes(ax, sc)
    radius = scene.region_radius()
    for i in range(n_v):
        c = colours[i % len(colours)]
        name = "predicted vehicle" if i == 0 else f"vehicle {i}"
        ax.plot(*shown[: k + 1, i, :2].T, "-", color=c, lw=2.6, label=f"{name}: observed")
        ax.plot(*shown[k:, i, :2].T, "-", color="0.45", lw=1.0,
                label="truth" if i == 0 else None)  # fmt: skip
        for d in scene.paths[1:, :, i]:
            ax.plot(*d.T, "-", color=c, lw=0.5, alpha=0.25)
        ls, note = ("-", "") if scene.reactive[i] else ("--", " (CV)")
        ax.plot(*scene.point[:, i].T, ls, color=c, lw=1.6,
                label=f"{name}: point prediction{note}")  # fmt: skip
        if scene.reactive[i]:
            ax.add_patch(Circle(scene.point[-1, i], float(radius[i]), fc=c, ec=c, alpha=0.12))
        corners = vehicle_corners(shown[k, i], sc.vehicle_length, sc.vehicle_width)
        ax.add_patch(Polygon(corners, closed=True, fc=c, ec="k", lw=0.5, alpha=0.8))
    if cv_final is not None:
        ax.plot(*cv_final, "x", color="k", ms=8, label="constant velocity (final)")
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m] (to scale)")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.22), fontsize=7, ncol=3, frameon=False)
    fig.subplots_adjust(bottom=0.42)
    return save_figure(fig, path, title or None)


def plot_prediction_errors(study: PredictionStudy, path: str | Path) -> Path:
    """Mean FDE of every method against t_obs, one panel per set (log scale)."""
    sets = list(dict.fromkeys(s.set for s in study.summaries))
    fig, axes = plt.subplots(1, max(len(sets), 1), figsize=(4.2 * max(len(sets), 1), 3.8),
                             squeeze=False)  # fmt: skip
    for ax, set_name in zip(axes[0], sets, strict=False):
        for name in METHODS:
            rows = [s for s in study.summaries if s.set == set_name and s.method == name]
            if not rows:
                continue
            style = METHOD_STYLES[name]
            ax.plot([r.t_obs for r in rows], [max(r.fde_mean_m, 1e-3) for r in rows], "o",
                    color=style["color"], ls=style["ls"], lw=style["lw"], label=name)  # fmt: skip
        n = max((s.n for s in study.summaries if s.set == set_name), default=0)
        ax.set_title(f"{set_name} (n ≤ {n} per t_obs)", fontsize=10)
        ax.set_yscale("log")
        ax.set_xlabel("observed time t_obs [s]")
        ax.set_ylabel("mean FDE [m] (floor 1 mm: an exact oracle)")
        ax.grid(alpha=0.3, which="both")
    axes[0][0].legend(fontsize=8)
    return save_figure(fig, path, "Final displacement error by method", dpi=120)


def plot_fde_by_kind(study: PredictionStudy, path: str | Path) -> Path | None:
    """The recorded episodes' FDE median by kind and method, bars with 95 % intervals.

    One panel per t_obs, stacked; along x the kinds the report shows
    (:func:`~drivestyle.studies.prediction.summaries.shown_kinds`: every kind pooled, each
    kind, the stop-and-go windows), one bar per method (its colour of
    :data:`METHOD_STYLES`) with the bootstrap 95 % interval of the median (vehicles
    resampled); each group labelled with its predictions (vehicles) at that t_obs. The set is
    :func:`~drivestyle.studies.prediction.summaries.report_set`'s (every recorded episode).

    Returns:
        The path, or None where the run has no recorded episode (nothing drawn).
    """
    set_name = report_set([s.set for s in study.kind_summaries])
    groups = shown_kinds(study.kind_summaries)
    if set_name is None or not groups:
        return None
    times = sorted({s.t_obs for s in study.kind_summaries if s.set == set_name})
    here = [s for s in study.kind_summaries if s.set == set_name]
    methods = [m for m in METHODS if any(s.method == m for s in here)]
    width = 0.8 / len(methods)
    width_in = max(5.0, 1.2 * len(groups) + 2.0)
    fig, axes = plt.subplots(len(times), 1, figsize=(width_in, 2.9 * len(times)), squeeze=False)
    for ax, t in zip(axes[:, 0], times, strict=True):
        labelled: set[str] = set()
        for j, method in enumerate(methods):
            for i, kind in enumerate(groups):
                s = study.summary(set_name, t, method, kind)
                if s is None:
                    continue
                st = s.stats["fde"]
                x = i - 0.4 + (j + 0.5) * width
                color = METHOD_STYLES[method]["color"]
                label = None if method in labelled else method
                labelled.add(method)
                ax.bar(x, st.median, width, color=color, label=label)
                yerr = [[st.median - st.median_lo], [st.median_hi - st.median]]
                ax.errorbar(x, st.median, yerr, fmt="none", ecolor="k", elinewidth=0.8, capsize=2)
        labels = []
        for kind in groups:
            s = study.summary(set_name, t, methods[0], kind)
            n = "" if s is None else f"\n{s.n} ({s.n_units})"
            name = {ALL_KINDS: "all kinds", STOP_AND_GO: "stop-and-go"}.get(kind)
            labels.append((name or kind.replace("_", " ")) + n)
        ax.set_xticks(range(len(groups)), labels, fontsize=8)
        ax.set_title(f"t_obs = {seconds(t)}", fontsize=10)
        ax.set_ylabel("FDE median [m]")
        ax.grid(alpha=0.3, axis="y")
    axes[0][0].legend(fontsize=7, ncol=3, loc="best")
    title = (
        f"Final displacement error by kind of episode ({set_name})\nmedian with its 95 % "
        "interval over vehicles; under each kind: predictions (vehicles)"
    )
    return save_figure(fig, path, title, dpi=120)


def plot_posterior_over_time(
    tracks: Sequence[TrackingRecord], path: str | Path, title: str = ""
) -> Path:
    """The online risk posterior over time: mean and 90 % band, one panel per vehicle.

    Args:
        tracks: the vehicles to show (e.g. spanning the risk range).
        path: output PNG.
        title: figure title.
    """
    n = max(len(tracks), 1)
    fig, axes = plt.subplots(1, n, figsize=(3.3 * n, 3.4), sharey=True, squeeze=False)
    for ax, tr in zip(axes[0], tracks, strict=False):
        t = np.asarray(tr.t)
        ax.fill_between(t, tr.lo, tr.hi, step="post", color=EV_RED, alpha=0.2,
                        label="90 % interval")  # fmt: skip
        ax.plot(t, tr.mean, "-", color=EV_RED, lw=1.6, label="posterior mean")
        ax.axhline(tr.true_risk, color="k", ls="--", lw=1.0, label="true risk")
        if tr.t_narrow is not None:
            ax.axvline(tr.t_narrow, color=TV_BLUE, ls=":", lw=1.2,
                       label="interval < 0.2 first")  # fmt: skip
        ax.set_title(f"{tr.vehicle_id}: p = {tr.true_risk:.2f}", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.set_ylim(0.48, 1.0)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("risk p")
    axes[0][0].legend(fontsize=7, loc="lower left")
    return save_figure(fig, path, title or "Online identification: the posterior over time")
