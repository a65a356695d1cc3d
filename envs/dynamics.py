"""Kinematic bicycle model (docs/DESIGN.md §2) and the one discrete map shared by env and SMPC.

The same Python functions evaluate on numpy arrays (the environment) and on CasADi
symbols (the SMPC's prediction model), so a noise-free closed loop follows the
prediction exactly.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, TypeVar

import casadi as ca
import numpy as np

if TYPE_CHECKING:
    from drivestyle.envs.scenario import ScenarioConfig

__all__ = [
    "INPUT_FIT_SCALE",
    "bicycle_ode",
    "inverse_step",
    "recover_inputs",
    "rk4_step",
    "rk4_step_scalar",
]

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


def rk4_step_scalar(
    x: float,
    y: float,
    phi: float,
    v: float,
    a: float,
    delta: float,
    T_s: float,
    l_f: float,
    l_r: float,
    n_sub: int = 1,
) -> tuple[float, float, float, float]:
    """:func:`rk4_step` on Python floats: the environment's fast path.

    The same operations in the same order as the array path (numpy's tan and arctan for β,
    whose results can differ from the math module's in the last bit), without building
    small arrays per stage: equal to :func:`rk4_step` to round-off (tested to 1e-12).

    Args:
        x: position along the road [m].
        y: lateral position [m].
        phi: heading [rad].
        v: speed [m/s].
        a: acceleration held over the step [m/s²].
        delta: steering angle held over the step [rad].
        T_s: step length [s].
        l_f: centre of mass to front axle [m].
        l_r: centre of mass to rear axle [m].
        n_sub: RK4 sub-steps per T_s.

    Returns:
        ξ_{k+1} = (x, y, φ, v).
    """
    # the input is held over the step, so β (and sin β) is the same at every stage
    beta = float(np.arctan(l_r / (l_f + l_r) * np.tan(delta)))
    sin_beta = math.sin(beta)
    cos, sin = math.cos, math.sin
    h = T_s / n_sub
    h2, h6 = h / 2, h / 6
    for _ in range(n_sub):
        b1 = phi + beta
        k1x, k1y, k1p = v * cos(b1), v * sin(b1), v / l_r * sin_beta
        v2 = v + h2 * a
        b2 = phi + h2 * k1p + beta
        k2x, k2y, k2p = v2 * cos(b2), v2 * sin(b2), v2 / l_r * sin_beta
        v3 = v + h2 * a
        b3 = phi + h2 * k2p + beta
        k3x, k3y, k3p = v3 * cos(b3), v3 * sin(b3), v3 / l_r * sin_beta
        v4 = v + h * a
        b4 = phi + h * k3p + beta
        k4x, k4y, k4p = v4 * cos(b4), v4 * sin(b4), v4 / l_r * sin_beta
        x = x + h6 * (k1x + 2 * k2x + 2 * k3x + k4x)
        y = y + h6 * (k1y + 2 * k2y + 2 * k3y + k4y)
        phi = phi + h6 * (k1p + 2 * k2p + 2 * k3p + k4p)
        v = v + h6 * (a + 2 * a + 2 * a + a)
    return x, y, phi, v


INPUT_FIT_SCALE = np.array([0.1, 0.05, 0.01, 0.1])
"""Scale of the one-step state mismatch [m, m, rad, m/s] :func:`inverse_step` weighs."""


def inverse_step(
    xi: np.ndarray,
    xi_next: np.ndarray,
    T_s: float,
    l_f: float,
    l_r: float,
    lower: tuple[float, float],
    upper: tuple[float, float],
) -> np.ndarray:
    """The input [a, δ] that carries ξ_k to ξ_{k+1} under :func:`rk4_step` (inputs unseen).

    Bounded least squares on the state mismatch scaled by :data:`INPUT_FIT_SCALE` (four
    equations, two unknowns: exact when ξ_{k+1} came from the model, the closest input for
    a recorded or noisy pair), started from a = Δv/T_s, δ = 0: projected Gauss–Newton (a few
    RK4 steps, ≈ 0.1 ms: the online tracker recovers one input per sample), and SciPy's
    trust-region solver where that does not converge.

    Args:
        xi: ξ_k = [x, y, φ, v], shape (4,).
        xi_next: ξ_{k+1}, shape (4,).
        T_s: the step between them [s].
        l_f: centre of mass to front axle [m].
        l_r: centre of mass to rear axle [m].
        lower: [a_min, δ_min] the input may take.
        upper: [a_max, δ_max].

    Returns:
        [a, δ], shape (2,).
    """
    xi, xi_next = np.asarray(xi, float), np.asarray(xi_next, float)
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)

    x, y, phi, v = (float(s) for s in xi)

    def mismatch(u: np.ndarray) -> np.ndarray:
        nxt = rk4_step_scalar(x, y, phi, v, float(u[0]), float(u[1]), T_s, l_f, l_r)
        return (np.array(nxt) - xi_next) / INPUT_FIT_SCALE

    u = np.array([float(np.clip((xi_next[3] - xi[3]) / T_s, lo[0], hi[0])), 0.0])
    r = mismatch(u)
    h = np.array([1e-6, 1e-7])
    for _ in range(20):
        J = np.stack([(mismatch(u + np.eye(2)[i] * h[i]) - r) / h[i] for i in range(2)], 1)
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        # an input held at its bound by a step pointing outside stays there, and the other
        # one is fitted alone (else the clipped two-input step is not the constrained one)
        held = ((u <= lo) & (step < 0)) | ((u >= hi) & (step > 0))
        if held.any() and not held.all():
            free = ~held
            step = np.zeros(2)
            step[free] = np.linalg.lstsq(J[:, free], -r, rcond=None)[0]
        elif held.all():
            return u
        u_new = np.clip(u + step, lo, hi)
        r_new = mismatch(u_new)
        for _ in range(4):  # backtrack a step that overshoots a recorded pair's residual
            if r_new @ r_new <= r @ r:
                break
            step = step / 2
            u_new = np.clip(u + step, lo, hi)
            r_new = mismatch(u_new)
        # converged when the projected step vanishes (1e-9: far below any input's
        # meaning), also where a bound holds the input (recorded steering beyond δ_max);
        # at a recorded pair's non-zero residual the last steps only move rounding noise
        converged = bool(np.all(np.abs(u_new - u) < 1e-9))
        if r_new @ r_new > r @ r:
            if converged:
                return u
            break  # no descent (a bound or a poor model fit): the general solver decides
        u, r = u_new, r_new
        if converged:
            return u
    from scipy.optimize import least_squares

    return least_squares(mismatch, u, bounds=(lo, hi)).x


def recover_inputs(
    ev: np.ndarray, scenario: ScenarioConfig, t: np.ndarray | None = None
) -> np.ndarray:
    """The inputs [a, δ] that carry each state to the next (recorded inputs are unseen).

    Per step, :func:`inverse_step`: the input within the scenario's bounds
    [a_min, a_max] × [−δ_max, δ_max] whose RK4 step of the bicycle model (l_f, l_r of the
    scenario) comes closest to the next state — exact for states the model produced, the
    closest input for recorded ones (every recorded path and the simulated tracker,
    :func:`drivestyle.envs.tracking.observe`, use this one function). The online tracker
    (:class:`drivestyle.irl.identification.online.StyleTracker`) recovers the same inputs sample
    by sample.

    Args:
        ev: EV states [x, y, φ, v], shape (n, 4).
        scenario: the episode's scenario (bounds, axle distances, T_s).
        t: sample times, shape (n,) [s] (default: T_s apart).

    Returns:
        Inputs, shape (n − 1, 2) [m/s², rad].
    """
    ev = np.asarray(ev, float)
    steps = np.full(ev.shape[0] - 1, scenario.dt) if t is None else np.diff(np.asarray(t, float))
    lo, hi = (scenario.a_min, -scenario.delta_max), (scenario.a_max, scenario.delta_max)
    u = np.zeros((ev.shape[0] - 1, 2))
    for k, dt in enumerate(steps):
        u[k] = inverse_step(ev[k], ev[k + 1], float(dt), scenario.l_f, scenario.l_r, lo, hi)
    return u
