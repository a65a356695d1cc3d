"""The inner problem of ME-IRL: r*_θ = argmin_r θᵀ f(r) over c_1 … c_S (§II-C2, docs/DESIGN.md §6).

The features split into a longitudinal group (f_ax, f_v, f_tiv: x spline only) and a lateral group
(the rest: y spline only), so the inner problem separates into two unconstrained problems of 3S
variables each. Each is solved by a damped Newton method with the exact gradient and Hessian that
CasADi derives from :func:`drivestyle.irl.paper.features.feature_values` (|·| smoothed),
warm-started from the previous solution. The same Hessian H and feature Jacobian J give the
sensitivity of the optimum used by the learner,

    ∂f(r*_θ)/∂θ = −J H⁻¹ Jᵀ     (implicit function theorem on ∇_c θᵀf = 0).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.paper.features import (
    FEATURES,
    X_FEATURES,
    FeatureBasis,
    FeatureConfig,
    feature_basis,
    feature_values,
)
from drivestyle.irl.paper.spline import demo_control_points
from drivestyle.planning.buffered import BufferedFunction

__all__ = ["InnerProblem", "InnerSolution", "InnerSolveError", "newton_minimize"]


class InnerSolveError(RuntimeError):
    """The inner optimisation did not converge."""


def newton_minimize(
    fgh, z0: np.ndarray, tol: float = 1e-9, max_iter: int = 100, f=None
) -> tuple[np.ndarray, int, bool]:
    """Minimise a smooth function by damped Newton steps.

    Levenberg damping makes the Newton matrix positive definite; an Armijo backtracking
    line search globalises.

    Args:
        fgh: z ↦ (value, gradient (n,), Hessian (n, n)).
        z0: starting point, shape (n,).
        tol: stop when ‖∇‖_∞ ≤ tol · (1 + |value|).
        max_iter: iteration cap.
        f: z ↦ value alone, for the line search's trial points (derivatives are then
            evaluated at accepted points only: a trial costs a fraction of a Hessian).

    Returns:
        (minimiser, iterations, converged).
    """
    f_only = f
    z = np.array(z0, dtype=float)
    f, g, H = fgh(z)
    n = z.size
    eye = np.eye(n)
    for it in range(max_iter):
        if not np.isfinite(f) or not np.all(np.isfinite(g)):
            return z, it, False
        if np.max(np.abs(g)) <= tol * (1.0 + abs(f)):
            return z, it, True
        mu, scale = 0.0, 1e-10 * (1.0 + np.max(np.abs(np.diag(H))))
        while True:  # smallest damping that makes the Newton matrix positive definite
            try:
                factor = cho_factor(H + mu * eye if mu else H, check_finite=False)
                break
            except LinAlgError:
                mu = max(4 * mu, scale)
        p = -cho_solve(factor, g, check_finite=False)
        slope = float(g @ p)
        if -slope <= 1e-13 * (1.0 + abs(f)):  # Newton decrement at round-off level
            return z, it, True
        step = 1.0
        while step > 1e-12:
            z_new = z + step * p
            if f_only is None:
                f_new, g_new, H_new = fgh(z_new)
            else:
                f_new = f_only(z_new)
            if np.isfinite(f_new) and f_new <= f + 1e-4 * step * slope:
                break
            step *= 0.5
        else:
            return z, it, bool(np.max(np.abs(g)) <= 1e3 * tol * (1.0 + abs(f)))
        if f_only is not None:
            f_new, g_new, H_new = fgh(z_new)
        if abs(f - f_new) <= 1e-15 * (1.0 + abs(f)) and step < 1e-6:
            return z_new, it + 1, True
        z, f, g, H = z_new, f_new, g_new, H_new
    return z, max_iter, False


@dataclass(frozen=True)
class InnerSolution:
    """Result of one inner solve."""

    control_points: np.ndarray
    """c_0 … c_S of r*_θ, shape (S+1, 6)."""
    features: np.ndarray
    """Exact scaled features Ω f(r*_θ) of the active set."""
    sensitivity: np.ndarray
    """∂f(r*_θ)/∂θ, shape (m, m) (smoothed features)."""
    iterations: int
    """Newton iterations (both groups)."""
    solve_ms: float
    """Wall time [ms]."""


class InnerProblem:
    """The inner problem for one demonstration, built once and warm-started.

    Args:
        demo: the demonstration (knots = its sample times; c_0 from its first sample).
        config: feature configuration (active set, constants).
        control_point_rule: how the demonstration's control points are derived
            (``drivestyle.irl.paper.spline.demo_control_points``).
        control_points: the demonstration's control points, shape (n, 6), instead of
            deriving them by ``control_point_rule`` (e.g. a trajectory that is itself a spline).
    """

    def __init__(
        self,
        demo: Demonstration,
        config: FeatureConfig | None = None,
        control_point_rule: str = "kinematic",
        control_points: np.ndarray | None = None,
    ) -> None:
        self.demo = demo
        self.config = config or FeatureConfig()
        self.control_point_rule = control_point_rule
        self.basis: FeatureBasis = feature_basis(demo, self.config)
        if control_points is None:
            self.C_demo = demo_control_points(demo, control_point_rule)
        else:
            C = np.asarray(control_points, dtype=float)
            if C.shape != (demo.n, 6) or not np.all(np.isfinite(C)):
                raise ValueError(
                    f"control_points must be finite with shape ({demo.n}, 6), got {C.shape}"
                )
            self.C_demo = C.copy()
        self.names = self.config.names
        self.S = demo.n - 1
        self.groups = {
            "x": [n for n in self.names if n in X_FEATURES],
            "y": [n for n in self.names if n not in X_FEATURES],
        }
        self.f_demo = self.features_of(self.C_demo)
        self._build()
        self.reset()

    def _build(self) -> None:
        n = 3 * self.S
        c0 = self.C_demo[0]
        self._fns = {}
        for axis, names in self.groups.items():
            z = ca.SX.sym(f"z{axis}", n)
            th = ca.SX.sym("theta", len(names))
            full = ca.vertcat(ca.DM(c0[:3] if axis == "x" else c0[3:]), z)
            cx, cy = (
                (full, ca.DM.zeros(3 * (self.S + 1)))
                if axis == "x"
                else (ca.DM.zeros(3 * (self.S + 1)), full)
            )
            f = feature_values(cx, cy, self.basis, smooth=True, names=names)
            obj = ca.dot(th, f)
            H, grad = ca.hessian(obj, z)
            fgh = ca.Function(f"fgh_{axis}", [z, th], [obj, grad, ca.densify(H)])
            fj = ca.Function(f"fJ_{axis}", [z], [f, ca.densify(ca.jacobian(f, z))])
            fo = ca.Function(f"f_{axis}", [z, th], [obj])
            self._fns[axis] = (BufferedFunction(fgh), BufferedFunction(fj), BufferedFunction(fo))

    def reset(self) -> None:
        """Warm start from the demonstration's own control points."""
        self._z = {"x": self.C_demo[1:, :3].ravel().copy(), "y": self.C_demo[1:, 3:].ravel().copy()}

    @property
    def warm_start(self) -> dict[str, np.ndarray]:
        """The current warm start (copy), to restore after a rejected trial θ."""
        return {k: v.copy() for k, v in self._z.items()}

    @warm_start.setter
    def warm_start(self, state: dict[str, np.ndarray]) -> None:
        self._z = {k: v.copy() for k, v in state.items()}

    def features_of(self, C: np.ndarray) -> np.ndarray:
        """Exact scaled features of the active set for control points C (S+1, 6)."""
        return feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), self.basis, names=self.names)

    def solve(self, theta: np.ndarray, tol: float = 1e-9, max_iter: int = 100) -> InnerSolution:
        """r*_θ, its features and their sensitivity to θ.

        Args:
            theta: weights of the active features (positive), shape (m,).
            tol: Newton tolerance.
            max_iter: Newton iteration cap per group.

        Returns:
            The solution.

        Raises:
            InnerSolveError: Newton did not converge (the message names the group and θ).
        """
        theta = np.asarray(theta, float)
        m = len(self.names)
        if theta.shape != (m,) or not np.all(np.isfinite(theta)) or np.any(theta <= 0):
            raise ValueError(f"theta must be {m} positive finite weights, got {theta}")
        t0 = time.perf_counter()
        sens = np.zeros((m, m))
        iters = 0
        C = self.C_demo.copy()
        for axis, names in self.groups.items():
            if not names:
                continue
            idx = [self.names.index(n) for n in names]
            th = theta[idx]
            fgh_fn, fj_fn, f_fn = self._fns[axis]

            def fgh(z, fn=fgh_fn, th=th):
                o, g, H = fn(z, th)
                return float(o[0]), g, H

            def f_only(z, fn=f_fn, th=th):
                return float(fn(z, th)[0][0])

            z, it, ok = newton_minimize(fgh, self._z[axis], tol, max_iter, f_only)
            iters += it
            if not ok:
                raise InnerSolveError(
                    f"inner problem ({axis} group: {names}) did not converge in {it} Newton "
                    f"iterations for theta={np.round(th, 6).tolist()}"
                )
            self._z[axis] = z
            _, _, H = fgh(z)
            _, J = fj_fn(z)
            try:
                HinvJt = cho_solve(cho_factor(H, check_finite=False), J.T)
            except LinAlgError:  # singular or indefinite at a degenerate optimum
                HinvJt = np.linalg.lstsq(H, J.T, rcond=None)[0]
            sens[np.ix_(idx, idx)] = -J @ HinvJt
            cols = slice(0, 3) if axis == "x" else slice(3, 6)
            C[1:, cols] = z.reshape(self.S, 3)
        features = self.features_of(C)
        return InnerSolution(C, features, sens, iters, (time.perf_counter() - t0) * 1e3)

    @property
    def feature_index(self) -> np.ndarray:
        """Indices of the active features in :data:`drivestyle.irl.paper.features.FEATURES`."""
        return np.array([FEATURES.index(n) for n in self.names])
