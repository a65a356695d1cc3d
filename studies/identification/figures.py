"""The identification study's figures, and the figure of one identification.

The confusion matrix and the noise curve of the held-out evaluation
(``evaluate-identification``), and its amortized posterior beside the exact
(``--posterior``); the posterior with the style's reproduction of one
identification (``identify-style --plot``). The population's and θ-against-risk figures
are shared (:mod:`drivestyle.studies.plotting`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.studies.plotting import EV_RED, TV_BLUE, draw_lanes, save_figure

if TYPE_CHECKING:
    from drivestyle.irl.driver.driver_style import Reproduction
    from drivestyle.irl.identification.result import Identification
    from drivestyle.studies.identification.amortized_results import BesideExact
    from drivestyle.studies.identification.study import EvaluationRecord

__all__ = [
    "NEAR_VEHICLE_M",
    "plot_beside_exact",
    "plot_confusion",
    "plot_identification",
    "plot_noise_curve",
]


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


def plot_beside_exact(beside: BesideExact, path: str | Path, title: str = "") -> Path:
    """True p against the exact and the amortized posterior means with their 90 % intervals.

    One panel per noise level; the two posteriors' points of one demonstration sit either
    side of its true p (shifted by 0.006) so that their bars do not hide each other; the
    demonstrations the exact refused are left out.

    Args:
        beside: the study (:func:`~drivestyle.studies.identification.amortized.
            evaluate_beside_exact`).
        path: output PNG.
        title: figure title.

    Returns:
        The path written.
    """
    n = len(beside.records)
    fig, axes = plt.subplots(1, n, figsize=(4.6 * n, 4.2), squeeze=False, sharey=True)
    for ax, records, summary in zip(axes[0], beside.records, beside.summaries, strict=True):
        pairs = [(r, r.exact) for r in records if r.exact is not None]
        true = np.array([r.risk for r, _ in pairs])
        for label, color, shift, mean, lo, hi in (
            ("exact", EV_RED, -0.006, [e.mean for _, e in pairs],
             [e.interval[0] for _, e in pairs], [e.interval[1] for _, e in pairs]),
            ("amortized", TV_BLUE, 0.006, [r.mean[0] for r, _ in pairs],
             [r.lo[0] for r, _ in pairs], [r.hi[0] for r, _ in pairs]),
        ):  # fmt: skip
            m = np.asarray(mean, float)
            # a mean may lie outside its central interval when the mass is split
            bars = [np.maximum(m - np.asarray(lo), 0.0), np.maximum(np.asarray(hi) - m, 0.0)]
            ax.errorbar(true + shift, m, yerr=bars, fmt="o", ms=3, alpha=0.6, elinewidth=0.6,
                        color=color, label=f"{label} mean, 90 % interval")  # fmt: skip
        ax.plot([0.5, 0.99], [0.5, 0.99], "k--", lw=0.8)
        ax.set_xlabel("true risk p")
        ax.set_title(f"σ = {summary.noise_sigma_m:g} m ({len(pairs)} demonstrations)", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("posterior mean of p")
    axes[0][0].legend(fontsize=7, loc="upper left")
    return save_figure(fig, path, title or "Amortized posterior beside the exact", dpi=110)


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
