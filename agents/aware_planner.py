"""An SMPC ego that predicts the vehicle cutting in by a pluggable model (DESIGN §17).

Today's SMPC predicts every other vehicle at constant velocity inside its NLP. Here the
ego of ``drivestyle/CutIn-v0`` (:mod:`drivestyle.envs.cut_in`) plans with the same cost,
chance constraint and covariance, but the other vehicle's *mean* path over the horizon
comes from a :class:`Predictor` (the NLP built with
:attr:`~drivestyle.planning.description.SMPCConfig.predicted_paths`):

- :class:`ConstantVelocityPredictor` — what the SMPC assumes today (the ego then plans
  exactly as :class:`~drivestyle.agents.smpc.SMPCExpert` does, tested);
- :class:`StylePredictor` — the style identified online: a
  :class:`~drivestyle.irl.identification.online.StyleTracker` updated with every observed state of
  the vehicle, and the library's style at the posterior mean risk driven in closed loop over
  the horizon from the vehicle's current state, the ego at constant velocity (what the
  vehicle's own SMPC assumes of it), each rollout's first solve warm-started from the
  previous rollout's first plan (:func:`~drivestyle.prediction.style.rollout_from`);
- :class:`OraclePredictor` — the same rollout with the vehicle's true style.

The scenario is the cut-in env's, in the lane changer's frame (its EV is the cutter, its
TV the ego); :func:`ego_scenario` turns it into the ego's own (its lane, its speed).
"""

from __future__ import annotations

import dataclasses
from typing import Protocol

import numpy as np

from drivestyle.agents.smpc import SMPCConfig, SMPCExpert
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.online import StyleTracker
from drivestyle.planning.description import PrimalDual
from drivestyle.prediction.kinematic import constant_velocity
from drivestyle.prediction.style import rollout_from

__all__ = [
    "EGO_RISK",
    "PREDICTORS",
    "AwareSMPC",
    "ConstantVelocityPredictor",
    "OraclePredictor",
    "Predictor",
    "StylePredictor",
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


class Predictor(Protocol):
    """A model of the other vehicle's mean path over the ego's horizon."""

    def reset(self, scenario: ScenarioConfig, risk: float) -> None:
        """Start an episode of a cut-in scenario (cutter's frame) with the cutter's true risk.

        Only the oracle may use the risk.
        """

    def predict(self, cutter: np.ndarray, ego: np.ndarray, steps: int) -> np.ndarray:
        """Observe the states at t_k; return the cutter's next ``steps`` positions.

        Returns:
            Positions at t_{k+1} … t_{k+steps}, shape (steps, 2).
        """


class _Rollout:
    """A style's closed-loop rollout with the ego at constant velocity, warm-started.

    The first solve starts from the previous rollout's first plan — the driver's own warm
    start: the NLP is not convex, and a cold start may find another plan than the one the
    driver follows.
    """

    def __init__(self) -> None:
        self.previous: PrimalDual | None = None

    def __call__(
        self, style: DriverStyle, cutter: np.ndarray, ego: np.ndarray, sc: ScenarioConfig,
        steps: int,
    ) -> np.ndarray:  # fmt: skip
        xs, self.previous = rollout_from(style, cutter, ego[None, :], sc, steps, self.previous)
        return xs[1:, :2]


class ConstantVelocityPredictor:
    """The cutter's last velocity held (today's SMPC)."""

    def __init__(self) -> None:
        self._dt = 0.2

    def reset(self, scenario: ScenarioConfig, risk: float) -> None:
        """Start an episode (only T_s is used)."""
        self._dt = scenario.dt

    def predict(self, cutter: np.ndarray, ego: np.ndarray, steps: int) -> np.ndarray:
        """Constant-velocity positions, shape (steps, 2)."""
        return constant_velocity(cutter, self._dt, steps)[1:]


class StylePredictor:
    """The cutter's style identified online, rolled out at the posterior mean risk.

    Args:
        library: the driver library whose cost the cutter is assumed to share.
    """

    def __init__(self, library: DriverLibrary) -> None:
        self.library = library
        self.tracker: StyleTracker | None = None
        self._scenario: ScenarioConfig | None = None
        self._rollout = _Rollout()

    def reset(self, scenario: ScenarioConfig, risk: float) -> None:
        """Start an episode: a fresh posterior (the true risk is not used)."""
        self._scenario = scenario
        self.tracker = StyleTracker(self.library, scenario)
        self._rollout = _Rollout()

    def predict(self, cutter: np.ndarray, ego: np.ndarray, steps: int) -> np.ndarray:
        """Update the posterior with (cutter, ego) and roll the style out, shape (steps, 2)."""
        if self.tracker is None or self._scenario is None:
            raise RuntimeError("StylePredictor.predict() before reset()")
        self.tracker.update(cutter, ego[None, :])
        style = self.tracker.style("mean")
        return self._rollout(style, cutter, ego, self._scenario, steps)


class OraclePredictor:
    """The cutter's true model (its weights and the episode's true risk) rolled out.

    Args:
        style: the cutter's weights (its risk is replaced by each episode's).
    """

    def __init__(self, style: DriverStyle) -> None:
        self.style = style
        self._scenario: ScenarioConfig | None = None
        self._rollout = _Rollout()

    def reset(self, scenario: ScenarioConfig, risk: float) -> None:
        """Start an episode with the cutter's true risk."""
        self._scenario = scenario
        self.style = dataclasses.replace(self.style, risk=float(risk))
        self._rollout = _Rollout()

    def predict(self, cutter: np.ndarray, ego: np.ndarray, steps: int) -> np.ndarray:
        """The true model's closed-loop path, shape (steps, 2)."""
        if self._scenario is None:
            raise RuntimeError("OraclePredictor.predict() before reset()")
        return self._rollout(self.style, cutter, ego, self._scenario, steps)


class AwareSMPC(SMPCExpert):
    """The ego's SMPC with the cutter's mean path from a :class:`Predictor`.

    Acts on ``drivestyle/CutIn-v0`` observations ([ego, cutter]); call :meth:`start` at
    every reset with the env's scenario and the cutter's risk.

    Args:
        predictor: the model of the cutter.
        config: the ego's SMPC (default: the paper's weights at :data:`EGO_RISK`); it is
            built with ``predicted_paths`` and one constrained vehicle.
        scenario: a cut-in scenario (cutter's frame) for the NLP's geometry.
    """

    def __init__(
        self,
        predictor: Predictor,
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
