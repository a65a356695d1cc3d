"""Piecewise quintic splines over control points (paper §II-B, §III-D; docs/DESIGN.md §4).

A trajectory r(t) on knots t_0 < … < t_S is one quintic per interval [t_j, t_{j+1}],
fixed by the control points c_j = [r^x, v^x, a^x, r^y, v^y, a^y] at its two ends, so
position, velocity and acceleration are continuous (C²) across knots.

Everything a feature needs is a value of r, ṙ or r̈ at fixed times, and those are linear
in the control points of one axis: :func:`basis_matrix` builds that linear map once, so
features and their exact derivatives are cheap (see :mod:`drivestyle.irl.paper.features`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from drivestyle.envs.demonstration import Demonstration

__all__ = [
    "CONTROL_POINT_RULES",
    "QuinticTrajectory",
    "basis_matrix",
    "demo_control_points",
    "evaluate_quintic",
    "quintic_coefficients",
    "spline_eval",
    "state_control_points",
]

CONTROL_POINT_RULES = ("kinematic", "paper")
"""How a sampled trajectory's velocities and accelerations are derived (DESIGN §4)."""


def _hermite_matrix(T: float) -> np.ndarray:
    """M(T) with q = M @ [r0, v0, a0, r1, v1, a1], q in ascending powers of τ."""
    T2, T3, T4, T5 = T**2, T**3, T**4, T**5
    return np.array(
        [
            [1, 0, 0, 0, 0, 0],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 0.5, 0, 0, 0],
            [-10 / T3, -6 / T2, -1.5 / T, 10 / T3, -4 / T2, 0.5 / T],
            [15 / T4, 8 / T3, 1.5 / T2, -15 / T4, 7 / T3, -1 / T2],
            [-6 / T5, -3 / T4, -0.5 / T3, 6 / T5, -3 / T4, 0.5 / T3],
        ]
    )


def quintic_coefficients(c0: ArrayLike, c1: ArrayLike, T: float) -> np.ndarray:
    """Coefficients of the quintic joining two one-axis control points (Simon 1999, eq. 7–8).

    Args:
        c0: [r, v, a] at τ = 0, shape (..., 3) [m, m/s, m/s²].
        c1: [r, v, a] at τ = T, shape (..., 3).
        T: segment duration [s], > 0.

    Returns:
        q_0 … q_5 in ascending powers of the local time τ ∈ [0, T], shape (..., 6).
    """
    if not T > 0:
        raise ValueError(f"segment duration must be > 0, got {T}")
    c = np.concatenate([np.asarray(c0, float), np.asarray(c1, float)], axis=-1)
    return c @ _hermite_matrix(T).T


def evaluate_quintic(q: ArrayLike, tau: ArrayLike, derivative: int = 0) -> np.ndarray:
    """Value (or derivative) of a quintic at local times τ.

    Args:
        q: coefficients in ascending powers, shape (..., 6).
        tau: local times, broadcastable against q[..., 0] [s].
        derivative: 0 position, 1 velocity, 2 acceleration, 3 jerk.

    Returns:
        The values, broadcast shape.
    """
    q = np.asarray(q, float)
    tau = np.asarray(tau, float)
    out = np.zeros(np.broadcast(q[..., 0], tau).shape)
    for p in range(derivative, 6):
        factor = np.prod(np.arange(p - derivative + 1, p + 1)) if derivative else 1.0
        out = out + factor * q[..., p] * tau ** (p - derivative)
    return out


def _locate(t_knots: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segment index and local time for each query time (clamped to the knot range)."""
    S = t_knots.size - 1
    j = np.clip(np.searchsorted(t_knots, t, side="right") - 1, 0, S - 1)
    return j, t - t_knots[j]


def basis_matrix(t_knots: ArrayLike, t: ArrayLike, derivative: int = 0) -> np.ndarray:
    """Linear map from one axis's control points to spline values at times ``t``.

    Args:
        t_knots: knot times t_0 … t_S, shape (S+1,) [s], strictly increasing.
        t: query times within [t_0, t_S], shape (m,) [s].
        derivative: 0 position, 1 velocity, 2 acceleration.

    Returns:
        B, shape (m, 3(S+1)), such that values = B @ c_axis with c_axis the flattened
        [r_j, v_j, a_j] of every knot j.
    """
    t_knots = np.asarray(t_knots, float)
    t = np.atleast_1d(np.asarray(t, float))
    S = t_knots.size - 1
    j, tau = _locate(t_knots, t)
    B = np.zeros((t.size, 3 * (S + 1)))
    powers = np.arange(6)
    for i in range(t.size):
        M = _hermite_matrix(t_knots[j[i] + 1] - t_knots[j[i]])
        if derivative == 0:
            row = tau[i] ** powers
        else:
            fac = np.array(
                [
                    np.prod(np.arange(p - derivative + 1, p + 1)) if p >= derivative else 0.0
                    for p in powers
                ]
            )
            row = fac * np.where(
                powers >= derivative, tau[i] ** np.maximum(powers - derivative, 0), 0.0
            )
        B[i, 3 * j[i] : 3 * j[i] + 6] = row @ M
    return B


def spline_eval(C: ArrayLike, t_knots: ArrayLike, t: ArrayLike, derivative: int = 0) -> np.ndarray:
    """Evaluate a 2-D piecewise quintic (vectorised over query times).

    Args:
        C: control points, shape (S+1, 6): [r^x, v^x, a^x, r^y, v^y, a^y] per knot.
        t_knots: knot times, shape (S+1,) [s].
        t: query times, shape (m,) [s].
        derivative: 0 position, 1 velocity, 2 acceleration.

    Returns:
        Values, shape (m, 2) as [x, y] (or their derivatives).
    """
    C = np.asarray(C, float)
    B = basis_matrix(t_knots, t, derivative)
    return np.stack([B @ C[:, :3].ravel(), B @ C[:, 3:].ravel()], axis=1)


def _central_diff(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """dv/dt by central differences, one-sided at the ends."""
    return np.gradient(v, t, edge_order=1)


def demo_control_points(demo: Demonstration, control_point_rule: str = "kinematic") -> np.ndarray:
    """Control points of a demonstration at its samples (DESIGN §4).

    Positions come from the states. Velocities and accelerations by ``control_point_rule``:

    - ``"paper"`` (§III-D as written): v^x = v cos φ, v^y = v sin φ,
      a^x = (v_{t+1} − v_{t−1})/(2T_s) cos φ, a^y likewise with sin φ (one-sided at the
      ends). It drops the side-slip β and the v·φ̇ term, so v^y jumps from 0 to v·φ_max
      across the first segment, which then carries most of f_ay (DESIGN §4).
    - ``"kinematic"`` (default): the bicycle model's own velocity, v^x = v cos(φ+β),
      v^y = v sin(φ+β) with β = atan(l_r/(l_f+l_r)·tan δ) from the applied steering, and
      accelerations as central differences of those velocities (one-sided at the ends),
      which keeps the v·φ̇ term. If the demonstration's heading is the course
      (``meta["heading"] == "course"``: recorded data, whose heading is atan2(ẏ, ẋ) = φ + β)
      or it has no steering input (u ≡ 0), β = 0.

    Args:
        demo: the demonstration.
        control_point_rule: ``"kinematic"`` or ``"paper"``.

    Returns:
        Control points, shape (n, 6) [m, m/s, m/s², m, m/s, m/s²].
    """
    try:
        sc = demo.scenario
        ratio = sc.l_r / (sc.l_f + sc.l_r)
    except ValueError:
        ratio = 0.5
    delta = np.append(demo.u[:, 1], demo.u[-1, 1])
    if demo.meta.get("heading") == "course":
        # a recorded heading is the course atan2(ẏ, ẋ) = φ + β: β is in it already
        delta = np.zeros_like(delta)
    return state_control_points(demo.t, demo.ev, delta, control_point_rule, ratio)


def state_control_points(
    t: np.ndarray, states: np.ndarray, delta: np.ndarray, control_point_rule: str, ratio: float
) -> np.ndarray:
    """Control points from sampled states by a rule of :func:`demo_control_points`.

    Args:
        t: sample times, shape (n,) [s] (n ≥ 2).
        states: [x, y, φ, v] per sample, shape (n, 4).
        delta: steering applied from each sample (the last one repeated), shape (n,) [rad].
        control_point_rule: ``"kinematic"`` or ``"paper"``.
        ratio: l_r/(l_f + l_r) of the side-slip β (kinematic rule).

    Returns:
        Control points, shape (n, 6).
    """
    if control_point_rule not in CONTROL_POINT_RULES:
        raise ValueError(
            f"unknown control-point rule {control_point_rule!r}; choose from {CONTROL_POINT_RULES}"
        )
    x, y, phi, v = np.asarray(states, float).T
    if control_point_rule == "paper":
        dv = _central_diff(v, t)
        vx, vy = v * np.cos(phi), v * np.sin(phi)
        ax, ay = dv * np.cos(phi), dv * np.sin(phi)
    else:
        beta = np.arctan(ratio * np.tan(np.asarray(delta, float)))
        vx, vy = v * np.cos(phi + beta), v * np.sin(phi + beta)
        ax, ay = _central_diff(vx, t), _central_diff(vy, t)
    return np.column_stack([x, vx, ax, y, vy, ay])


@dataclass(frozen=True)
class QuinticTrajectory:
    """A 2-D piecewise quintic with its first control point fixed (§II-B).

    ``free`` holds c_1 … c_S, the optimiser's variables; ``c0`` stays as given.
    """

    t_knots: np.ndarray
    """Knot times t_0 … t_S, shape (S+1,) [s]."""
    c0: np.ndarray
    """Fixed first control point [r^x, v^x, a^x, r^y, v^y, a^y], shape (6,)."""
    free: np.ndarray
    """Control points c_1 … c_S, shape (S, 6)."""

    def __post_init__(self) -> None:
        t = np.asarray(self.t_knots, float)
        if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
            raise ValueError("t_knots must be a strictly increasing 1-D array of >= 2 times")
        if np.shape(self.c0) != (6,) or np.shape(self.free) != (t.size - 1, 6):
            raise ValueError(
                f"c0 must have shape (6,) and free ({t.size - 1}, 6); "
                f"got {np.shape(self.c0)} and {np.shape(self.free)}"
            )

    @property
    def control_points(self) -> np.ndarray:
        """All control points c_0 … c_S, shape (S+1, 6)."""
        return np.vstack([self.c0, self.free])

    def __call__(self, t: ArrayLike, derivative: int = 0) -> np.ndarray:
        """[x, y] (or a derivative) at times ``t``, shape (m, 2)."""
        return spline_eval(self.control_points, self.t_knots, np.atleast_1d(t), derivative)
