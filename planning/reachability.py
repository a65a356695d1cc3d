"""Where the EV can be one step ahead, and plans that cannot exist (DESIGN §16).

Every plan of the style's NLP must keep the EV outside each constrained vehicle's nominal
ellipse from stage 1 on (‖z̄_1‖ − 1 ≥ 0, :mod:`drivestyle.planning.smpc_problem`; a hard
constraint with no slack, independent of the risk p). Stage 1 is one RK4 step of the
kinematic bicycle from the fixed ξ0 under an input inside its bounds, so the EV's
position there lies in a small set known before any solve. When that whole set lies
inside a vehicle's nominal ellipse, no plan exists at any risk: the solvers (fatrop, then
IPOPT from the same guess) can only fail, at 20–50 ms per row on recorded lane changes
another vehicle drives into the region of (RESULTS §15), and the planner's answer is the
failed plan's, known without them.

The set. One RK4 step with the input u = [a, δ] held: each of the four slopes' position
part is v_i·(cos(φ_i + β), sin(φ_i + β)) with β = atan(l_r/(l_f + l_r)·tan δ),
v_i = v_0 + c_i·T_s·a and φ_i = φ_0 + c_i·T_s·(v_{i−1}/l_r)·sin β (c_i ∈ {0, ½, ½, 1}), and
the step is their weighted mean (weights 1/6, 2/6, 2/6, 1/6) times T_s. In the frame of
φ_0, slope i has speed v_i between v_0 + c_i·T_s·a_min and v_0 + c_i·T_s·a_max and
direction ψ_i ∈ [−Δ_i, Δ_i] with Δ_i = β_max + c_i·T_s·max|v|/l_r·sin β_max, so its
along-track part v·cos ψ and cross-track part v·sin ψ lie in the intervals spanned by the
corners of the speed interval × the range of cos ψ (resp. sin ψ) — a product of two
intervals takes its extremes at corners — and the mean lies in the weighted sum of the
four intervals. The set is inside the rectangle those sums span, and ‖z̄‖ is convex in
the position, so its largest value on the set is at most its largest at the rectangle's
four corners.

Soundness margins. The planner accepts a solver's point when every constraint holds to
1e-4 (:func:`~drivestyle.planning.smpc_problem.constraint_violation`): the input may
exceed its bounds, the stage-1 state its RK4 image and the margin zero by that much.
:data:`INPUT_SLACK`, :data:`POSITION_SLACK` and :data:`MARGIN_SLACK` cover each with a
factor of ten, so a row certified here is one the planner could never accept.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "INPUT_SLACK",
    "MARGIN_SLACK",
    "POSITION_SLACK",
    "coasting_inside",
    "stage_one_blocked",
    "stage_one_box",
]

INPUT_SLACK = 1e-3
"""Widening of the input bounds [m/s², rad]: 10× the accepted bound violation."""
POSITION_SLACK = 1e-3
"""Widening of the stage-1 position rectangle [m]: 10× the accepted dynamics defect."""
MARGIN_SLACK = 1e-3
"""A certified row's largest nominal margin ‖z̄_1‖ − 1 is below −MARGIN_SLACK."""
_RK4_NODES = (0.0, 0.5, 0.5, 1.0)
"""c_i: the heading of slope i has turned for c_i·T_s, its speed changed for c_i·T_s."""
_RK4_WEIGHTS = (1 / 6, 2 / 6, 2 / 6, 1 / 6)
"""RK4's weights of the four slopes."""


def stage_one_box(
    xi0: np.ndarray,
    u_lo: np.ndarray,
    u_hi: np.ndarray,
    T_s: float,
    l_f: float,
    l_r: float,
) -> np.ndarray:
    """Corners of a rectangle holding the EV's position after one RK4 step (module docstring).

    Args:
        xi0: ξ0 = [x, y, φ, v], shape (4,) [m, m, rad, m/s].
        u_lo: lower input bounds [a_min, −δ_max], shape (2,) [m/s², rad].
        u_hi: upper input bounds [a_max, δ_max], shape (2,).
        T_s: step length [s].
        l_f: centre of mass to front axle [m].
        l_r: centre of mass to rear axle [m].

    Returns:
        The four corners (x, y), shape (4, 2) [m], widened by :data:`POSITION_SLACK`.
    """
    x0, y0, phi0, v0 = (float(c) for c in xi0)
    a_lo, d_lo = float(u_lo[0]) - INPUT_SLACK, float(u_lo[1]) - INPUT_SLACK
    a_hi, d_hi = float(u_hi[0]) + INPUT_SLACK, float(u_hi[1]) + INPUT_SLACK
    beta = math.atan(l_r / (l_f + l_r) * math.tan(min(max(abs(d_lo), abs(d_hi)), 1.5)))
    v_top = max(abs(v0 + a_lo * T_s), abs(v0 + a_hi * T_s), abs(v0))
    a_min = a_max = c_min = c_max = 0.0
    for c, weight in zip(_RK4_NODES, _RK4_WEIGHTS, strict=True):
        speeds = (v0 + c * T_s * a_lo, v0 + c * T_s * a_hi)
        # the heading's own slack: ξ0 holds to the accepted equality violation
        turn = min(beta + c * T_s * v_top / l_r * math.sin(beta) + INPUT_SLACK, math.pi)
        side = math.sin(turn) if turn < math.pi / 2 else 1.0
        along = [v * k for v in speeds for k in (math.cos(turn), 1.0)]
        cross = [v * k for v in speeds for k in (-side, side)]
        a_min += weight * min(along)
        a_max += weight * max(along)
        c_min += weight * min(cross)
        c_max += weight * max(cross)
    a_min, a_max = T_s * a_min - POSITION_SLACK, T_s * a_max + POSITION_SLACK
    c_min, c_max = T_s * c_min - POSITION_SLACK, T_s * c_max + POSITION_SLACK
    local = np.array([[a_min, c_min], [a_min, c_max], [a_max, c_min], [a_max, c_max]])
    cos_p, sin_p = math.cos(phi0), math.sin(phi0)
    x = x0 + cos_p * local[:, 0] - sin_p * local[:, 1]
    y = y0 + sin_p * local[:, 0] + cos_p * local[:, 1]
    return np.column_stack((x, y))


def stage_one_blocked(
    corners: np.ndarray, vehicles: np.ndarray, T_s: float, l_a: float, l_b: float
) -> bool:
    """Whether every stage-1 position lies inside some vehicle's nominal ellipse.

    The vehicles are predicted at constant velocity, as the NLP predicts them
    (:func:`~drivestyle.planning.smpc_problem._ellipse_margins`): the centre at stage 1 is
    (x + v·cos φ·T_s, y + v·sin φ·T_s), the ellipse axis-aligned with semi-axes l_a, l_b.

    Args:
        corners: :func:`stage_one_box`, shape (4, 2) [m].
        vehicles: the constrained vehicles' states, shape (M, 4) [m, m, rad, m/s].
        T_s: step length [s].
        l_a: semi-major axis [m].
        l_b: semi-minor axis [m].

    Returns:
        True when, for one vehicle, ‖z̄_1‖ − 1 < −:data:`MARGIN_SLACK` at all four corners
        (then at every point of the rectangle: ‖z̄‖ is convex). A plan needs the margin
        ≥ 0 against every vehicle, so one such vehicle rules every plan out.
    """
    veh = np.asarray(vehicles, dtype=float).reshape(-1, 4)
    cx = veh[:, 0] + veh[:, 3] * np.cos(veh[:, 2]) * T_s
    cy = veh[:, 1] + veh[:, 3] * np.sin(veh[:, 2]) * T_s
    z1 = (corners[None, :, 0] - cx[:, None]) / l_a
    z2 = (corners[None, :, 1] - cy[:, None]) / l_b
    largest = np.sqrt(z1 * z1 + z2 * z2).max(axis=1)
    return bool(np.any(largest - 1.0 < -MARGIN_SLACK))


def coasting_inside(
    xi0: np.ndarray, vehicles: np.ndarray, T_s: float, l_a: float, l_b: float
) -> bool:
    """Whether the EV coasting one step (u = 0) ends inside some vehicle's nominal ellipse.

    With u = 0 the RK4 step is exact, ξ0's position plus v·T_s along φ, and u = 0 lies
    inside every scenario's input bounds, so that point is in :func:`stage_one_box`'s
    rectangle: a row can only be :func:`stage_one_blocked` when this holds. It costs a
    few float operations, where the rectangle costs tens of microseconds, and it is false
    on nearly every row a driver of the class plans (RESULTS §15), so it screens them.

    Args:
        xi0: ξ0 = [x, y, φ, v], shape (4,) [m, m, rad, m/s].
        vehicles: the constrained vehicles' states, flat (4M,) or (M, 4).
        T_s: step length [s].
        l_a: semi-major axis [m].
        l_b: semi-minor axis [m].

    Returns:
        True when ‖z̄_1‖ < 1 − :data:`MARGIN_SLACK` at the coasting position for a vehicle.
    """
    x0, y0, phi0, v0 = np.asarray(xi0, dtype=float)[:4].tolist()
    px, py = x0 + v0 * math.cos(phi0) * T_s, y0 + v0 * math.sin(phi0) * T_s
    flat = np.asarray(vehicles, dtype=float).ravel().tolist()
    limit = (1.0 - MARGIN_SLACK) ** 2
    for j in range(0, len(flat) - 3, 4):
        x, y, phi, v = flat[j : j + 4]
        dx = (px - x - v * math.cos(phi) * T_s) / l_a
        dy = (py - y - v * math.sin(phi) * T_s) / l_b
        if dx * dx + dy * dy < limit:
            return True
    return False
