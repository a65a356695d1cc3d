"""The kinematic predictors: constant velocity and constant acceleration (DESIGN §17).

- :class:`ConstantVelocity` (``cv``): the last velocity vector (v cos φ, v sin φ) held;
- :class:`ConstantAcceleration` (``ca``): the last velocity change per step held as well.

:func:`others_at_constant_velocity` is the observer's model of the *surrounding* vehicles
(the style rollouts drive among them). Not to be confused with
:mod:`drivestyle.planning.tv_gaussian`, the SMPC's own model of the vehicles around it
(constant velocity plus a growing covariance, inside the NLP).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drivestyle.prediction.protocol import Observation, PredictedPath

__all__ = [
    "ConstantAcceleration",
    "ConstantVelocity",
    "constant_acceleration",
    "constant_velocity",
    "others_at_constant_velocity",
]


def constant_velocity(state: np.ndarray, dt: float, steps: int) -> np.ndarray:
    """Positions under constant velocity: p_j = p_k + j T_s (v cos φ, v sin φ).

    Args:
        state: the last observed state [x, y, φ, v], shape (4,).
        dt: T_s [s].
        steps: H, samples to predict.

    Returns:
        Positions at j = 0 … H, shape (H + 1, 2) (row 0: the last observed position).
    """
    x, y, phi, v = (float(s) for s in state)
    j = np.arange(steps + 1)[:, None] * dt
    return np.array([x, y]) + j * v * np.array([np.cos(phi), np.sin(phi)])


def constant_acceleration(states: np.ndarray, dt: float, steps: int) -> np.ndarray:
    """Positions under constant acceleration: p_j = p_k + j T_s v_k + ½ (j T_s)² a_k.

    The velocity vector is (v cos φ, v sin φ); a_k is its change over the last step
    divided by T_s (zero with one sample).

    Args:
        states: the observed states, shape (k + 1, 4), the last one current.
        dt: T_s [s].
        steps: H.

    Returns:
        Shape (H + 1, 2).
    """
    vel = states[:, 3:4] * np.stack([np.cos(states[:, 2]), np.sin(states[:, 2])], axis=1)
    acc = (vel[-1] - vel[-2]) / dt if len(states) > 1 else np.zeros(2)
    tau = np.arange(steps + 1)[:, None] * dt
    return states[-1, :2] + tau * vel[-1] + 0.5 * tau**2 * acc


def others_at_constant_velocity(others: np.ndarray, dt: float, steps: int) -> np.ndarray:
    """The surrounding vehicles' states over the next ``steps`` at constant velocity.

    Args:
        others: their last observed states, shape (m, 4).
        dt: T_s [s].
        steps: H.

    Returns:
        Shape (H + 1, m, 4) (heading and speed held).
    """
    tau = np.arange(steps + 1)[:, None] * dt
    out = np.repeat(others[None, :, :], steps + 1, axis=0).astype(float)
    out[..., 0] += tau * others[:, 3] * np.cos(others[:, 2])
    out[..., 1] += tau * others[:, 3] * np.sin(others[:, 2])
    return out


@dataclass(frozen=True)
class ConstantVelocity:
    """``cv``: :func:`constant_velocity` from the last observed state."""

    def predict(self, seen: Observation, steps: int) -> PredictedPath:
        """The constant-velocity path (:class:`~drivestyle.prediction.protocol.Predictor`)."""
        return PredictedPath(constant_velocity(seen.state, seen.dt, steps))


@dataclass(frozen=True)
class ConstantAcceleration:
    """``ca``: :func:`constant_acceleration` from the observed states."""

    def predict(self, seen: Observation, steps: int) -> PredictedPath:
        """The constant-acceleration path (:class:`~drivestyle.prediction.protocol.Predictor`)."""
        return PredictedPath(constant_acceleration(seen.ev, seen.dt, steps))
