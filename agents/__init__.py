"""drivestyle agents: the drivers.

The stochastic MPC expert's closed-loop shell (``smpc``; its NLP is
:mod:`drivestyle.planning`'s), its demonstrations (``demo_generation``), the style-aware
ego (``aware_planner``), SB3 policies on a learned reward (``sb3_baseline``) and other
drivers simulated by highway-env (IDM + MOBIL classes) and recorded as tracks
(``highway_drivers``). The planning names re-exported here (``SMPCProblem``,
``chance_margin``, …) live in :mod:`drivestyle.planning`.
"""

from drivestyle.agents.demo_generation import demo_summary, generate_demonstration, rollout_expert
from drivestyle.agents.smpc import (
    InfeasibleStartError,
    SMPCConfig,
    SMPCDecision,
    SMPCExpert,
    SolveReport,
)
from drivestyle.planning.chance import chance_margin, risk_quantile
from drivestyle.planning.smpc_problem import SMPCProblem
from drivestyle.planning.tv_gaussian import (
    PAPER_TV_UNCERTAINTY,
    TVUncertainty,
    tv_covariance,
    tv_mean_prediction,
)

__all__ = [
    "PAPER_TV_UNCERTAINTY",
    "InfeasibleStartError",
    "SMPCConfig",
    "SMPCDecision",
    "SMPCExpert",
    "SMPCProblem",
    "SolveReport",
    "TVUncertainty",
    "chance_margin",
    "demo_summary",
    "generate_demonstration",
    "risk_quantile",
    "rollout_expert",
    "tv_covariance",
    "tv_mean_prediction",
]
