"""Figures of demonstrations (the paper's Fig. 2)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Ellipse, Polygon

from envs.demonstration import Demonstration
from envs.safety import elliptical_index, trigger_time, vehicle_corners

__all__ = ["draw_lanes", "plot_demonstration", "save_figure"]

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
    ev, tv, others = demo.ev, demo.tv, demo.others
    veh = demo.vehicles  # traffic: the least s_e over every vehicle
    s_e = elliptical_index(
        ev[:, None, 0] - veh[:, :, 0], ev[:, None, 1] - veh[:, :, 1], sc.l_a, sc.l_b
    ).min(axis=1)
    t_trg = trigger_time(demo.t, s_e, sc.trigger_lambda)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 6.5), height_ratios=(1, 1.3))

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
            label=f"$t_{{trg}}$ = {t_trg:.1f} s (x = {ev[i, 0]:.0f} m)",
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

    x_lo = min(ev[:, 0].min(), tv[:, 0].min()) - sc.l_a * 1.5
    x_hi = max(ev[:, 0].max(), tv[:, 0].max()) + sc.l_a * 1.5
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
    ax2.set_ylim(-0.5, sc.road_width + 0.5)
    ax2.set_xlabel("x [m]")
    ax2.set_ylabel("y [m]")
    ax2.legend(loc="upper left", fontsize=8, ncol=4)
    ax1.set_xlim(x_lo, x_hi)
    return save_figure(fig, path, title)
