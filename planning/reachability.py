"""Where the EV can be one step ahead, and plans that cannot exist (DESIGN §16).

Every plan of the style's NLP must keep the EV outside each constrained vehicle's nominal
ellipse from stage 1 on (‖z̄_1‖ − 1 ≥ 0, :mod:`drivestyle.planning.description`; a hard
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
1e-4 (:func:`~drivestyle.planning.description.constraint_violation`): the input may
exceed its bounds, the stage-1 state its RK4 image and the margin zero by that much.
:data:`INPUT_SLACK`, :data:`POSITION_SLACK` and :data:`MARGIN_SLACK` cover each with a
factor of ten, so a row certified here is one the planner could never accept.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "COVER_DEPTH",
    "INPUT_SLACK",
    "MARGIN_SLACK",
    "POSITION_SLACK",
    "box_blocked",
    "coasting_stages",
    "covered",
    "reachable_boxes",
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
    """Whether every stage-1 position lies inside the nominal ellipses (:func:`covered`).

    The vehicles are predicted at constant velocity, as the NLP predicts them
    (:func:`~drivestyle.planning.transcription.ellipse_margins`): the centre at stage 1 is
    (x + v·cos φ·T_s, y + v·sin φ·T_s), the ellipse axis-aligned with semi-axes l_a, l_b.

    Args:
        corners: :func:`stage_one_box`, shape (4, 2) [m].
        vehicles: the constrained vehicles' states, flat (4M,) or (M, 4) [m, m, rad, m/s].
        T_s: step length [s].
        l_a: semi-major axis [m].
        l_b: semi-minor axis [m].

    Returns:
        True when the rectangle is covered: a plan needs the margin ≥ 0 against every
        vehicle, so a stage-1 position inside any one ellipse rules it out.
    """
    c = np.asarray(corners, dtype=float)
    return covered(c[0], c[2] - c[0], c[1] - c[0], _centres(vehicles, T_s), l_a, l_b)


def _centres(vehicles: np.ndarray, t: float) -> np.ndarray:
    """The vehicles' predicted centres at time t (constant velocity), shape (M, 2)."""
    veh = np.asarray(vehicles, dtype=float).reshape(-1, 4)
    return np.column_stack((veh[:, 0] + veh[:, 3] * np.cos(veh[:, 2]) * t,
                            veh[:, 1] + veh[:, 3] * np.sin(veh[:, 2]) * t))  # fmt: skip


COVER_DEPTH = 3
"""Halvings of a parallelogram per side :func:`covered` tries (at most 8 × 8 cells)."""


def covered(
    origin: np.ndarray,
    e1: np.ndarray,
    e2: np.ndarray,
    centres: np.ndarray,
    l_a: float,
    l_b: float,
    depth: int = COVER_DEPTH,
) -> bool:
    """Whether the union of the ellipses covers the parallelogram origin + [0,1]e1 + [0,1]e2.

    A cell is covered when its four corners are inside one ellipse by
    :data:`MARGIN_SLACK` (‖z̄‖ is convex, so then all of it is); a cell no single ellipse
    covers is halved along both edges, up to ``depth`` times. Two vehicles whose
    ellipses overlap can rule out a set neither covers alone (the EV between a leader
    and a vehicle beside it). Sound: True only when every cell of a partition is covered.

    Args:
        origin: a corner, shape (2,) [m].
        e1: first edge, shape (2,) [m].
        e2: second edge, shape (2,) [m].
        centres: the ellipses' centres, shape (M, 2) [m].
        l_a: semi-major axis (along x) [m].
        l_b: semi-minor axis (along y) [m].
        depth: halvings allowed.

    Returns:
        True when covered.
    """
    scale = np.array([1.0 / l_a, 1.0 / l_b])
    limit = (1.0 - MARGIN_SLACK) ** 2
    unit = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    cells = np.asarray(origin, dtype=float)[None]  # each cell's origin
    size = 1.0
    edges = np.vstack((e1, e2)).astype(float)  # (2, 2)
    for level in range(depth + 1):
        # corners of every cell: (cells, 4, 2); their ‖z̄‖² from every centre: (cells, M, 4)
        corners = cells[:, None, :] + size * unit @ edges
        z = (corners[:, None, :, :] - centres[None, :, None, :]) * scale
        inside = (np.sum(z * z, axis=-1) < limit).all(axis=2).any(axis=1)
        open_cells = cells[~inside]
        if open_cells.size == 0:
            return True
        if level == depth:
            return False
        size /= 2
        halves = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]) * size @ edges
        cells = (open_cells[:, None, :] + halves[None]).reshape(-1, 2)
    return False


def coasting_stages(
    xi0: np.ndarray, vehicles: np.ndarray, T_s: float, l_a: float, l_b: float, stages: int
) -> list[int]:
    """The stages k = 1 … ``stages`` at which the EV coasting (u = 0) is inside an ellipse.

    With u = 0 the RK4 step is exact — the EV moves straight at constant speed — and u = 0
    lies inside every scenario's input bounds, so the coasting position is in
    :func:`stage_one_box`'s rectangle and, where it respects the state bounds, in every
    stage's reachable set: a stage can only be :func:`stage_one_blocked` or
    :func:`box_blocked` when it is listed here. Each vehicle is predicted at constant
    velocity, as the NLP predicts it. The list costs a few float operations per vehicle,
    where a rectangle costs tens of microseconds, and it is empty on most rows a driver of
    the class plans (1,836 of 2,040 in four simulated identifications), so it screens the
    rows worth a certificate.

    Returns:
        The stages, increasing (empty on most rows a driver of the class plans).
    """
    x0, y0, phi0, v0 = np.asarray(xi0, dtype=float)[:4].tolist()
    flat = np.asarray(vehicles, dtype=float).ravel().tolist()
    limit = (1.0 - MARGIN_SLACK) ** 2
    ex, ey = v0 * math.cos(phi0) * T_s, v0 * math.sin(phi0) * T_s
    # the offset to each vehicle is r0 + k·w (both move straight): its smallest norm over
    # k in [1, stages] in closed form first, as most rows are never inside
    near = False
    for j in range(0, len(flat) - 3, 4):
        x, y, phi, v = flat[j : j + 4]
        r1, r2 = (x0 - x) / l_a, (y0 - y) / l_b
        w1, w2 = (ex - v * math.cos(phi) * T_s) / l_a, (ey - v * math.sin(phi) * T_s) / l_b
        ww = w1 * w1 + w2 * w2
        k = min(max(-(r1 * w1 + r2 * w2) / ww, 1.0), float(stages)) if ww > 0 else 1.0
        d1, d2 = r1 + k * w1, r2 + k * w2
        if d1 * d1 + d2 * d2 < limit * (1 + 1e-9):  # round-off: the loop below decides
            near = True
            break
    if not near:
        return []
    inside = []
    for k in range(1, stages + 1):
        px, py = x0 + k * ex, y0 + k * ey
        for j in range(0, len(flat) - 3, 4):
            x, y, phi, v = flat[j : j + 4]
            dx = (px - x - v * math.cos(phi) * k * T_s) / l_a
            dy = (py - y - v * math.sin(phi) * k * T_s) / l_b
            if dx * dx + dy * dy < limit:
                inside.append(k)
                break
    return inside


def _product(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """The interval product [a]·[b] (its extremes are at corners)."""
    c = (a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1])
    return min(c), max(c)


def _cos_range(lo: float, hi: float) -> tuple[float, float]:
    """Cos over [lo, hi] (|lo|, |hi| < π)."""
    top = 1.0 if lo <= 0.0 <= hi else max(math.cos(lo), math.cos(hi))
    return min(math.cos(lo), math.cos(hi)), top


def _sin_range(lo: float, hi: float) -> tuple[float, float]:
    """Sin over [lo, hi] (|lo|, |hi| < π)."""
    bottom = -1.0 if lo <= -math.pi / 2 else math.sin(lo)
    top = 1.0 if hi >= math.pi / 2 else math.sin(hi)
    return bottom, top


def reachable_boxes(
    xi0: np.ndarray,
    u_lo: np.ndarray,
    u_hi: np.ndarray,
    state_lo: np.ndarray,
    state_hi: np.ndarray,
    T_s: float,
    l_f: float,
    l_r: float,
    stages: int,
) -> np.ndarray:
    """Road-frame boxes holding the EV's position at stages 1 … ``stages`` (interval RK4).

    Interval arithmetic on the RK4 map, stage by stage: from state intervals (x, y, φ, v),
    slope i is evaluated at a heading within c_i·T_s·ω of φ's interval (ω = max|v|/l_r ·
    sin β_max bounds the yaw rate) and a speed within c_i·T_s·a of v's, points in a
    direction within β_max of that heading, and adds speed × cos (resp. sin) of the
    direction, as interval products, with RK4's weights. After each step the heading,
    speed and lateral intervals are cut to the state bounds, which every plan keeps at
    stages 1 … N. Every interval is widened per stage by the slacks of the module
    docstring. Looser than :func:`stage_one_box` (it forgets how heading and displacement
    go together) but good for any stage.

    Args:
        xi0: ξ0 = [x, y, φ, v], shape (4,) [m, m, rad, m/s].
        u_lo: lower input bounds [a_min, −δ_max], shape (2,).
        u_hi: upper input bounds [a_max, δ_max], shape (2,).
        state_lo: lower state bounds of stages ≥ 1 [x, y, φ, v], shape (4,) (−inf: none).
        state_hi: upper state bounds, shape (4,).
        T_s: step length [s].
        l_f: centre of mass to front axle [m].
        l_r: centre of mass to rear axle [m].
        stages: K ≥ 1.

    Returns:
        Shape (K, 2, 2): per stage [[x_lo, x_hi], [y_lo, y_hi]] [m]; [[inf, −inf], [inf,
        −inf]] (empty) from the first stage no state within the bounds can reach.
    """
    a_lo, d_lo = float(u_lo[0]) - INPUT_SLACK, float(u_lo[1]) - INPUT_SLACK
    a_hi, d_hi = float(u_hi[0]) + INPUT_SLACK, float(u_hi[1]) + INPUT_SLACK
    beta = math.atan(l_r / (l_f + l_r) * math.tan(min(max(abs(d_lo), abs(d_hi)), 1.5)))
    # ξ0 holds to the accepted equality violation, the bounds to the accepted excess
    slack = np.array([POSITION_SLACK, POSITION_SLACK, INPUT_SLACK, INPUT_SLACK])
    start = np.asarray(xi0, dtype=float)[:4]
    lo, hi = (start - slack).tolist(), (start + slack).tolist()
    bound_lo = (np.asarray(state_lo, dtype=float) - slack).tolist()
    bound_hi = (np.asarray(state_hi, dtype=float) + slack).tolist()
    out = np.empty((stages, 2, 2))
    for k in range(stages):
        v_top = max(abs(lo[3] + a_lo * T_s), abs(hi[3] + a_hi * T_s), abs(lo[3]), abs(hi[3]))
        omega = v_top / l_r * math.sin(beta)
        dx = [0.0, 0.0]
        dy = [0.0, 0.0]
        for c, weight in zip(_RK4_NODES, _RK4_WEIGHTS, strict=True):
            speed = (lo[3] + c * T_s * min(a_lo, 0.0), hi[3] + c * T_s * max(a_hi, 0.0))
            turn = c * T_s * omega + beta
            th_lo, th_hi = lo[2] - turn, hi[2] + turn
            if th_hi - th_lo >= math.pi or max(abs(th_lo), abs(th_hi)) >= math.pi:
                cos_r = sin_r = (-1.0, 1.0)
            else:
                cos_r, sin_r = _cos_range(th_lo, th_hi), _sin_range(th_lo, th_hi)
            px, py = _product(speed, cos_r), _product(speed, sin_r)
            dx = [dx[0] + weight * px[0], dx[1] + weight * px[1]]
            dy = [dy[0] + weight * py[0], dy[1] + weight * py[1]]
        lo = [lo[0] + T_s * dx[0] - POSITION_SLACK, lo[1] + T_s * dy[0] - POSITION_SLACK,
              lo[2] - T_s * omega - INPUT_SLACK, lo[3] + T_s * a_lo - INPUT_SLACK]  # fmt: skip
        hi = [hi[0] + T_s * dx[1] + POSITION_SLACK, hi[1] + T_s * dy[1] + POSITION_SLACK,
              hi[2] + T_s * omega + INPUT_SLACK, hi[3] + T_s * a_hi + INPUT_SLACK]  # fmt: skip
        lo = [max(c, b) for c, b in zip(lo, bound_lo, strict=True)]
        hi = [min(c, b) for c, b in zip(hi, bound_hi, strict=True)]
        if any(h < low for low, h in zip(lo, hi, strict=True)):
            # no state within the bounds is reachable: this stage and every later one empty
            out[k:] = [[math.inf, -math.inf], [math.inf, -math.inf]]
            break
        out[k] = [[lo[0], hi[0]], [lo[1], hi[1]]]
    return out


def box_blocked(box: np.ndarray, vehicles: np.ndarray, t: float, l_a: float, l_b: float) -> bool:
    """Whether a road-frame box lies inside the vehicles' nominal ellipses at time t.

    Args:
        box: [[x_lo, x_hi], [y_lo, y_hi]] [m] (:func:`reachable_boxes`).
        vehicles: the constrained vehicles' states, flat (4M,) or (M, 4).
        t: the stage's time k·T_s [s] (the vehicles move at constant velocity).
        l_a: semi-major axis [m].
        l_b: semi-minor axis [m].

    Returns:
        True when :func:`covered`, or the box is empty (no state reaches the stage).
    """
    (x_lo, x_hi), (y_lo, y_hi) = np.asarray(box, dtype=float).tolist()
    if x_lo > x_hi or y_lo > y_hi:
        return True
    return covered(np.array([x_lo, y_lo]), np.array([x_hi - x_lo, 0.0]),
                   np.array([0.0, y_hi - y_lo]), _centres(vehicles, t), l_a, l_b)  # fmt: skip
