"""Calibration of the TV prediction uncertainty against the paper's demonstration (DESIGN §3).

The paper gives no covariance for its TV prediction, yet the covariance decides whether the
risk p changes the behaviour at all. :func:`uncertainty_scan` runs the SMPC closed loop on
the paper scenario for every (scale, p) pair, the scale multiplying
:data:`drivestyle.agents.prediction.PAPER_TV_UNCERTAINTY`, and :func:`plot_risk_sweep` draws the EV
paths and s_e per risk.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.agents.prediction import PAPER_TV_UNCERTAINTY
from drivestyle.agents.smpc import SMPCConfig
from drivestyle.agents.studies.figures import draw_lanes, plt, save_figure
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index
from drivestyle.envs.scenario import PAPER

__all__ = ["SCAN_KEYS", "plot_risk_sweep", "uncertainty_scan"]

SCAN_KEYS = (
    "t_trg_s",
    "min_s_e",
    "x_at_min_s_e",
    "min_d_k",
    "t_enter_target_lane_s",
    "final_lane",
    "collision",
    "n_solver_failures",
)
"""Demonstration summary keys kept per (scale, p) row."""


def uncertainty_scan(
    scales: Sequence[float],
    risks: Sequence[float],
    seed: int = 0,
    progress: Callable[[], None] | None = None,
) -> tuple[dict[str, Any], dict[float, Demonstration]]:
    """SMPC demonstrations of the paper scenario for every uncertainty scale and risk.

    Args:
        scales: factors on :data:`PAPER_TV_UNCERTAINTY` (1 = the calibrated default).
        risks: risk levels p in (0, 1).
        seed: env seed.
        progress: called after each closed loop.

    Returns:
        The payload (``base_uncertainty``, ``rows`` with :data:`SCAN_KEYS` and ``final_y``
        per pair, the paper's reference values) and the scale-1 demonstrations by p.
    """
    rows, demos = [], {}
    for s in scales:
        for p in risks:
            cfg = SMPCConfig(risk=p, uncertainty=PAPER_TV_UNCERTAINTY.scaled(s))
            demo, summary = generate_demonstration(p, PAPER, cfg, seed=seed)
            rows.append(
                {
                    "scale": s,
                    "risk": p,
                    **{k: summary[k] for k in SCAN_KEYS},
                    "final_y": float(demo.ev[-1, 1]),
                }
            )
            if s == 1.0:
                demos[p] = demo
            if progress is not None:
                progress()
    payload = {
        "base_uncertainty": asdict(PAPER_TV_UNCERTAINTY),
        "rows": rows,
        "paper": {"risk": 0.7, "t_trg_s": 3.0, "x_at_min_s_e_approx": 170.0},
    }
    return payload, demos


def plot_risk_sweep(demos: dict[float, Demonstration], path: str | Path) -> Path:
    """s_e and the EV path against x for each risk's demonstration of the paper scenario."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    cmap = plt.get_cmap("viridis")
    for i, (p, demo) in enumerate(sorted(demos.items())):
        c = cmap(i / max(len(demos) - 1, 1))
        s_e = elliptical_index(
            demo.ev[:, 0] - demo.tv[:, 0], demo.ev[:, 1] - demo.tv[:, 1], PAPER.l_a, PAPER.l_b
        )
        ax1.plot(demo.ev[:, 0], s_e, color=c, label=f"p = {p:g}")
        ax2.plot(demo.ev[:, 0], demo.ev[:, 1], color=c)
    ax1.axhline(PAPER.trigger_lambda, color="k", ls="--", lw=0.8, label="$\\lambda$")
    ax1.set_ylabel("$s_e$")
    ax1.set_ylim(0, 6)
    ax1.legend(fontsize=8, ncol=4)
    draw_lanes(ax2, PAPER)
    ax2.set_xlabel("EV x [m]")
    ax2.set_ylabel("EV y [m]")
    return save_figure(fig, path, "SMPC demonstrations on the paper scenario by risk p", dpi=120)
