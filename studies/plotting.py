"""What the studies' figures share (the one module that selects matplotlib's backend).

The colours of the ego (EV) and target (TV) vehicles, lanes drawn as lines, saving a
figure; and the figures drawn by several studies or by commands that are not a study: a
demonstration (the paper's Fig. 2; ``generate-demo``, the paper study), the learned θ
against the risk (``build-style-library``, the identification study), a population's
identified risks (``mine-styles``, the identification study) and an RL learning curve
(``train-baseline``). Each study draws its own figures in its ``figures.py``. Every
function takes data and a path and returns the path.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Ellipse, Polygon
from matplotlib.ticker import MaxNLocator

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index, trigger_time, vehicle_corners
from drivestyle.studies.formatting import seconds

__all__ = [
    "EV_RED",
    "SCALED_ORANGE",
    "TV_BLUE",
    "draw_lanes",
    "plot_demonstration",
    "plot_learning_curve",
    "plot_population",
    "plot_theta_vs_risk",
    "save_figure",
]

EV_RED = "#d62828"
"""The ego vehicle's (and the identified style's) colour."""
TV_BLUE = "#1d4ed8"
"""The target vehicle's (and the truth's) colour."""
SCALED_ORANGE = "#f59e0b"
"""The scaled ellipse's (λ) colour."""


def draw_lanes(ax: plt.Axes, sc) -> None:
    """Road edges (solid) and lane lines (dashed) of a scenario as horizontal lines."""
    for i in range(sc.n_lanes + 1):
        edge = i in (0, sc.n_lanes)
        ax.axhline(
            i * sc.lane_width,
            color="0.3" if edge else "0.6",
            lw=1.4 if edge else 0.8,
            ls="-" if edge else "--",
            zorder=0,
        )


def save_figure(
    fig: plt.Figure, path: str | Path, title: str | None = None, dpi: int = 130
) -> Path:
    """Title, tighten, write (creating folders) and close a figure; returns the path."""
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def plot_demonstration(
    demo: Demonstration,
    path: str | Path,
    samples: tuple[int, ...] = (1, 16, 31),
    title: str | None = None,
) -> Path:
    """Draw the equivalent of the paper's Fig. 2 and save it.

    Top: elliptical index s_e along the EV's x with the threshold λ and t_trg. Bottom:
    EV and TV paths, vehicle rectangles, the safety ellipse (l_a, l_b) and the scaled
    ellipse (√λ·l_a, √λ·l_b) around the TV at the given (1-based) samples.

    Args:
        demo: the demonstration (with ``meta["scenario"]``).
        path: output image (PNG).
        samples: 1-based sample numbers at which ellipses are drawn (clipped to n).
        title: figure title.

    Returns:
        The path written.
    """
    sc = demo.scenario
    ev, tv, others = demo.ev, demo.tv, demo.other_vehicles
    veh = demo.vehicles  # traffic: the least s_e over every vehicle
    s_e = elliptical_index(
        ev[:, None, 0] - veh[:, :, 0], ev[:, None, 1] - veh[:, :, 1], sc.l_a, sc.l_b
    ).min(axis=1)
    t_trg = trigger_time(demo.t, s_e, sc.trigger_lambda)
    x_lo = min(ev[:, 0].min(), tv[:, 0].min()) - sc.l_a * 1.5
    x_hi = max(ev[:, 0].max(), tv[:, 0].max()) + sc.l_a * 1.5
    y_lo, y_hi = -0.5, sc.road_width + 0.5
    # the road panel is drawn to scale (equal axes: cars and ellipses keep their true
    # shape), so its height follows from the road's width over the x span
    width = 11.0
    road_h = max(width * 0.9 * (y_hi - y_lo) / (x_hi - x_lo), 0.6)
    fig, (ax1, ax2) = plt.subplots(
        2, 1, figsize=(width, 2.8 + road_h + 1.4), height_ratios=(2.8, road_h + 0.6)
    )

    ax1.plot(ev[:, 0], s_e, "-o", color=EV_RED, ms=3, label="$s_e$")
    ax1.axhline(
        sc.trigger_lambda, color=SCALED_ORANGE, ls="--", label=f"$\\lambda$ = {sc.trigger_lambda:g}"
    )
    ax1.axhline(1.0, color=TV_BLUE, ls=":", label="safety ellipse ($s_e$ = 1)")
    if t_trg is not None:
        i = int(np.argmin(np.abs(demo.t - t_trg)))
        ax1.plot(
            ev[i, 0],
            s_e[i],
            "k*",
            ms=12,
            label=f"$t_{{trg}}$ = {seconds(t_trg)} (x = {ev[i, 0]:.0f} m)",
        )
    else:
        ax1.text(
            0.5,
            0.9,
            "trigger never fires: reactive features inactive",
            transform=ax1.transAxes,
            ha="center",
            color="k",
        )
    ax1.set_ylabel("elliptical index $s_e$")
    ax1.set_ylim(0, min(float(s_e.max()) * 1.05, 8))
    ax1.legend(loc="upper right", fontsize=8)
    ax1.grid(alpha=0.3)

    for j in range(others.shape[1]):
        ax2.plot(
            others[:, j, 0],
            others[:, j, 1],
            "-",
            color="0.5",
            lw=1.0,
            label="other vehicles" if j == 0 else None,
        )
    draw_lanes(ax2, sc)
    ax2.plot(ev[:, 0], ev[:, 1], "-", color=EV_RED, lw=1.5, label="EV")
    ax2.plot(tv[:, 0], tv[:, 1], "-", color=TV_BLUE, lw=1.5, label="TV")
    r = np.sqrt(sc.trigger_lambda)
    for j, s in enumerate(sorted({min(max(s, 1), demo.n) for s in samples})):
        i = s - 1
        ax2.add_patch(
            Ellipse(
                (tv[i, 0], tv[i, 1]),
                2 * sc.l_a,
                2 * sc.l_b,
                fill=False,
                ec=TV_BLUE,
                lw=1.2,
                label="safety ellipse" if j == 0 else None,
            )
        )
        ax2.add_patch(
            Ellipse(
                (tv[i, 0], tv[i, 1]),
                2 * r * sc.l_a,
                2 * r * sc.l_b,
                fill=False,
                ec=SCALED_ORANGE,
                ls="--",
                lw=1.2,
                label="scaled ellipse ($\\lambda$)" if j == 0 else None,
            )
        )
        for state, color in ((ev[i], EV_RED), (tv[i], TV_BLUE), *((o, "0.5") for o in others[i])):
            corners = vehicle_corners(state, sc.vehicle_length, sc.vehicle_width)
            ax2.add_patch(Polygon(corners, closed=True, fc=color, ec="k", lw=0.5, alpha=0.8))
        ax2.annotate(f"k={s}", (ev[i, 0], ev[i, 1] - 1.6), ha="center", fontsize=8)
    ax2.set_xlim(x_lo, x_hi)
    ax2.set_ylim(y_lo, y_hi)
    ax2.set_aspect("equal", adjustable="box")
    ax2.set_xlabel("x [m] (to scale)")
    ax2.set_ylabel("y [m]")
    ax2.legend(loc="upper center", bbox_to_anchor=(0.5, -0.45), fontsize=8, ncol=7, frameon=False)
    ax1.set_xlim(x_lo, x_hi)
    return save_figure(fig, path, title)


def plot_theta_vs_risk(libraries: dict, path: str | Path) -> Path:
    """Normalised θ (per feature group) against the risk p, one panel per library."""
    fig, axes = plt.subplots(1, len(libraries), figsize=(6 * len(libraries), 4), squeeze=False)
    for ax, (name, lib) in zip(axes[0], libraries.items(), strict=True):
        from drivestyle.irl.paper.learner import normalise_theta

        th = np.array([normalise_theta(np.asarray(t), lib.features.names) for t in lib.thetas])
        for j, n in enumerate(lib.features.names):
            ax.plot(lib.risks, th[:, j], "o-", label=n)
        ax.set_xlabel("SMPC risk p")
        ax.set_ylabel("θ / Σθ of its group")
        ax.set_title(f"{name} features")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
    return save_figure(fig, path, dpi=120)


def plot_population(rows: Sequence[dict], path: str | Path, title: str = "") -> Path:
    """Estimated against true risk (where known, with 90 % intervals) and the distribution.

    Args:
        rows: ``styles.csv`` rows (:mod:`drivestyle.irl.identification.mining`).
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
    ax2.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts: no fractional ticks
    ax2.set_xlabel("estimated risk (posterior mean)")
    ax2.set_ylabel("vehicles")
    ax2.grid(alpha=0.3)
    return save_figure(fig, path, title, dpi=120)


def plot_learning_curve(out: str | Path, title: str) -> Path:
    """Training episode returns (``monitor.csv``) and evaluation returns (``evaluations.npz``).

    Args:
        out: a :func:`drivestyle.agents.sb3_baseline.train_baseline` output folder; the
            figure is written there as ``learning_curve.png``.
        title: figure title.

    Returns:
        The figure's path.
    """
    out = Path(out)
    fig, ax = plt.subplots(figsize=(7, 4))
    monitor = out / "monitor.csv"
    if monitor.is_file():
        data = np.atleast_2d(np.genfromtxt(monitor, delimiter=",", skip_header=2, usecols=(0, 1)))
        if data.size:
            steps = np.cumsum(data[:, 1])
            ax.plot(steps, data[:, 0], ".", ms=2, alpha=0.4, label="training episodes")
            k = min(25, len(data))
            smooth = np.convolve(data[:, 0], np.ones(k) / k, mode="valid")
            ax.plot(steps[k - 1 :], smooth, lw=1.5, label=f"training, mean of {k}")
    evals = out / "evaluations.npz"
    if evals.is_file():
        with np.load(evals) as ev:
            ax.plot(ev["timesteps"], ev["results"].mean(axis=1), "o-", label="evaluation")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return (−learned cost)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend()
    return save_figure(fig, out / "learning_curve.png", dpi=120)
