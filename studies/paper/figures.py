"""The paper study's figures: Fig. 3 (reproduced paths), Fig. 4 (lateral motion), risk sweep.

Fig. 3 and Fig. 4 show a learning's iterations 1, 11, 21 and the last (as the paper's);
``learn-style`` draws them too. The risk sweep is the TV-uncertainty calibration's
(:mod:`~drivestyle.studies.paper.calibration`). Fig. 2 (a demonstration) is shared:
:func:`drivestyle.studies.plotting.plot_demonstration`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index
from drivestyle.irl.paper.learner import LearningResult
from drivestyle.irl.paper.spline import spline_eval
from drivestyle.studies.plotting import draw_lanes, save_figure

__all__ = [
    "PAPER_ITERATIONS",
    "first_segment_note",
    "plot_lateral",
    "plot_reproductions",
    "plot_risk_sweep",
    "select_iterations",
]

PAPER_ITERATIONS = (1, 11, 21)
"""The iterations the paper's Figs. 3 and 4 show."""


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
