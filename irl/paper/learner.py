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
styles are comparable, and how they stopped (:data:`LearningStatus`): ``"converged"`` at the
rule's stopping criterion, ``"max_iter"`` at the cap, ``"stalled"`` when the inner problem
could not be solved at the trial θ (only :class:`~drivestyle.irl.paper.inner.InnerSolveError` is
taken as such; any other error propagates).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from drivestyle.envs.demonstration import Demonstration, DemonstrationError
from drivestyle.envs.plausibility import check_plausible
from drivestyle.irl.metrics import trajectory_errors
from drivestyle.irl.paper.features import X_FEATURES, FeatureConfig
from drivestyle.irl.paper.inner import InnerProblem, InnerSolution, InnerSolveError

__all__ = [
    "IRLConfig",
    "IterationRecord",
    "LearningResult",
    "LearningStatus",
    "MaxEntIRL",
    "check_learnable",
    "normalise_theta",
]

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
    seconds), is physically plausible (:func:`~drivestyle.envs.plausibility.check_plausible`:
    no overlap at t = 0, forward driving, lateral speed within the heading bound, lanes that
    fit the data, one lane change to +y), shows the EV moving, and shows a lane change:
    enough lateral progress towards the target lane (:data:`MIN_LANE_CHANGE_PROGRESS`; an
    SMPC that waits for the TV within the horizon has begun its lane change, an EV keeping
    its lane has not).

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
    check_plausible(demo)
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


LearningStatus = Literal["converged", "max_iter", "stalled"]
"""How learning stopped: at a fixed point of the update rule, at the iteration cap, or because
the inner problem could not be solved at any trial θ (the last θ is then not a fixed point)."""

LM_TRIALS = 12
"""LM: damped trial steps per iteration before learning is declared stalled or converged."""


@dataclass(frozen=True)
class IterationRecord:
    """One outer iteration (iteration 1 is the initial θ)."""

    iteration: int
    theta: np.ndarray
    epsilon: float
    """Learning error ε = ‖f(r*_θ) − f(r_D)‖₂ (scaled features, averaged over demonstrations)."""
    rmse_y_m: float
    """Lateral RMSE of the reproductions, mean over the demonstrations [m]."""
    control_points: tuple[np.ndarray, ...]
    """The reproduction r*_θ of each demonstration, shape (S+1, 6) each."""

    def to_json(self) -> dict[str, Any]:
        """The entry of ``style.json``'s ``history`` (the control points are not written)."""
        return {
            "iteration": self.iteration,
            "theta": self.theta.tolist(),
            "epsilon": self.epsilon,
            "rmse_y_m": self.rmse_y_m,
        }


@dataclass(frozen=True)
class LearningResult:
    """Outcome of :meth:`MaxEntIRL.learn`."""

    names: tuple[str, ...]
    theta: np.ndarray
    """The learned weights (the last accepted θ)."""
    theta_normalised: np.ndarray
    """θ normalised per feature group (:func:`normalise_theta`)."""
    status: LearningStatus
    stop_reason: str
    """Why learning stopped, in words (the stalled case names the inner failure)."""
    learning_error: float
    feature_values_demo: np.ndarray
    feature_values_reproduced: np.ndarray
    solutions: tuple[InnerSolution, ...]
    """r*_θ per demonstration at the returned θ."""
    history: tuple[IterationRecord, ...]
    wall_time_s: float
    inner_solve_ms: tuple[float, ...]
    """Wall time of every successful inner solve (trials included) [ms]."""
    errors: tuple[dict[str, float | None], ...]
    """Trajectory errors per demonstration (:func:`drivestyle.irl.metrics.trajectory_errors`)."""
    inner_failures: int = 0
    """Trial θ whose inner problem did not converge (LM rejects them and damps more)."""

    @property
    def iterations(self) -> int:
        """Outer iterations, the initial θ counted as iteration 1."""
        return len(self.history)

    @property
    def converged(self) -> bool:
        """Whether the update rule reached its stopping criterion (``status == "converged"``)."""
        return self.status == "converged"

    def to_json(self) -> dict[str, Any]:
        """The learning part of ``style.json`` (docs/DESIGN.md §7 keys, plus ``status``)."""
        return {
            "features": list(self.names),
            "theta": self.theta.tolist(),
            "theta_normalised": self.theta_normalised.tolist(),
            "iterations": self.iterations,
            "converged": self.converged,
            "status": self.status,
            "stop_reason": self.stop_reason,
            "inner_failures": self.inner_failures,
            "learning_error": self.learning_error,
            "wall_time_s": self.wall_time_s,
            "inner_solve_ms_median": float(np.median(self.inner_solve_ms)),
            "feature_values_demo": self.feature_values_demo.tolist(),
            "feature_values_reproduced": self.feature_values_reproduced.tolist(),
            "history": [h.to_json() for h in self.history],
        }


@dataclass(frozen=True)
class _Point:
    """θ with its inner solutions: the state both update rules move."""

    theta: np.ndarray
    f: np.ndarray
    """Features of r*_θ, averaged over the demonstrations."""
    sensitivity: np.ndarray
    """∂f(r*_θ)/∂θ, averaged over the demonstrations."""
    solutions: tuple[InnerSolution, ...]


@dataclass(frozen=True)
class _Stop:
    """Where an update rule stopped, and why."""

    point: _Point
    status: LearningStatus
    reason: str


class MaxEntIRL:
    """ME-IRL over one or several demonstrations (features averaged).

    Args:
        demos: the demonstrations (each with ``meta["scenario"]``).
        features: feature configuration (active set and constants), or one per
            demonstration (same active set; e.g. recorded episodes with their own lanes).
        config: outer-loop settings.
        control_point_rule: how the demonstrations' control points are derived
            (``drivestyle.irl.paper.spline``).
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
        self._scale = np.maximum(np.abs(self.f_demo), self.config.f_floor)
        """Denominators of the relative feature errors (LM; the default initial θ is 1/scale)."""
        # the state of the run in progress (one at a time: the problems' warm starts are shared)
        self._history: list[IterationRecord] = []
        self._inner_ms: list[float] = []
        self._inner_failures = 0
        self._progress: Callable[[IterationRecord], None] | None = None

    def learn(
        self,
        theta0: np.ndarray | None = None,
        progress: Callable[[IterationRecord], None] | None = None,
    ) -> LearningResult:
        """Run the outer loop with the configured update rule.

        Args:
            theta0: initial weights (default: 1/max(|f_D|, f_floor) for 'lm', 1 for
                'paper').
            progress: called with each iteration's record.

        Returns:
            The learning result; ``history[i].control_points`` holds the reproduction at
            iteration i + 1 (iteration 1 is the initial θ). Its ``status`` is ``"stalled"``
            when the inner problem could not be solved at the next θ (paper rule) or at the
            smallest of an iteration's trial steps (LM); θ is then the last solved one.

        Raises:
            InnerSolveError: the inner problem cannot be solved at the initial θ.
        """
        cfg = self.config
        if theta0 is None:
            theta0 = 1.0 / self._scale if cfg.method == "lm" else np.ones(len(self.names))
        for p in self.problems:
            p.reset()
        self._history, self._inner_ms, self._inner_failures = [], [], 0
        self._progress = progress
        t0 = time.perf_counter()
        start = self._evaluate(np.asarray(theta0, float).copy())
        self._record(start)
        rule = self._paper_rule if cfg.method == "paper" else self._levenberg_marquardt
        stop = rule(start)
        wall = time.perf_counter() - t0
        return self._result(stop, wall)

    def _paper_rule(self, point: _Point) -> _Stop:
        """The paper's rule: θ ← max(θ + α (f(r*_θ) − f(r_D)), θ_min) until |Δε| < ε̄."""
        cfg = self.config
        eps_prev = self._history[-1].epsilon
        for _ in range(2, cfg.max_iter + 1):
            theta = np.maximum(point.theta + cfg.alpha * (point.f - self.f_demo), cfg.theta_min)
            try:
                point = self._evaluate(theta)
            except InnerSolveError as exc:
                # no damping to fall back on: the last solved θ is the answer, not a fixed point
                self._inner_failures += 1
                return _Stop(point, "stalled", f"the inner problem failed at the next θ: {exc}")
            eps = self._record(point).epsilon
            if abs(eps - eps_prev) < cfg.epsilon_bar:
                return _Stop(point, "converged", f"|ε_i − ε_(i−1)| < ε̄ = {cfg.epsilon_bar:g}")
            eps_prev = eps
        return _Stop(point, "max_iter", f"reached max_iter = {cfg.max_iter}")

    def _levenberg_marquardt(self, point: _Point) -> _Stop:
        """Levenberg–Marquardt in φ = log θ on the relative feature errors, with a gauge prior.

        Each iteration tries up to :data:`LM_TRIALS` damped steps; a trial whose inner problem
        does not converge is rejected with more damping than one that does not lower the cost.
        """
        cfg = self.config
        scale = self._scale
        phi0 = np.log(point.theta)
        phi = phi0.copy()
        lam = cfg.lm_lambda

        def cost(f_: np.ndarray, phi_: np.ndarray) -> float:
            e = (f_ - self.f_demo) / scale
            return 0.5 * float(e @ e) + 0.5 * cfg.prior * float((phi_ - phi0) @ (phi_ - phi0))

        c = cost(point.f, phi)
        for _ in range(2, cfg.max_iter + 1):
            e = (point.f - self.f_demo) / scale
            A = point.sensitivity * point.theta[None, :] / scale[:, None]
            g = A.T @ e + cfg.prior * (phi - phi0)
            N = A.T @ A + cfg.prior * np.eye(phi.size)
            saved = [p.warm_start for p in self.problems]
            trial: _Point | None = None
            failure: InnerSolveError | None = None
            c_new = math.inf
            for _trial in range(LM_TRIALS):
                # a rejected trial must not move the warm start into another basin
                self._restore(saved)
                step = np.linalg.solve(N + lam * np.diag(np.diag(N) + 1e-12), -g)
                phi_new = phi + np.clip(step, -3.0, 3.0)
                try:
                    trial = self._evaluate(np.exp(phi_new))
                except InnerSolveError as exc:
                    self._inner_failures += 1
                    failure, trial = exc, None
                    lam *= 8
                    continue
                failure = None
                c_new = cost(trial.f, phi_new)
                if c_new < c:
                    break
                trial = None
                lam *= 4
            if trial is None:
                self._restore(saved)
                if failure is not None:
                    # the smallest step tried could not be solved: θ is not known to be optimal
                    return _Stop(
                        point,
                        "stalled",
                        f"the inner problem failed at the last of {LM_TRIALS} trial steps: "
                        f"{failure}",
                    )
                return _Stop(point, "converged", f"no lower cost in {LM_TRIALS} damped steps")
            rel = (c - c_new) / max(c, 1e-300)
            phi, point, c = phi_new, trial, c_new
            lam = max(lam / 3, 1e-9)
            self._record(point)
            if rel < cfg.tol:
                return _Stop(point, "converged", f"cost decreased by less than tol = {cfg.tol:g}")
        return _Stop(point, "max_iter", f"reached max_iter = {cfg.max_iter}")

    def _restore(self, warm_starts: Sequence[dict[str, np.ndarray]]) -> None:
        for p, state in zip(self.problems, warm_starts, strict=True):
            p.warm_start = state

    def _evaluate(self, theta: np.ndarray) -> _Point:
        sols = tuple(p.solve(theta, tol=self.config.inner_tol) for p in self.problems)
        self._inner_ms += [s.solve_ms for s in sols]
        f = np.mean([s.features for s in sols], axis=0)
        sens = np.mean([s.sensitivity for s in sols], axis=0)
        return _Point(theta, f, sens, sols)

    def _errors(self, point: _Point) -> tuple[dict[str, float | None], ...]:
        return tuple(
            trajectory_errors(
                s.control_points[:, [0, 3]], p.demo, p.basis.events.t_trg, p.basis.events.t_rct_end
            )
            for s, p in zip(point.solutions, self.problems, strict=True)
        )

    def _record(self, point: _Point) -> IterationRecord:
        errs = self._errors(point)
        entry = IterationRecord(
            iteration=len(self._history) + 1,
            theta=point.theta,
            epsilon=float(np.linalg.norm(point.f - self.f_demo)),
            rmse_y_m=float(np.mean([e["rmse_y_m"] for e in errs])),
            control_points=tuple(s.control_points for s in point.solutions),
        )
        self._history.append(entry)
        if self._progress:
            self._progress(entry)
        return entry

    def _result(self, stop: _Stop, wall: float) -> LearningResult:
        point = stop.point
        return LearningResult(
            names=self.names,
            theta=point.theta,
            theta_normalised=normalise_theta(point.theta, self.names),
            status=stop.status,
            stop_reason=stop.reason,
            learning_error=float(np.linalg.norm(point.f - self.f_demo)),
            feature_values_demo=self.f_demo,
            feature_values_reproduced=point.f,
            solutions=point.solutions,
            history=tuple(self._history),
            wall_time_s=wall,
            inner_solve_ms=tuple(self._inner_ms),
            errors=self._errors(point),
            inner_failures=self._inner_failures,
        )
