"""What every predictor is: the observed part of a vehicle in, its predicted path out.

DESIGN §17. An *observer* has seen a vehicle's first samples ξ_0 … ξ_k and those of the
vehicles around it (an :class:`Observation`: nothing after sample k is in it, so no
predictor can read the future); a :class:`Predictor` returns the vehicle's positions
ξ_k … ξ_{k+H} (a :class:`PredictedPath`, row 0 the present). Each method of
:data:`drivestyle.prediction.methods.METHODS` is one predictor;
:func:`~drivestyle.prediction.methods.predict` runs them by name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from drivestyle.envs.scenario import ScenarioConfig

__all__ = ["ForecastError", "Observation", "PredictedPath", "Predictor"]


class ForecastError(ValueError):
    """A prediction request the data cannot answer (observation window, shapes)."""


@dataclass(frozen=True)
class Observation:
    """A vehicle as an observer has seen it after t_obs: samples 0 … k, nothing later."""

    ev: np.ndarray
    """The vehicle's observed states ξ_0 … ξ_k [x, y, φ, v], shape (k + 1, 4) [m, m, rad, m/s];
    the last one is the present."""
    vehicles: np.ndarray
    """The surrounding vehicles' states at the same samples, shape (k + 1, m, 4) (the vehicle
    it reacts to first in slot 0)."""
    scenario: ScenarioConfig
    """The scenario it is predicted in (T_s, lanes, geometry, target lane, v_ref; recorded
    traffic: one built from the observed samples only)."""

    def __post_init__(self) -> None:
        ev, vehicles = np.shape(self.ev), np.shape(self.vehicles)
        if len(ev) != 2 or ev[0] < 1 or ev[1] != 4:
            raise ForecastError(f"observed states must have shape (k + 1, 4), got {ev}")
        if len(vehicles) != 3 or vehicles[0] != ev[0] or vehicles[2] != 4:
            raise ForecastError(
                f"the surrounding vehicles' states must have shape ({ev[0]}, m, 4), got {vehicles}"
            )

    @property
    def dt(self) -> float:
        """T_s [s] (the scenario's)."""
        return self.scenario.dt

    @property
    def state(self) -> np.ndarray:
        """ξ_k, the vehicle's current state, shape (4,)."""
        return self.ev[-1]

    @property
    def others(self) -> np.ndarray:
        """The surrounding vehicles' current states, shape (m, 4)."""
        return self.vehicles[-1]


@dataclass(frozen=True)
class PredictedPath:
    """One predictor's path of the vehicle."""

    xy: np.ndarray
    """Positions at j = 0 … H, shape (H + 1, 2) [m] (row 0: the last observed position)."""
    risk: float | None = None
    """The risk a style predictor drove at (a mixture: its posterior mean); None otherwise."""
    radius: float | None = None
    """A sampling predictor's own 90 % region of the final position: the radius around its
    final position holding 90 % of its samples' [m]; None: a point predictor."""


class Predictor(Protocol):
    """A prediction method: the observed vehicle and a horizon in, its predicted path out."""

    def predict(self, seen: Observation, steps: int) -> PredictedPath:
        """The vehicle's positions over the next ``steps`` samples.

        Args:
            seen: what the observer has seen (samples 0 … k).
            steps: H, samples to predict.

        Returns:
            The path at j = 0 … H (H + 1 rows).
        """
        ...
