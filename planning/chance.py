"""Chance-constrained collision avoidance: the tangent back-off (docs/DESIGN.md §3).

Pr(d_k ≥ 0) ≥ p with d_k = Δx²/l_a² + Δy²/l_b² − 1 and a Gaussian TV position
q ~ N(q̄, Σ) is replaced by the deterministic, conservative condition of Zhu &
Alonso-Mora (RA-L 2019): with Ω = diag(1/l_a², 1/l_b²), z̄ = Ω^½(p_EV − q̄),
n = z̄/‖z̄‖ and S = Ω^½ Σ Ω^½,

    g = ‖z̄‖ − 1 − Φ⁻¹(p) · sqrt(nᵀ S n) ≥ 0.                                  (DESIGN §3)

The collision ellipse lies inside the half-space nᵀz ≤ 1 tangent to it, and the
half-space constraint holds with probability exactly p when g = 0, so Pr(d ≥ 0) ≥ p for
every Σ. The functions evaluate on numpy arrays and on CasADi symbols alike.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import casadi as ca
import numpy as np

__all__ = ["chance_margin", "risk_quantile"]


def risk_quantile(p: float) -> float:
    """κ = Φ⁻¹(p), the standard-normal quantile of the risk parameter.

    Args:
        p: risk parameter, the required probability of staying outside the ellipse.

    Returns:
        κ (0 for p = 0.5, positive above).

    Raises:
        ValueError: p not in the open interval (0, 1).
    """
    if not (isinstance(p, (int, float)) and math.isfinite(p) and 0.0 < p < 1.0):
        raise ValueError(f"risk parameter p must lie in the open interval (0, 1), got {p!r}")
    return NormalDist().inv_cdf(float(p))


def chance_margin(dx, dy, sxx, sxy, syy, l_a: float | ca.SX, l_b: float, kappa: float | ca.SX):
    """Tangent back-off margin g (module docstring); the chance constraint is g ≥ 0.

    Args:
        dx: x_EV − x̄_TV [m] (numpy array or CasADi expression).
        dy: y_EV − ȳ_TV [m].
        sxx: Σ_xx of the TV position [m²].
        sxy: Σ_xy [m²].
        syy: Σ_yy [m²].
        l_a: semi-major axis [m] (a number, or a CasADi parameter: the style's region).
        l_b: semi-minor axis [m].
        kappa: Φ⁻¹(p), see :func:`risk_quantile` (or a CasADi parameter).

    Returns:
        g = ‖z̄‖ − 1 − κ sqrt(nᵀSn) [-], same type and shape as ``dx``.
    """
    sqrt = ca.sqrt if isinstance(dx, (ca.SX, ca.MX)) else np.sqrt
    z1 = dx / l_a
    z2 = dy / l_b
    norm = sqrt(z1 * z1 + z2 * z2)
    zsz = z1 * z1 * (sxx / l_a**2) + 2 * z1 * z2 * (sxy / (l_a * l_b)) + z2 * z2 * (syy / l_b**2)
    return norm - 1 - kappa * sqrt(zsz) / norm
