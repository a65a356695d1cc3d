"""Figures of the learning study (the paper's Figs. 3 and 4)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from envs.demonstration import Demonstration
from envs.plotting import draw_lanes, save_figure
from irl.learner import LearningResult
from irl.spline import spline_eval

__all__ = ["plot_lateral", "plot_reproductions", "select_iterations"]

PAPER_ITERATIONS = (1, 11, 21)


def select_iterations(
    result: LearningResult, wanted: Sequence[int] = PAPER_ITERATIONS
) -> list[int]:
    """The paper's iterations 1, 11, 21 that exist, plus the last one."""
    n = len(result.history)
    its = [i for i in wanted if i <= n]
    if n not in its:
        its.append(n)
    return its


def _fine(C: np.ndarray, t: np.ndarray, derivative: int) -> tuple[np.ndarray, np.ndarray]:
    tt = np.linspace(t[0], t[-1], 20 * (t.size - 1) + 1)
    return tt, spline_eval(C, t, tt, derivative)


def plot_reproductions(
    demo: Demonstration,
    results: dict[str, LearningResult],
    demo_C: np.ndarray,
    path: str | Path,
    react_window=None,
) -> Path:
    """Reproduced x–y paths at iterations 1, 11, 21 and the last (Fig. 3).

    One panel per feature set (base on top, reactive below), the demonstration overlaid.

    Args:
        demo: the demonstration.
        results: feature-set name → learning result (history with control points).
        demo_C: the demonstration's control points (for its spline).
        path: output PNG.
        react_window: (x_start, x_end) of the reaction to shade, or None.

    Returns:
        The path written.
    """
    sc = demo.scenario
    fig, axes = plt.subplots(
        len(results), 1, figsize=(9, 3.2 * len(results)), sharex=True, squeeze=False
    )
    cmap = plt.get_cmap("viridis")
    for ax, (name, res) in zip(axes[:, 0], results.items(), strict=True):
        draw_lanes(ax, sc)
        if react_window is not None:
            ax.axvspan(*react_window, color="orange", alpha=0.12, label="reaction window")
        its = select_iterations(res)
        for k, it in enumerate(its):
            C = res.history[it - 1]["control_points"][0]
            _, xy = _fine(C, demo.t, 0)
            ax.plot(
                xy[:, 0],
                xy[:, 1],
                color=cmap(k / max(len(its) - 1, 1)),
                lw=1.3,
                label=f"iteration {it}" + (" (last)" if it == len(res.history) else ""),
            )
        _, xy = _fine(demo_C, demo.t, 0)
        ax.plot(xy[:, 0], xy[:, 1], "r--", lw=2, label="demonstration")
        err = res.errors[0]
        ax.set_title(
            f"{name} features ({len(res.names)}): rmse_y = {err['rmse_y_m']:.3f} m"
            + (
                f", reaction window {err['rmse_y_reaction_m']:.3f} m"
                if err["rmse_y_reaction_m"] is not None
                else ""
            ),
            fontsize=10,
        )
        ax.set_ylabel("y [m]")
        ax.set_ylim(0, sc.road_width)
        ax.legend(fontsize=7, ncol=3, loc="upper left")
    axes[-1, 0].set_xlabel("x [m]")
    return save_figure(fig, path)


def plot_lateral(
    demo: Demonstration,
    result: LearningResult,
    demo_C: np.ndarray,
    path: str | Path,
    title: str = "",
) -> Path:
    """Lateral velocity and acceleration at iterations 1, 11, 21 and the last (Fig. 4).

    The demonstration's are overlaid.

    Args:
        demo: the demonstration.
        result: learning result with history.
        demo_C: the demonstration's control points.
        path: output PNG.
        title: figure title.

    Returns:
        The path written.
    """
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    cmap = plt.get_cmap("viridis")
    its = select_iterations(result)
    for k, it in enumerate(its):
        C = result.history[it - 1]["control_points"][0]
        c = cmap(k / max(len(its) - 1, 1))
        tt, v = _fine(C, demo.t, 1)
        _, a = _fine(C, demo.t, 2)
        a1.plot(tt, v[:, 1], color=c, label=f"iteration {it}")
        a2.plot(tt, a[:, 1], color=c)
    tt, v = _fine(demo_C, demo.t, 1)
    _, a = _fine(demo_C, demo.t, 2)
    a1.plot(tt, v[:, 1], "r--", lw=2, label="demonstration")
    a2.plot(tt, a[:, 1], "r--", lw=2)
    a1.set_ylabel("lateral velocity [m/s]")
    a2.set_ylabel("lateral acceleration [m/s²]")
    a2.set_xlabel("t [s]")
    a1.legend(fontsize=8, ncol=3)
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
    return save_figure(fig, path, title)


def plot_theta_vs_risk(libraries: dict, path: str | Path) -> Path:
    """Normalised θ (per feature group) against the risk p, one panel per library."""
    fig, axes = plt.subplots(1, len(libraries), figsize=(6 * len(libraries), 4), squeeze=False)
    for ax, (name, lib) in zip(axes[0], libraries.items(), strict=True):
        from irl.learner import normalise_theta

        th = np.array([normalise_theta(np.asarray(t), lib.features.names) for t in lib.thetas])
        for j, n in enumerate(lib.features.names):
            ax.plot(lib.risks, th[:, j], "o-", label=n)
        ax.set_xlabel("SMPC risk p")
        ax.set_ylabel("θ / Σθ of its group")
        ax.set_title(f"{name} features")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
    return save_figure(fig, path, dpi=120)


def plot_confusion(
    records: list[dict], grid: Sequence[float], scorer: str, path: str | Path, title: str = ""
) -> Path:
    """Confusion matrix of true vs estimated grid risk."""
    grid = list(grid)
    M = np.zeros((len(grid), len(grid)))
    for r in records:
        if r["grid"] and "error" not in r:
            M[grid.index(r["risk"]), grid.index(r[f"{scorer}_estimate"])] += 1
    fig, ax = plt.subplots(figsize=(5, 4.2))
    im = ax.imshow(M, cmap="Blues")
    for i in range(len(grid)):
        for j in range(len(grid)):
            if M[i, j]:
                ax.text(
                    j,
                    i,
                    int(M[i, j]),
                    ha="center",
                    va="center",
                    color="white" if M[i, j] > M.max() / 2 else "black",
                )
    ax.set_xticks(range(len(grid)), [f"{p:g}" for p in grid])
    ax.set_yticks(range(len(grid)), [f"{p:g}" for p in grid])
    ax.set_xlabel("estimated p")
    ax.set_ylabel("true p")
    fig.colorbar(im, ax=ax, shrink=0.8)
    return save_figure(fig, path, title, dpi=120)


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
    a1.plot(demo.ev[:, 0], demo.ev[:, 1], "k-", lw=2.2, label="recorded")
    a2.plot(demo.t, np.gradient(demo.ev[:, 1], demo.t), "k-", lw=2.2, label="recorded")
    if np.abs(demo.tv[:, 0] - demo.ev[:, 0]).min() < 500:
        a1.plot(demo.tv[:, 0], demo.tv[:, 1], color="0.6", lw=1, label="target vehicle")
    for name, xy in paths.items():
        a1.plot(xy[:, 0], xy[:, 1], lw=1.4, label=name)
        a2.plot(demo.t, np.gradient(xy[:, 1], demo.t), lw=1.4, label=name)
    draw_lanes(a1, demo.scenario)
    a1.set_ylim(-0.5, 2.5 * demo.scenario.lane_width)
    a1.set_xlabel("x [m]")
    a1.set_ylabel("y [m] (lane change to +y)")
    a2.set_xlabel("t [s]")
    a2.set_ylabel("lateral speed [m/s]")
    a1.legend(fontsize=7, ncol=3)
    a2.grid(alpha=0.3)
    return save_figure(fig, path, title, dpi=110)


def plot_noise_curve(curve: list[dict], path: str | Path, title: str = "") -> Path:
    """Identification accuracy and interval coverage against position noise σ.

    Args:
        curve: per σ, ``noise_sigma_m``, ``grid_accuracy_informative``,
            ``interval_coverage`` (fractions).
        path: output PNG.
        title: figure title.
    """
    sig = [c["noise_sigma_m"] for c in curve]
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    ax.plot(sig, [c["grid_accuracy_informative"] for c in curve], "o-", label="grid accuracy")
    ax.plot(sig, [c["interval_coverage"] for c in curve], "s--", label="90 % interval coverage")
    ax.set_xlabel("position noise σ [m]")
    ax.set_ylabel("fraction of demonstrations")
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    ax.legend()
    return save_figure(fig, path, title, dpi=120)


def plot_population(rows: Sequence[dict], path: str | Path, title: str = "") -> Path:
    """Estimated against true risk (where known, with 90 % intervals) and the distribution.

    Args:
        rows: ``styles.csv`` rows (:mod:`irl.mining`).
        path: output PNG.
        title: figure title.
    """

    def num(v) -> float:
        try:
            return float(v)
        except (TypeError, ValueError):
            return float("nan")

    ok = [r for r in rows if r["status"] == "ok"]
    est = np.array([num(r["risk_mean"]) for r in ok])
    true = np.array([num(r["true_risk"]) for r in ok])
    lo = np.array([num(r["risk_lo"]) for r in ok])
    hi = np.array([num(r["risk_hi"]) for r in ok])
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    known = np.isfinite(true)
    if known.any():
        ax1.errorbar(
            true[known],
            est[known],
            # the posterior mean may lie outside the 90 % set's span when the mass is split
            yerr=[
                np.maximum(est[known] - lo[known], 0.0),
                np.maximum(hi[known] - est[known], 0.0),
            ],
            fmt="o",
            ms=3,
            alpha=0.5,
            elinewidth=0.6,
        )
        ax1.plot([0.5, 0.95], [0.5, 0.95], "k--", lw=0.8)
        ax1.set_xlabel("true risk p")
        ax1.set_ylabel("posterior mean (bars: 90 % interval)")
    else:
        ax1.text(0.5, 0.5, "no true risks (recorded data)", ha="center", transform=ax1.transAxes)
    ax1.grid(alpha=0.3)
    ax2.hist(est[np.isfinite(est)], bins=np.linspace(0.45, 1.0, 23), color="C1", alpha=0.8)
    ax2.set_xlabel("estimated risk (posterior mean)")
    ax2.set_ylabel("vehicles")
    ax2.grid(alpha=0.3)
    return save_figure(fig, path, title, dpi=120)
