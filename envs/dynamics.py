"""Kinematic bicycle model (docs/DESIGN.md §2) and the one discrete map shared by env and SMPC.

The same Python functions evaluate on numpy arrays (the environment) and on CasADi
symbols (the SMPC's prediction model), so a noise-free closed loop follows the
prediction exactly.
"""

from __future__ import annotations

from typing import TypeVar

import casadi as ca
import numpy as np

__all__ = ["bicycle_ode", "rk4_step"]

Arr = TypeVar("Arr", np.ndarray, ca.SX, ca.MX)


def _ops(xi: object) -> tuple:
    """(stack, sin, cos, atan, tan) for numpy or CasADi operands."""
    if isinstance(xi, (ca.SX, ca.MX, ca.DM)):
        return ca.vertcat, ca.sin, ca.cos, ca.atan, ca.tan
    return (lambda *a: np.array(a, dtype=float)), np.sin, np.cos, np.arctan, np.tan


def bicycle_ode(xi: Arr, u: Arr, l_f: float, l_r: float) -> Arr:
    """Continuous-time kinematic bicycle model ξ̇ = f(ξ, u).

    β = atan(l_r/(l_f+l_r)·tan δ); ẋ = v cos(φ+β); ẏ = v sin(φ+β); φ̇ = (v/l_r) sin β;
    v̇ = a.

    Args:
        xi: state [x, y, φ, v], shape (4,) [m, m, rad, m/s] (numpy or CasADi).
        u: input [a, δ], shape (2,) [m/s², rad].
        l_f: centre of mass to front axle [m].
        l_r: centre of mass to rear axle [m].

    Returns:
        ξ̇, shape (4,), same array type as ``xi``.
    """
    stack, sin, cos, atan, tan = _ops(xi)
    phi, v = xi[2], xi[3]
    a, delta = u[0], u[1]
    beta = atan(l_r / (l_f + l_r) * tan(delta))
    return stack(v * cos(phi + beta), v * sin(phi + beta), v / l_r * sin(beta), a)


def rk4_step(xi: Arr, u: Arr, T_s: float, l_f: float, l_r: float, n_sub: int = 1) -> Arr:
    """Discrete map ξ_{k+1} = F(ξ_k, u_k): classic RK4 with zero-order-hold input.

    Args:
        xi: state [x, y, φ, v], shape (4,).
        u: input [a, δ] held over the step, shape (2,).
        T_s: step length [s].
        l_f: centre of mass to front axle [m].
        l_r: centre of mass to rear axle [m].
        n_sub: RK4 sub-steps per T_s (one step of 0.2 s is accurate to ~1e-7 m here).

    Returns:
        ξ_{k+1}, shape (4,), same array type as ``xi``.
    """
    h = T_s / n_sub
    for _ in range(n_sub):
        k1 = bicycle_ode(xi, u, l_f, l_r)
        k2 = bicycle_ode(xi + h / 2 * k1, u, l_f, l_r)
        k3 = bicycle_ode(xi + h / 2 * k2, u, l_f, l_r)
        k4 = bicycle_ode(xi + h * k3, u, l_f, l_r)
        xi = xi + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return xi
