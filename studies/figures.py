"""The figures the studies draw, and the colours, lanes and saving they share.

With the prediction study's own (:mod:`drivestyle.studies.prediction.figures`), the only
modules that import matplotlib.

Demonstrations (the paper's Fig. 2), learning (Figs. 3 and 4), the comparisons of the
learned style's drivers, the uncertainty calibration, the RL learning curve, identification
and mining, recorded episodes. Every function takes data and a path and returns the path.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Ellipse, Polygon
from matplotlib.ticker import MaxNLocator

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index, trigger_time, vehicle_corners
from drivestyle.irl.paper.learner import LearningResult
from drivestyle.irl.paper.spline import spline_eval
from drivestyle.studies.reports import seconds

if TYPE_CHECKING:
    from drivestyle.irl.driver.driver_style import Reproduction
    from drivestyle.irl.identification.posterior import Identification
    from drivestyle.studies.av_vs_human import AVHumanComparison
    from drivestyle.studies.compare import HeldoutComparison
    from drivestyle.studies.cut_in_study import PlanningStudy
    from drivestyle.studies.identification_study import EvaluationRecord
    from drivestyle.studies.real_traffic import DriverTrafficStudy, RealTrafficStudy

__all__ = [
    "draw_lanes",
    "first_segment_note",
    "plot_comparison",
    "plot_confusion",
    "plot_demonstration",
    "plot_driver_traffic",
    "plot_episode",
    "plot_heldout",
    "plot_identification",
    "plot_lateral",
    "plot_learning_curve",
    "plot_noise_curve",
    "plot_planning",
    "plot_population",
    "plot_reproductions",
    "plot_risk_sweep",
    "plot_theta_vs_risk",
    "save_figure",
    "select_iterations",
]

EV_RED = "#d62828"
TV_BLUE = "#1d4ed8"
SCALED_ORANGE = "#f59e0b"


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
            C = res.history[it - 1].control_points[0]
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

    The demonstration's are overlaid. When the demonstration's largest lateral
    acceleration lies in its first segment, the figure says why (see
    :func:`first_segment_note`).

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
        C = result.history[it - 1].control_points[0]
        c = cmap(k / max(len(its) - 1, 1))
        tt, v = _fine(C, demo.t, 1)
        _, a = _fine(C, demo.t, 2)
        a1.plot(tt, v[:, 1], color=c, label=f"iteration {it}")
        a2.plot(tt, a[:, 1], color=c)
    tt, v = _fine(demo_C, demo.t, 1)
    _, a = _fine(demo_C, demo.t, 2)
    a1.plot(tt, v[:, 1], "r--", lw=2, label="demonstration")
    a2.plot(tt, a[:, 1], "r--", lw=2)
    note = first_segment_note(demo, demo_C)
    if note is not None:
        i = int(np.argmax(np.abs(a[:, 1])))
        a2.annotate(
            note,
            (tt[i], a[i, 1]),
            xytext=(0.12, 0.93),
            textcoords="axes fraction",
            va="top",
            fontsize=7.5,
            arrowprops={"arrowstyle": "->", "lw": 0.8},
            bbox={"boxstyle": "round", "fc": "white", "ec": "0.6"},
        )
    a1.set_ylabel("lateral velocity [m/s]")
    a2.set_ylabel("lateral acceleration [m/s²]")
    a2.set_xlabel("t [s]")
    a1.legend(fontsize=8, ncol=3)
    for ax in (a1, a2):
        ax.grid(alpha=0.3)
    return save_figure(fig, path, title)


def first_segment_note(demo: Demonstration, demo_C: np.ndarray) -> str | None:
    """Why the demonstration's lateral acceleration peaks in its first segment, or None.

    The SMPC steers to its heading bound within its first step, so the EV's lateral
    velocity jumps across segment 0 (v·φ̇ of the bicycle model) and the quintic segment
    interpolating that jump between the knots' accelerations overshoots it. This is the
    demonstration as the learner sees it, not a plotting artefact (DESIGN §4).

    Args:
        demo: the demonstration.
        demo_C: its control points.

    Returns:
        The note (peak value, its time, the first step's heading change and v·φ̇), or None
        when segment 0 holds no spike (a peak over twice the largest |a_y| after it).
    """
    tt, a = _fine(demo_C, demo.t, 2)
    i = int(np.argmax(np.abs(a[:, 1])))
    dt = float(demo.t[1] - demo.t[0])
    later = np.abs(a[tt >= demo.t[1], 1]).max()
    if tt[i] >= demo.t[1] or abs(a[i, 1]) <= 2.0 * later:  # no spike in segment 0
        return None
    dphi = float(demo.ev[1, 2] - demo.ev[0, 2])
    v_phidot = float(demo.ev[0, 3]) * dphi / dt
    return (
        f"{a[i, 1]:.1f} m/s² at t = {tt[i]:.2f} s: in its first step (0–{dt:g} s) the SMPC\n"
        f"turns to its heading bound (Δφ = {dphi:.3f} rad, v·φ̇ ≈ {v_phidot:.1f} m/s²);\n"
        "the spline's segment 0 interpolating that jump overshoots it (DESIGN §4)"
    )


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


def plot_confusion(
    records: Sequence[EvaluationRecord],
    grid: Sequence[float],
    scorer: str,
    path: str | Path,
    title: str = "",
) -> Path:
    """Confusion matrix of true vs estimated grid risk."""
    grid = list(grid)
    M = np.zeros((len(grid), len(grid)))
    for r in records:
        if r.grid and r.ok:
            M[grid.index(r.risk), grid.index(r.estimate(scorer))] += 1
    fig, ax = plt.subplots(figsize=(5, 4.2))
    im = ax.imshow(M, cmap="Blues")
    for i in range(len(grid)):
        for j in range(len(grid)):
            if M[i, j]:
                ax.text(
                    j,
                    i,
                    str(int(M[i, j])),
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


def plot_risk_sweep(demos: dict[float, Demonstration], path: str | Path) -> Path:
    """s_e and the EV path against x for each risk's demonstration (``risk_sweep.png``).

    Args:
        demos: risk p → SMPC demonstration of one scenario (all the same scenario).
        path: output PNG.

    Returns:
        The path written.
    """
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    cmap = plt.get_cmap("viridis")
    sc = next(iter(demos.values())).scenario
    for i, (p, demo) in enumerate(sorted(demos.items())):
        c = cmap(i / max(len(demos) - 1, 1))
        s_e = elliptical_index(
            demo.ev[:, 0] - demo.tv[:, 0], demo.ev[:, 1] - demo.tv[:, 1], sc.l_a, sc.l_b
        )
        ax1.plot(demo.ev[:, 0], s_e, color=c, label=f"p = {p:g}")
        ax2.plot(demo.ev[:, 0], demo.ev[:, 1], color=c)
    ax1.axhline(sc.trigger_lambda, color="k", ls="--", lw=0.8, label="$\\lambda$")
    ax1.set_ylabel("$s_e$")
    ax1.set_ylim(0, 6)
    ax1.legend(fontsize=8, ncol=4)
    draw_lanes(ax2, sc)
    ax2.set_xlabel("EV x [m]")
    ax2.set_ylabel("EV y [m]")
    return save_figure(fig, path, "SMPC demonstrations on the paper scenario by risk p", dpi=120)


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


NEAR_VEHICLE_M = 300.0
"""Other vehicles farther than this from the EV throughout are not drawn (a placeholder TV
1 km away would squash the road to a line)."""


def plot_identification(
    ident: Identification,
    demos: Sequence[Demonstration],
    reproductions: Sequence[Reproduction | None],
    path: str | Path,
    title: str = "",
) -> Path:
    """The risk posterior with its prior and 90 % interval, and the style's reproduction.

    Left: the posterior density over p [1/unit p] (driver libraries: the continuous
    posterior on its grid; paper-model libraries: the mass per library risk as bars), the
    uniform prior and the 90 % interval, with the verdict (KL, interval width, residual
    RMS in noise floors). Right, one panel per demonstration: the recorded path (x–y), the
    style's closed-loop reproduction at the identified risk, and the other vehicles that
    come within :data:`NEAR_VEHICLE_M` of the EV.

    Args:
        ident: the identification (:func:`~drivestyle.irl.identification.posterior.identify`).
        demos: its demonstrations.
        reproductions: per demonstration the reproduction at the identified risk (None:
            not drawn, e.g. a paper-model library).
        path: output PNG.
        title: figure title.

    Returns:
        The path written.
    """
    n = len(demos)
    fig, axes = plt.subplots(1, 1 + n, figsize=(4.2 + 5.0 * n, 3.8), squeeze=False,
                             gridspec_kw={"width_ratios": [1.0] + [1.4] * n})  # fmt: skip
    ax = axes[0][0]
    lo, hi = ident.risk_interval
    if ident.density:
        grid = np.asarray(ident.density_risks)
        step = float(np.median(np.diff(grid))) if grid.size > 1 else 1.0
        dens = np.asarray(ident.density) / step
        ax.plot(grid, dens, "-", color=EV_RED, lw=1.8, label="posterior")
        ax.plot(grid, np.full(grid.size, 1.0 / (step * grid.size)), "--", color="0.4",
                lw=1.2, label="prior (uniform)")  # fmt: skip
        inside = (grid >= lo - 1e-9) & (grid <= hi + 1e-9)
        ax.fill_between(grid, 0, dens, where=inside, color=EV_RED, alpha=0.2,
                        label="90 % interval")  # fmt: skip
        ax.set_ylabel("density [1/unit p]")
    else:
        risks = np.asarray(ident.risks)
        width = 0.8 * float(np.min(np.diff(risks))) if risks.size > 1 else 0.05
        ax.bar(risks, ident.posterior, width=width, color=EV_RED, alpha=0.6, label="posterior")
        ax.axhline(1.0 / risks.size, color="0.4", ls="--", lw=1.2, label="prior (uniform)")
        ax.axvspan(lo, hi, color=EV_RED, alpha=0.1, label="90 % interval")
        ax.set_ylabel("posterior mass")
    ax.axvline(ident.risk_interpolated, color="k", lw=1.0, label="posterior mean")
    for p in {q for q in ident.true_risks if q is not None}:
        ax.axvline(p, color=TV_BLUE, ls=":", lw=1.4, label="true risk")
    v = ident.verdict
    if v is not None:
        floors = "" if v.floors is None else f", residual {v.floors:.1f} floors"
        ax.set_title(f"{v.phrase}\nKL {v.kl_nats:.2f} nats, interval "
                     f"{v.width_ratio:.0%} of prior{floors}", fontsize=8)  # fmt: skip
    ax.set_xlabel("risk p")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    for ax, demo, rep in zip(axes[0][1:], demos, reproductions, strict=True):
        ax.plot(demo.ev[:, 0], demo.ev[:, 1], "k-", lw=2.2, label="recorded", zorder=3)
        if rep is not None:
            ax.plot(rep.states[:, 0], rep.states[:, 1], "--", color=EV_RED, lw=1.6, zorder=4,
                    label=f"style at p = {ident.risk_interpolated:.2f}")  # fmt: skip
        vehicles = demo.vehicles
        far = 0
        for j in range(vehicles.shape[1]):
            dist = np.hypot(vehicles[:, j, 0] - demo.ev[:, 0], vehicles[:, j, 1] - demo.ev[:, 1])
            if dist.min() > NEAR_VEHICLE_M:
                far += 1
                continue
            label = ("target vehicle", "other vehicles")[j] if j < 2 else None
            color = "0.6" if j else TV_BLUE
            ax.plot(vehicles[:, j, 0], vehicles[:, j, 1], "-", lw=1.4, color=color, label=label)
        draw_lanes(ax, demo.scenario)
        ax.set_ylim(-0.5, demo.scenario.n_lanes * demo.scenario.lane_width + 0.5)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        note = f" ({far} more > {NEAR_VEHICLE_M:.0f} m away)" if far else ""
        ax.set_title(f"{demo.meta.get('name', 'demonstration')}{note}", fontsize=8)
        ax.legend(fontsize=7, loc="best")
    return save_figure(fig, path, title or "Identification: posterior and reproduction", dpi=110)


def plot_av_human(comparison: AVHumanComparison, path: str | Path) -> Path:
    """Each quantity's lane changes per group (dots), medians and 95 % intervals (bars)."""
    from drivestyle.studies.av_vs_human import GROUPS, QUANTITIES

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
