"""Safety geometry: the elliptical index, the ellipse constraint and vehicle overlap.

Pure numpy functions, vectorised over leading dimensions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "ellipse_constraint",
    "elliptical_index",
    "rectangles_overlap",
    "trigger_time",
    "vehicle_corners",
    "vehicles_overlap",
]


def elliptical_index(dx: ArrayLike, dy: ArrayLike, l_a: float, l_b: float) -> np.ndarray:
    """Elliptical index s_e = Δx²/l_a² + Δy²/l_b² (eq. 9).

    Args:
        dx: longitudinal distance x_EV − x_TV, any shape [m].
        dy: lateral distance y_EV − y_TV, same shape [m].
        l_a: semi-major axis [m].
        l_b: semi-minor axis [m].

    Returns:
        s_e, same shape as ``dx`` [-]. s_e < 1 means the EV is inside the ellipse.
    """
    dx = np.asarray(dx, dtype=float)
    dy = np.asarray(dy, dtype=float)
    return (dx / l_a) ** 2 + (dy / l_b) ** 2


def ellipse_constraint(dx: ArrayLike, dy: ArrayLike, l_a: float, l_b: float) -> np.ndarray:
    """Hard safety constraint value d_k = s_e − 1 (eq. 4); safe iff d_k ≥ 0.

    Args:
        dx: x_EV − x_TV [m].
        dy: y_EV − y_TV [m].
        l_a: semi-major axis [m].
        l_b: semi-minor axis [m].

    Returns:
        d_k, same shape as ``dx``.
    """
    return elliptical_index(dx, dy, l_a, l_b) - 1.0


def vehicle_corners(state: ArrayLike, length: float, width: float) -> np.ndarray:
    """Corners of a vehicle's rectangle, counter-clockwise from the front-left.

    Args:
        state: [x, y, φ, ...] of the vehicle centre, shape (≥3,) [m, m, rad].
        length: vehicle length [m].
        width: vehicle width [m].

    Returns:
        Corner positions, shape (4, 2) [m].
    """
    x, y, phi = (float(v) for v in np.asarray(state, dtype=float)[:3])
    c, s = np.cos(phi), np.sin(phi)
    half = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]
    rot = np.array([[c, -s], [s, c]])
    return half @ rot.T + [x, y]


def rectangles_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two convex quadrilaterals overlap (separating-axis theorem).

    Touching edges count as overlap, so a reported non-collision is a strict gap.

    Args:
        a: corners of the first rectangle in order, shape (4, 2) [m].
        b: corners of the second rectangle, shape (4, 2) [m].

    Returns:
        True if the interiors intersect or the boundaries touch.
    """
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.stack([-edges[:, 1], edges[:, 0]], axis=1)
        for n in normals:
            pa, pb = a @ n, b @ n
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def vehicles_overlap(
    a: np.ndarray, b: np.ndarray, size_a: np.ndarray, size_b: np.ndarray
) -> np.ndarray:
    """Whether pairs of vehicle rectangles overlap, many pairs at once.

    The separating-axis test of :func:`rectangles_overlap` on the rectangles
    :func:`vehicle_corners` gives (touching counts as overlap), vectorised over pairs: two
    rectangles are apart when, on one of the four edge normals, the distance of their
    centres exceeds the sum of their half extents.

    Args:
        a: [x, y, φ] of the first vehicle of each pair, shape (p, ≥3) [m, m, rad].
        b: [x, y, φ] of the second, shape (p, ≥3).
        size_a: [length, width] of the first, shape (p, 2) [m].
        size_b: [length, width] of the second, shape (p, 2) [m].

    Returns:
        Shape (p,) bool.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    half_a, half_b = np.asarray(size_a, float) / 2, np.asarray(size_b, float) / 2
    d = b[:, :2] - a[:, :2]
    apart = np.zeros(d.shape[0], bool)
    for phi in (a[:, 2], b[:, 2]):
        for axis in (np.column_stack([np.cos(phi), np.sin(phi)]),
                     np.column_stack([-np.sin(phi), np.cos(phi)])):  # fmt: skip
            reach = np.zeros(d.shape[0])
            for ang, half in ((a[:, 2], half_a), (b[:, 2], half_b)):
                along = np.abs(np.cos(ang) * axis[:, 0] + np.sin(ang) * axis[:, 1])
                across = np.abs(-np.sin(ang) * axis[:, 0] + np.cos(ang) * axis[:, 1])
                reach += half[:, 0] * along + half[:, 1] * across
            apart |= np.abs(np.sum(d * axis, axis=1)) > reach
    return ~apart


def trigger_time(t: ArrayLike, s_e: ArrayLike, lam: float) -> float | None:
    """Triggering time t_trg: the first sample at which s_e < λ (§III-B).

    Args:
        t: sample times, shape (n,) [s].
        s_e: elliptical index at those samples, shape (n,).
        lam: threshold λ.

    Returns:
        t_trg [s], or None if s_e never drops below λ (the reactive features are then
        inactive).
    """
    below = np.flatnonzero(np.asarray(s_e) < lam)
    return float(np.asarray(t)[below[0]]) if below.size else None
