"""Online predictors of the vehicle cutting in: fed every step, for the ego's plan (DESIGN §17).

The offline predictors (:class:`~drivestyle.prediction.protocol.Predictor`) see an
:class:`~drivestyle.prediction.protocol.Observation` once and return a path. These are fed
online, one step at a time, in the cut-in scene of ``drivestyle/CutIn-v0``
(:mod:`drivestyle.envs.cut_in`): an :class:`OnlinePredictor` is reset at every episode and
asked at every step for the cutter's mean path over the ego's horizon, which the style-aware
ego (:class:`~drivestyle.agents.aware_planner.AwareSMPC`) plans around:

- :class:`ConstantVelocityPredictor` — what the SMPC assumes today (the ego then plans
  exactly as :class:`~drivestyle.agents.smpc.SMPCExpert` does, tested);
- :class:`StylePredictor` — the style identified online: a
  :class:`~drivestyle.irl.identification.online.StyleTracker` updated with every observed state of
  the vehicle, and the library's style at the posterior mean risk driven in closed loop over
  the horizon from the vehicle's current state, the ego at constant velocity (what the
  vehicle's own SMPC assumes of it), each rollout's first solve warm-started from the
  previous rollout's first plan (:func:`~drivestyle.prediction.style.rollout_from`);
- :class:`OraclePredictor` — the same rollout with the vehicle's true style.

Their scenario is the cut-in env's, in the lane changer's frame (its EV is the cutter, its
TV the ego).
"""

from __future__ import annotations

import dataclasses
from typing import Protocol

import numpy as np

from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.online import StyleTracker
from drivestyle.planning.description import PrimalDual
from drivestyle.prediction.kinematic import constant_velocity
from drivestyle.prediction.style import rollout_from

__all__ = [
    "ConstantVelocityPredictor",
    "OnlinePredictor",
    "OraclePredictor",
    "StylePredictor",
]


class OnlinePredictor(Protocol):
    """A model of the cutting-in vehicle's mean path over the ego's horizon, fed online.

    Stateful, unlike :class:`~drivestyle.prediction.protocol.Predictor`: :meth:`reset` at
    every episode, then :meth:`predict` at every step with that step's states only.
    """

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
