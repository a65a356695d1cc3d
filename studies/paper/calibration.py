"""Calibration of the TV prediction uncertainty against the paper's demonstration (DESIGN §3).

The paper gives no covariance for its TV prediction, yet the covariance decides whether the
risk p changes the behaviour at all. :func:`uncertainty_scan` runs the SMPC closed loop on
the paper scenario for every (scale, p) pair, the scale multiplying
:data:`drivestyle.planning.tv_gaussian.PAPER_TV_UNCERTAINTY`;
:func:`drivestyle.studies.paper.figures.plot_risk_sweep` draws the EV paths and s_e per risk.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.agents.smpc import SMPCConfig
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import PAPER
from drivestyle.planning.tv_gaussian import PAPER_TV_UNCERTAINTY

__all__ = ["PAPER_CALIBRATION", "SCAN_KEYS", "UncertaintyScan", "uncertainty_scan"]

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

PAPER_CALIBRATION = {"risk": 0.7, "t_trg_s": 3.0, "x_at_min_s_e_approx": 170.0}
"""What the paper's demonstration shows, the target of the calibration."""


@dataclass(frozen=True)
class UncertaintyScan:
    """SMPC demonstrations of the paper scenario per uncertainty scale and risk.

    Attributes:
        base_uncertainty: the calibrated uncertainty the scales multiply (JSON-ready).
        rows: per (scale, p) pair: ``scale``, ``risk``, the :data:`SCAN_KEYS` and
            ``final_y``, in scan order.
        demos: the scale-1 demonstrations by risk p (for the figure; not in the JSON).
    """

    base_uncertainty: dict[str, Any]
    rows: list[dict[str, Any]]
    demos: dict[float, Demonstration]

    def to_json(self) -> dict[str, Any]:
        """``calibration.json``'s study keys: ``base_uncertainty``, ``rows``, ``paper``."""
        return {
            "base_uncertainty": self.base_uncertainty,
            "rows": self.rows,
            "paper": PAPER_CALIBRATION,
        }


def uncertainty_scan(
    scales: Sequence[float],
    risks: Sequence[float],
    seed: int = 0,
    progress: Callable[[], None] | None = None,
) -> UncertaintyScan:
    """SMPC demonstrations of the paper scenario for every uncertainty scale and risk.

    Args:
        scales: factors on :data:`PAPER_TV_UNCERTAINTY` (1 = the calibrated default).
        risks: risk levels p in (0, 1).
        seed: env seed.
        progress: called after each closed loop.

    Returns:
        The scan (rows per pair and the scale-1 demonstrations by p).
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
    return UncertaintyScan(asdict(PAPER_TV_UNCERTAINTY), rows, demos)
