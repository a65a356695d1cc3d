"""A parameter box and its map to unconstrained space (DESIGN §22).

The flow lives on R^D; the parameters live in a box [low, high]. Each coordinate is mapped
by the logit of its position in the box,

    u = (θ − low) / (high − low),    z = logit(u) = log u − log(1 − u),

so every sample the flow draws maps back inside the box, θ = low + (high − low) σ(z), and
a density on z becomes one on θ by the change of variables

    log p(θ) = log q(z) + Σ_d log |dz_d/dθ_d|,   dz/dθ = 1 / ((high − low) u (1 − u)).

Pure numpy functions, computed in float64.
"""

from __future__ import annotations

import numpy as np

__all__ = ["EDGE", "check_box", "from_unconstrained", "log_abs_det", "to_unconstrained"]

EDGE = 1e-6
"""A position in the box is clipped to [EDGE, 1 − EDGE] before the logit: a parameter on
the box's edge maps to a finite z (|z| <= 13.8)."""


def check_box(low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The box's bounds as float64 arrays, checked (finite, same shape (D,), low < high).

    Raises:
        ValueError: the bounds are not a box.
    """
    lo = np.asarray(low, float)
    hi = np.asarray(high, float)
    if lo.ndim != 1 or lo.shape != hi.shape or lo.size == 0:
        raise ValueError(f"low and high must have one shape (D,), got {lo.shape} and {hi.shape}")
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError("the box's bounds must be finite")
    bad = np.flatnonzero(lo >= hi)
    if bad.size:
        raise ValueError(f"low must be below high; not for coordinate(s) {bad.tolist()}")
    return lo, hi


def _position(theta: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    u = (np.asarray(theta, float) - low) / (high - low)
    return np.clip(u, EDGE, 1.0 - EDGE)


def to_unconstrained(theta: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Unconstrained z = logit((θ − low) / (high − low)) of ``theta`` (..., D), per coordinate."""
    u = _position(theta, low, high)
    return np.log(u) - np.log1p(-u)


def from_unconstrained(z: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """θ = low + (high − low) σ(z), coordinate-wise: always inside the box."""
    u = 0.5 * (1.0 + np.tanh(0.5 * np.asarray(z, float)))  # σ(z) without overflow
    return low + (high - low) * u


def log_abs_det(theta: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Σ_d log |dz_d/dθ_d| of :func:`to_unconstrained` at ``theta`` (..., D): shape (...)."""
    u = _position(theta, low, high)
    return -np.sum(np.log(high - low) + np.log(u) + np.log1p(-u), axis=-1)
