"""An SMPC ego that predicts the vehicle cutting in by a pluggable model (DESIGN §17).

Today's SMPC predicts every other vehicle at constant velocity inside its NLP. Here the
ego of ``drivestyle/CutIn-v0`` (:mod:`drivestyle.envs.cut_in`) plans with the same cost,
chance constraint and covariance, but the other vehicle's *mean* path over the horizon
comes from an :class:`~drivestyle.prediction.online.OnlinePredictor` (the NLP built with
:attr:`~drivestyle.planning.description.SMPCConfig.predicted_paths`): constant velocity
(today's SMPC), the style identified online, or the vehicle's true style — the online
predictors of :mod:`drivestyle.prediction.online`.

The scenario is the cut-in env's, in the lane changer's frame (its EV is the cutter, its
TV the ego); :func:`ego_scenario` turns it into the ego's own (its lane, its speed).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from drivestyle.agents.smpc import SMPCConfig, SMPCExpert
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.prediction.online import OnlinePredictor

__all__ = [
    "EGO_RISK",
    "PREDICTORS",
    "AwareSMPC",
    "ego_scenario",
]

EGO_RISK = 0.9
"""The ego's own risk level p (a cautious automated vehicle)."""
PREDICTORS = ("cv", "style", "oracle")
"""The ego's prediction models of the cut-in study, in report order."""


def ego_scenario(scenario: ScenarioConfig) -> ScenarioConfig:
    """The ego's view of a cut-in scenario: its lane is the target, its speed the reference.

    Args:
        scenario: the cut-in scenario in the lane changer's frame (EV = cutter, TV = ego).

    Returns:
        The same road and bounds with the ego as EV: it keeps ``tv_lane`` at its initial
        speed ``tv_speed`` (the cutter becomes its TV).
    """
    sc = scenario
    other = next(lane for lane in range(sc.n_lanes) if lane != sc.tv_lane)
    return dataclasses.replace(
        sc, ev_lane=other, target_lane=sc.tv_lane, ev_x=sc.ev_x + sc.tv_gap,
        ev_speed=sc.tv_speed, tv_lane=sc.ev_lane, tv_gap=-sc.tv_gap, tv_speed=sc.ev_speed,
        v_ref=max(sc.tv_speed, 1.0), check_start=False,
    )  # fmt: skip


class AwareSMPC(SMPCExpert):
    """The ego's SMPC with the cutter's mean path from an online predictor.

    Acts on ``drivestyle/CutIn-v0`` observations ([ego, cutter]); call :meth:`start` at
    every reset with the env's scenario and the cutter's risk.

    Args:
        predictor: the model of the cutter (:mod:`drivestyle.prediction.online`).
        config: the ego's SMPC (default: the paper's weights at :data:`EGO_RISK`); it is
            built with ``predicted_paths`` and one constrained vehicle.
        scenario: a cut-in scenario (cutter's frame) for the NLP's geometry.
    """

    def __init__(
        self,
        predictor: OnlinePredictor,
        config: SMPCConfig | None = None,
        scenario: ScenarioConfig | None = None,
    ) -> None:
        cfg = dataclasses.replace(
            config or SMPCConfig(risk=EGO_RISK), predicted_paths=True, max_vehicles=1,
            compiled=True,
        )  # fmt: skip
        super().__init__(cfg, ego_scenario(scenario or ScenarioConfig()))
        self.predictor = predictor

    def start(self, scenario: ScenarioConfig, cutter_risk: float) -> None:
        """Begin an episode of the cut-in ``scenario`` (cutter's frame)."""
        self.reset(ego_scenario(scenario))
        self.predictor.reset(scenario, cutter_risk)

    def _constrained_vehicles(self, xi0: np.ndarray, others: np.ndarray) -> np.ndarray:
        """The cutter's predicted path, shape (1, N, 2) (observation: ego, cutter)."""
        return self.predictor.predict(others[0], xi0, self.config.horizon)[None]
