"""ME-IRL learner (paper §II-C2; docs/DESIGN.md §6).

It finds θ whose optimal trajectory reproduces the demonstrations' features.

Learning error ε = ‖f(r*_θ) − f(r_D)‖₂ on scaled features, with f averaged over the
demonstrations (and r*_θ solved in each demonstration's own scenario). Two update rules:

- ``"paper"``: θ ← max(θ + α (f(r*_θ) − f(r_D)), θ_min), stopping when
  |ε_i − ε_{i−1}| < ε̄ (the paper's rule; needs a tuned α).
- ``"lm"`` (default): Levenberg–Marquardt in φ = log θ on the relative errors
  e = (f(r*_θ) − f(r_D)) / max(|f(r_D)|, f_floor) with the exact sensitivity of the
  optimum ∂f(r*)/∂θ = −J H⁻¹ Jᵀ and a weak prior ‖φ − φ_0‖² that fixes the gauge (θ is
  identifiable only up to one scale per feature group, since x and y features never
  interact). It stops when the relative decrease of the cost is below ``tol``.

Both report θ normalised per group (x group: ax, v, tiv; y group: the rest) so that
styles are comparable.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from drivestyle.envs.demonstration import Demonstration, DemonstrationError
from drivestyle.irl.features import X_FEATURES, FeatureConfig
from drivestyle.irl.inner import InnerProblem, InnerSolution
from drivestyle.irl.metrics import trajectory_errors

__all__ = ["IRLConfig", "LearningResult", "MaxEntIRL", "check_learnable", "normalise_theta"]

UPDATE_RULES = ("lm", "paper")
"""Outer updates: Levenberg–Marquardt in log θ (default) or the paper's gradient rule."""


@dataclass(frozen=True)
class IRLConfig:
    """Outer-loop settings."""

    method: str = "lm"
    """'lm' (Levenberg–Marquardt in log θ, default) or 'paper' (gradient rule)."""
    max_iter: int = 60
    """Outer iteration cap ('paper' needs several hundred: use e.g. 400)."""
    epsilon_bar: float = 0.01
    """ε̄: the paper's termination threshold on |ε_i − ε_{i−1}|."""
    alpha: float = 3e-4
    """α: learning rate of the paper's rule."""
    theta_min: float = 1e-6
    """Floor that keeps θ positive under the paper's rule."""
    tol: float = 1e-4
    """LM: stop when the cost decreases by less than this fraction."""
    f_floor: float = 0.05
    """Floor of the relative-error denominators (scaled-feature units)."""
    prior: float = 1e-4
    """Weight of the gauge prior on log θ (LM)."""
    lm_lambda: float = 1e-2
    """Initial LM damping."""
    inner_tol: float = 1e-9
    """Newton tolerance of the inner problem."""

    def __post_init__(self) -> None:
        if self.method not in UPDATE_RULES:
            raise ValueError(f"method must be one of {UPDATE_RULES}, got {self.method!r}")
        if not (isinstance(self.max_iter, int) and self.max_iter >= 1):
            raise ValueError(f"max_iter must be a positive integer, got {self.max_iter!r}")
        for name in (
            "epsilon_bar",
            "alpha",
            "theta_min",
            "tol",
            "f_floor",
            "lm_lambda",
            "inner_tol",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(self.prior) and self.prior >= 0):
            raise ValueError(f"prior must be >= 0, got {self.prior!r}")


def normalise_theta(theta: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """θ divided by its group's sum (x group and y group separately): the gauge-free style."""
    theta = np.asarray(theta, float).copy()
    for group in (X_FEATURES, None):
        mask = np.array([(n in X_FEATURES) == (group is not None) for n in names])
        if mask.any():
            theta[mask] /= theta[mask].sum()
    return theta


MIN_TRAVEL_M = 1.0
"""A demonstration whose EV travels less than this does not show a driving style."""
MIN_LANE_CHANGE_PROGRESS = 0.1
"""Least lateral progress towards the target lane centre, as a fraction of the distance
between the lane centres, that makes a lane change. SMPC demonstrations that wait for the
TV still reach ≥ 20 % within the horizon (180 random-family draws, all six grid risks);
an EV keeping its lane with a ±0.3 m drift stays below 6 %."""


def check_learnable(demo: Demonstration) -> None:
    """Reject demonstrations that cannot show a lane-change style (DESIGN §5, §8).

    A learnable demonstration has a scenario in its metadata, is sampled on that
    scenario's grid T_s (the features' event times, windows and the reward's steps are in
    seconds), shows the EV moving, and shows a lane change: enough lateral
    progress towards the target lane (:data:`MIN_LANE_CHANGE_PROGRESS`; an SMPC that waits
    for the TV within the horizon has begun its lane change, an EV keeping its lane has not).

    Args:
        demo: the demonstration.

    Raises:
        DemonstrationError: the message names which condition fails, with the numbers.
    """
    sc = demo.scenario
    dt = np.diff(demo.t)
    if not np.allclose(dt, sc.dt, rtol=1e-6, atol=1e-9):
        raise DemonstrationError(
            f"the demonstration is sampled every {float(np.median(dt)):g} s but its scenario's "
            f"T_s is {sc.dt:g} s; resample it to T_s (times rescaled or mixed up?)"
        )
    travel = float(np.hypot(*np.ptp(demo.ev[:, :2], axis=0)))
    if travel < MIN_TRAVEL_M:
        raise DemonstrationError(
            f"the EV moves only {travel:.2f} m in {float(demo.t[-1] - demo.t[0]):g} s: "
            "a standing vehicle shows no driving style"
        )
    if sc.ev_lane == sc.target_lane:
        raise DemonstrationError(
            f"the scenario is not a lane change (ev_lane == target_lane == {sc.ev_lane})"
        )
    y0, y1 = float(sc.lane_centres[sc.ev_lane]), sc.y_ref
    toward = (demo.ev[:, 1] - y0) * np.sign(y1 - y0)
    progress = float(toward.max()) / abs(y1 - y0)
    if progress < MIN_LANE_CHANGE_PROGRESS:
        raise DemonstrationError(
            f"no lane change: the EV moves at most {max(float(toward.max()), 0.0):.2f} m towards "
            f"lane {sc.target_lane} ({progress:.0%} of the way from its lane centre to the "
            f"target's; a lane change needs at least {MIN_LANE_CHANGE_PROGRESS:.0%})"
        )


@dataclass
class LearningResult:
    """Outcome of :meth:`MaxEntIRL.learn`."""

    names: tuple[str, ...]
    theta: np.ndarray
    theta_normalised: np.ndarray
    iterations: int
    converged: bool
    learning_error: float
    feature_values_demo: np.ndarray
    feature_values_reproduced: np.ndarray
    solutions: list[InnerSolution]
    history: list[dict[str, Any]] = field(default_factory=list)
    wall_time_s: float = 0.0
    inner_solve_ms: list[float] = field(default_factory=list)
    errors: list[dict[str, float | None]] = field(default_factory=list)


class MaxEntIRL:
    """ME-IRL over one or several demonstrations (features averaged).

    Args:
        demos: the demonstrations (each with ``meta["scenario"]``).
        features: feature configuration (active set and constants), or one per
            demonstration (same active set; e.g. recorded episodes with their own lanes).
        config: outer-loop settings.
        control_point_rule: how the demonstrations' control points are derived
            (``drivestyle.irl.spline``).
        control_points: per demonstration, control points to use instead of the rule.
    """

    def __init__(
        self,
        demos: Demonstration | Sequence[Demonstration],
        features: FeatureConfig | Sequence[FeatureConfig] | None = None,
        config: IRLConfig | None = None,
        control_point_rule: str = "kinematic",
        control_points: Sequence[np.ndarray] | None = None,
    ) -> None:
        demos = [demos] if isinstance(demos, Demonstration) else list(demos)
        if not demos:
            raise ValueError("need at least one demonstration")
        for i, demo in enumerate(demos):
            try:
                check_learnable(demo)
            except DemonstrationError as exc:
                what = (
                    f"demonstration {i + 1} of {len(demos)}"
                    if len(demos) > 1
                    else "the demonstration"
                )
                raise DemonstrationError(f"cannot learn from {what}: {exc}") from None
        if control_points is not None and len(control_points) != len(demos):
            raise ValueError("control_points needs one array per demonstration")
        if isinstance(features, (list, tuple)):  # one configuration per demonstration
            per_demo = list(features)
            if len(per_demo) != len(demos):
                raise ValueError("features needs one FeatureConfig per demonstration")
            if len({f.names for f in per_demo}) != 1:
                raise ValueError("all per-demonstration feature configs need the same set")
        else:
            per_demo = [features or FeatureConfig()] * len(demos)
        self.features = per_demo[0]
        self.config = config or IRLConfig()
        cps = list(control_points) if control_points is not None else [None] * len(demos)
        self.problems = [
            InnerProblem(d, f, control_point_rule, c)
            for d, f, c in zip(demos, per_demo, cps, strict=True)
        ]
        self.names = self.features.names
        self.f_demo = np.mean([p.f_demo for p in self.problems], axis=0)

    def _evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[InnerSolution]]:
        sols = [p.solve(theta, tol=self.config.inner_tol) for p in self.problems]
        f = np.mean([s.features for s in sols], axis=0)
        sens = np.mean([s.sensitivity for s in sols], axis=0)
        return f, sens, sols

    def _record(self, history, it, theta, f, sols) -> dict[str, Any]:
        errs = [
            trajectory_errors(
                s.control_points[:, [0, 3]], p.demo, p.basis.events.t_trg, p.basis.events.t_rct_end
            )
            for s, p in zip(sols, self.problems, strict=True)
        ]
        entry = {
            "iteration": it,
            "theta": theta.tolist(),
            "epsilon": float(np.linalg.norm(f - self.f_demo)),
            "rmse_y_m": float(np.mean([e["rmse_y_m"] for e in errs])),
            "control_points": [s.control_points for s in sols],
        }
        history.append(entry)
        return entry

    def learn(
        self,
        theta0: np.ndarray | None = None,
        progress: Callable[[dict[str, Any]], None] | None = None,
    ) -> LearningResult:
        """Run the outer loop.

        Args:
            theta0: initial weights (default: 1/max(|f_D|, f_floor) for 'lm', 1 for
                'paper').
            progress: called with each iteration's history entry.

        Returns:
            The learning result; ``history[i]["control_points"]`` holds the reproduction
            at iteration i (iteration 1 is the initial θ).
        """
        cfg = self.config
        scale = np.maximum(np.abs(self.f_demo), cfg.f_floor)
        if theta0 is None:
            theta0 = 1.0 / scale if cfg.method == "lm" else np.ones(len(self.names))
        theta = np.asarray(theta0, float).copy()
        for p in self.problems:
            p.reset()
        t0 = time.perf_counter()
        history: list[dict[str, Any]] = []
        inner_ms: list[float] = []
        f, sens, sols = self._evaluate(theta)
        inner_ms += [s.solve_ms for s in sols]
        entry = self._record(history, 1, theta, f, sols)
        if progress:
            progress(entry)
        converged = False
        if cfg.method == "paper":
            eps_prev = entry["epsilon"]
            for it in range(2, cfg.max_iter + 1):
                theta = np.maximum(theta + cfg.alpha * (f - self.f_demo), cfg.theta_min)
                f, sens, sols = self._evaluate(theta)
                inner_ms += [s.solve_ms for s in sols]
                entry = self._record(history, it, theta, f, sols)
                if progress:
                    progress(entry)
                if abs(entry["epsilon"] - eps_prev) < cfg.epsilon_bar:
                    converged = True
                    break
                eps_prev = entry["epsilon"]
        else:
            phi0 = np.log(theta)
            phi = phi0.copy()
            lam = cfg.lm_lambda

            def cost(f_, phi_):
                e = (f_ - self.f_demo) / scale
                return 0.5 * float(e @ e) + 0.5 * cfg.prior * float((phi_ - phi0) @ (phi_ - phi0))

            c = cost(f, phi)
            it = 1
            while it < cfg.max_iter:
                e = (f - self.f_demo) / scale
                A = sens * theta[None, :] / scale[:, None]
                g = A.T @ e + cfg.prior * (phi - phi0)
                N = A.T @ A + cfg.prior * np.eye(phi.size)
                improved = False
                saved = [p.warm_start for p in self.problems]
                for _ in range(12):
                    # a rejected trial must not move the warm start into another basin
                    for p, state in zip(self.problems, saved, strict=True):
                        p.warm_start = state
                    step = np.linalg.solve(N + lam * np.diag(np.diag(N) + 1e-12), -g)
                    phi_new = phi + np.clip(step, -3.0, 3.0)
                    theta_new = np.exp(phi_new)
                    try:
                        f_new, sens_new, sols_new = self._evaluate(theta_new)
                    except RuntimeError:
                        lam *= 8
                        continue
                    inner_ms += [s.solve_ms for s in sols_new]
                    c_new = cost(f_new, phi_new)
                    if c_new < c:
                        improved = True
                        break
                    lam *= 4
                if not improved:
                    converged = True  # no descent direction left at this damping
                    break
                it += 1
                rel = (c - c_new) / max(c, 1e-300)
                phi, theta, f, sens, sols, c = phi_new, theta_new, f_new, sens_new, sols_new, c_new
                lam = max(lam / 3, 1e-9)
                entry = self._record(history, it, theta, f, sols)
                if progress:
                    progress(entry)
                if rel < cfg.tol:
                    converged = True
                    break
        wall = time.perf_counter() - t0
        errors = [
            trajectory_errors(
                s.control_points[:, [0, 3]], p.demo, p.basis.events.t_trg, p.basis.events.t_rct_end
            )
            for s, p in zip(sols, self.problems, strict=True)
        ]
        return LearningResult(
            names=self.names,
            theta=theta,
            theta_normalised=normalise_theta(theta, self.names),
            iterations=len(history),
            converged=converged,
            learning_error=float(np.linalg.norm(f - self.f_demo)),
            feature_values_demo=self.f_demo,
            feature_values_reproduced=f,
            solutions=sols,
            history=history,
            wall_time_s=wall,
            inner_solve_ms=inner_ms,
            errors=errors,
        )
