"""The capacity of a style model class: how well can its *best* parameters reproduce one driver?

The study behind RESULTS §10's capacity table. For one driver, SMPC(p), and K training
scenarios of the random family, each reproduction class gets its best parameters by fitting
the reproductions of the K training demonstrations *directly* (derivative-free:
:func:`~drivestyle.studies.capacity.nelder_mead.nelder_mead`), and is then scored in-sample
and on held-out scenarios of the same family. The learners of the two models (ME-IRL for
the paper's, teacher forcing for the receding-horizon style) are scored beside them. The
classes (:data:`CLASSES`):

``paper_nm``
    The paper model: argmin θᵀf over the whole horizon (the ME-IRL inner problem, ten
    reactive features), reproduced as a spline in each demonstration's own scenario (as
    ``compare_baseline`` and identification do), θ fitted by Nelder–Mead in log θ (one
    weight per feature group fixed: x and y features never interact, so each group's scale
    is free).
``paper_irl``
    The same class, θ learned by ME-IRL from the K demonstrations jointly
    (:func:`drivestyle.irl.paper.style.fit_style`).
``rh_cost_nm``
    The receding-horizon planner of :mod:`drivestyle.irl.driver.driver_style` with its cost only:
    p = 0.5 (κ = 0: the nominal ellipse, no back-off), the four free weights fitted by
    Nelder–Mead on closed-loop reproductions
(:func:`~drivestyle.irl.driver.driver_style.reproduce`). ``rh_chance_nm``
    The same planner with the chance constraint: the weights and p fitted by Nelder–Mead.
``rh_learned``
    The same planner learned by :func:`~drivestyle.irl.driver.driver_learning.learn_driver` (the
    product's learner: teacher-forced input residuals, no reproduction in the loop).

The objective scores x and y together (a fit on y alone hides the error by moving x):
per demonstration sqrt(rmse_y² + (:data:`X_WEIGHT`·rmse_x)²) — a lateral metre weighs as
much as two longitudinal metres — averaged over the training demonstrations. Each
Nelder–Mead run starts from the better of the class's generic start and its learner's
answer (``paper_nm`` from ME-IRL's start and result, ``rh_chance_nm`` from the normalised
weights and ``learn_driver``'s style, ``rh_cost_nm`` from both weight vectors at p = 0.5):
a fitted class is then never worse in-sample than its learner on the objective, and the
table separates what the class can express from what the learner finds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstration
from drivestyle.agents.smpc import SMPCConfig
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.driver_learning import learn_driver
from drivestyle.irl.driver.driver_style import (
    RISK_RANGE,
    WEIGHT_NAMES,
    DriverStyle,
    initial_weights,
    reproduce,
)
from drivestyle.irl.paper.features import X_FEATURES, FeatureConfig
from drivestyle.irl.paper.inner import InnerProblem, InnerSolveError
from drivestyle.irl.paper.learner import IRLConfig
from drivestyle.irl.paper.style import fit_style
from drivestyle.studies.capacity.nelder_mead import nelder_mead

__all__ = [
    "CLASSES",
    "LABELS",
    "TEST_SEED",
    "TRAIN_SEED",
    "X_WEIGHT",
    "CapacityError",
    "CapacityStudy",
    "ClassResult",
    "RiskCapacity",
    "capacity_of_risk",
    "capacity_study",
    "reproduction_score",
]

CLASSES = ("paper_nm", "paper_irl", "rh_cost_nm", "rh_chance_nm", "rh_learned")
"""The reproduction classes, in table order."""
LABELS = {
    "paper_nm": "paper: argmin θᵀf over the horizon, θ fitted (NM)",
    "paper_irl": "paper: θ learned by ME-IRL (K demos jointly)",
    "rh_cost_nm": "receding horizon, cost only (p = 0.5), weights fitted (NM)",
    "rh_chance_nm": "receding horizon + chance constraint, weights and p fitted (NM)",
    "rh_learned": "receding horizon, learned (learn_driver, teacher forcing)",
}
"""Row labels of the table."""
X_WEIGHT = 0.5
"""Weight of the longitudinal error in the objective: sqrt(rmse_y² + (X_WEIGHT·rmse_x)²)."""
TRAIN_SEED = 0
"""Seed of the training scenario draws (the project's training seed)."""
TEST_SEED = 500
"""Seed of the held-out scenario draws (the project's validation seed)."""
_LOG_STEP = 1.0
"""Nelder–Mead's initial simplex step in log-weights (a factor e) and in the risk coordinate."""
_FAILED = 1e3
"""Objective of a parameter vector whose reproduction cannot be computed [m]."""


class CapacityError(ValueError):
    """Bad input to the capacity study."""


# ---------------------------------------------------------------------------- scoring
def reproduction_score(rmse_y: float, rmse_xy: float) -> float:
    """The per-demonstration objective sqrt(rmse_y² + (:data:`X_WEIGHT`·rmse_x)²) [m].

    Args:
        rmse_y: lateral RMSE [m].
        rmse_xy: position RMSE [m] (rmse_x² = rmse_xy² − rmse_y²).
    """
    rmse_x2 = max(rmse_xy**2 - rmse_y**2, 0.0)
    return math.sqrt(rmse_y**2 + X_WEIGHT**2 * rmse_x2)


def _ellipse_margin(xy: np.ndarray, demo: Demonstration) -> float:
    """Least nominal ellipse margin d_k of positions ``xy`` (n, 2) against the demo's vehicles."""
    sc = demo.scenario
    rel = xy[:, None, :] - demo.vehicles[:, :, :2]
    d = (rel[..., 0] / sc.l_a) ** 2 + (rel[..., 1] / sc.l_b) ** 2 - 1.0
    return float(np.min(d))


@dataclass(frozen=True)
class _Scores:
    """Per-demonstration errors of one parameter vector."""

    rmse_y: tuple[float, ...]
    rmse_xy: tuple[float, ...]
    min_d: tuple[float, ...]

    @property
    def objective(self) -> float:
        if not all(math.isfinite(v) for v in self.rmse_xy):
            return _FAILED
        pairs = zip(self.rmse_y, self.rmse_xy, strict=True)
        return float(np.mean([reproduction_score(y, xy) for y, xy in pairs]))


class _PaperModel:
    """The paper model's spline reproductions of a set of demonstrations."""

    def __init__(self, demos: Sequence[Demonstration], features: FeatureConfig) -> None:
        self.problems = [InnerProblem(d, features) for d in demos]
        names = self.problems[0].names
        self.names = names
        x_idx = [i for i, n in enumerate(names) if n in X_FEATURES]
        y_idx = [i for i, n in enumerate(names) if n not in X_FEATURES]
        # the argmin is invariant to each group's scale: fix the first weight of each group
        self.fixed = [g[0] for g in (x_idx, y_idx) if g]
        self.free = [i for i in range(len(names)) if i not in self.fixed]

    def scores(self, theta: np.ndarray) -> _Scores:
        ys, xys, ds = [], [], []
        for p in self.problems:
            p.reset()  # every θ from the demo's own control points: order-independent
            try:
                C = p.solve(theta).control_points
            except InnerSolveError:
                ys.append(math.nan)
                xys.append(math.nan)
                ds.append(math.nan)
                continue
            xy = C[:, [0, 3]]
            err = xy - p.demo.ev[:, :2]
            ys.append(float(np.sqrt(np.mean(err[:, 1] ** 2))))
            xys.append(float(np.sqrt(np.mean(np.sum(err**2, axis=1)))))
            ds.append(_ellipse_margin(xy, p.demo))
        return _Scores(tuple(ys), tuple(xys), tuple(ds))

    def gauge(self, theta: np.ndarray) -> np.ndarray:
        """θ with each group divided by its fixed weight (same reproduction)."""
        theta = np.asarray(theta, float).copy()
        for i, n in zip(self.fixed, ("x", "y"), strict=False):
            group = [j for j, m in enumerate(self.names) if (m in X_FEATURES) == (n == "x")]
            theta[group] /= theta[i]
        return theta

    def theta_of(self, z: np.ndarray) -> np.ndarray:
        theta = np.ones(len(self.names))
        theta[self.free] = np.exp(np.clip(z, -30.0, 30.0))
        return theta


def _class_result(
    name: str,
    params: dict[str, float],
    train: _Scores,
    test: _Scores,
    evaluations: int,
    seconds: float,
    start: str,
) -> ClassResult:
    """A :class:`ClassResult` from one parameter vector's training and held-out scores."""
    return ClassResult(
        name, params, train.objective, train.rmse_y, train.rmse_xy,
        test.rmse_y, test.rmse_xy, test.min_d, evaluations, seconds, start,
    )  # fmt: skip


def _rh_scores(style: DriverStyle, demos: Sequence[Demonstration]) -> _Scores:
    ys, xys, ds = [], [], []
    for d in demos:
        rep = reproduce(style, d)
        y, xy = rep.errors(d)
        ys.append(y)
        xys.append(xy)
        ds.append(rep.min_d)
    return _Scores(tuple(ys), tuple(xys), tuple(ds))


_FREE_W = [i for i, n in enumerate(WEIGHT_NAMES) if n != "accel"]
"""Indices of the free weights (w_a = 1 is the gauge of the receding-horizon style)."""


def _risk_of(s: float) -> float:
    """The risk lo + (hi − lo)·sigmoid(s): an unconstrained coordinate for p ∈ RISK_RANGE."""
    lo, hi = RISK_RANGE
    return lo + (hi - lo) / (1.0 + math.exp(-float(np.clip(s, -50.0, 50.0))))


def _s_of(risk: float) -> float:
    lo, hi = RISK_RANGE
    q = min(max((risk - lo) / (hi - lo), 1e-4), 1 - 1e-4)
    return math.log(q / (1 - q))


def _style_of(z: np.ndarray, risk: float | None) -> DriverStyle:
    """Weights from log w (free ones) and p from z[-1] (or the fixed ``risk``)."""
    w = np.ones(len(WEIGHT_NAMES))
    w[_FREE_W] = np.exp(np.clip(z[: len(_FREE_W)], -30.0, 30.0))
    p = _risk_of(z[len(_FREE_W)]) if risk is None else risk
    return DriverStyle(tuple(w), risk=p)


def _z_of(style: DriverStyle, with_risk: bool) -> np.ndarray:
    z = list(np.log(style.normalised()[_FREE_W]))
    if with_risk:
        z.append(_s_of(style.risk))
    return np.array(z)


# ---------------------------------------------------------------------------- results
def _median(values: Sequence[float]) -> float | None:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if len(finite) == len(values) and finite else None


def _listed(values: Sequence[float]) -> list[float | None]:
    return [v if math.isfinite(v) else None for v in values]


@dataclass(frozen=True)
class ClassResult:
    """One reproduction class for one driver: its parameters and how they reproduce."""

    name: str
    """One of :data:`CLASSES`."""
    params: Mapping[str, float]
    """The parameters found (θ per feature, or the weights and ``risk``)."""
    objective: float
    """The training objective: mean of :func:`reproduction_score` over the training demos."""
    train_rmse_y: tuple[float, ...]
    """Per training demonstration [m] (NaN: the reproduction failed)."""
    train_rmse_xy: tuple[float, ...]
    test_rmse_y: tuple[float, ...]
    """Per held-out demonstration [m]."""
    test_rmse_xy: tuple[float, ...]
    test_min_d: tuple[float, ...]
    """Least nominal ellipse margin of each held-out reproduction (< 0: inside)."""
    evaluations: int
    """Objective evaluations of the Nelder–Mead fit (0 for a learner's row)."""
    seconds: float
    """Wall time of the fit [s]."""
    start: str = ""
    """Where the Nelder–Mead run started (the better-scored candidate)."""

    @property
    def label(self) -> str:
        """The table's row label."""
        return LABELS[self.name]

    def medians(self) -> dict[str, float | None]:
        """Median rmse_y and rmse_xy, training and held-out (None if a reproduction failed)."""
        return {
            "train_rmse_y_m": _median(self.train_rmse_y),
            "train_rmse_xy_m": _median(self.train_rmse_xy),
            "test_rmse_y_m": _median(self.test_rmse_y),
            "test_rmse_xy_m": _median(self.test_rmse_xy),
        }

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict: medians, per-demonstration errors, parameters, cost."""
        return {
            "name": self.name,
            "label": self.label,
            **self.medians(),
            "objective_m": self.objective,
            "test_min_d": min(self.test_min_d) if self.test_min_d else None,
            "params": dict(self.params),
            "evaluations": self.evaluations,
            "seconds": self.seconds,
            "start": self.start,
            "per_demo": {
                "train_rmse_y_m": _listed(self.train_rmse_y),
                "train_rmse_xy_m": _listed(self.train_rmse_xy),
                "test_rmse_y_m": _listed(self.test_rmse_y),
                "test_rmse_xy_m": _listed(self.test_rmse_xy),
                "test_min_d": _listed(self.test_min_d),
            },
        }


@dataclass(frozen=True)
class RiskCapacity:
    """Every class for one driver SMPC(p)."""

    risk: float
    classes: tuple[ClassResult, ...]
    driver_min_d_test: tuple[float, ...]
    """The driver's own least ellipse margin in each held-out demonstration."""
    seconds: float
    """Wall time of this driver's study (demonstrations included) [s]."""

    def by_name(self) -> dict[str, ClassResult]:
        """Class name → result."""
        return {c.name: c for c in self.classes}

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "risk": self.risk,
            "driver_min_d_test": list(self.driver_min_d_test),
            "seconds": self.seconds,
            "classes": {c.name: c.to_json() for c in self.classes},
        }


@dataclass(frozen=True)
class CapacityStudy:
    """The capacity table: every class for every driver (``capacity.json``)."""

    risks: tuple[float, ...]
    budget: int
    """Nelder–Mead evaluations per fitted class."""
    train_scenarios: tuple[ScenarioConfig, ...]
    test_scenarios: tuple[ScenarioConfig, ...]
    rows: tuple[RiskCapacity, ...]
    seconds: float
    """Wall time of the whole study [s]."""
    train_seed: int = TRAIN_SEED
    test_seed: int = TEST_SEED
    learn_options: Mapping[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``capacity.json``)."""
        return {
            "risks": list(self.risks),
            "n_train": len(self.train_scenarios),
            "n_test": len(self.test_scenarios),
            "train_seed": self.train_seed,
            "test_seed": self.test_seed,
            "budget": self.budget,
            "objective": (
                f"mean over training demonstrations of sqrt(rmse_y^2 + ({X_WEIGHT} rmse_x)^2)"
            ),
            "learn_options": dict(self.learn_options),
            "seconds": self.seconds,
            "classes": {name: LABELS[name] for name in CLASSES},
            "rows": [r.to_json() for r in self.rows],
            "train_scenarios": [sc.to_dict() for sc in self.train_scenarios],
            "test_scenarios": [sc.to_dict() for sc in self.test_scenarios],
        }


# ---------------------------------------------------------------------------- the study
def _best_start(
    candidates: Sequence[tuple[str, np.ndarray]], fun: Callable[[np.ndarray], float]
) -> tuple[str, np.ndarray, float]:
    scored = [(fun(z), i, name, z) for i, (name, z) in enumerate(candidates)]
    value, _, name, z = min(scored, key=lambda s: (s[0], s[1]))
    return name, z, value


def _fit(
    candidates: Sequence[tuple[str, np.ndarray]],
    objective: Callable[[np.ndarray], float],
    budget: int,
) -> tuple[np.ndarray, int, str]:
    """Nelder–Mead from the best candidate; the candidates' evaluations count in the budget."""
    start, z0, _ = _best_start(candidates, objective)
    left = budget - len(candidates)
    if left < 1:
        return z0, len(candidates), start
    nm = nelder_mead(objective, z0, _LOG_STEP, left)
    return nm.x, nm.evaluations + len(candidates), start


def capacity_of_risk(
    risk: float,
    train: Sequence[Demonstration],
    test: Sequence[Demonstration],
    budget: int,
    learn_options: Mapping[str, Any] | None = None,
    irl_max_iter: int | None = None,
) -> RiskCapacity:
    """Every class of :data:`CLASSES` for one driver's demonstrations.

    Args:
        risk: the driver's p (recorded only).
        train: its training demonstrations (K ≥ 1).
        test: its held-out demonstrations (≥ 1).
        budget: objective evaluations per Nelder–Mead fit (the starting candidates count).
        learn_options: keyword arguments of
            :func:`~drivestyle.irl.driver.driver_learning.learn_driver` (e.g. fewer starting
            points for a quick run); default: its defaults.
        irl_max_iter: ME-IRL's outer iteration cap (default: its default).

    Returns:
        The classes' results.

    Raises:
        CapacityError: no training or held-out demonstrations, or a budget < 1.
    """
    if not train or not test:
        raise CapacityError("need at least one training and one held-out demonstration")
    if not (isinstance(budget, int) and budget >= 1):
        raise CapacityError(f"budget must be an integer >= 1, got {budget!r}")
    t_risk = time.perf_counter()
    results: dict[str, ClassResult] = {}

    # ---- the paper model: ME-IRL, then Nelder–Mead from its start and its answer
    features = FeatureConfig("reactive")
    t0 = time.perf_counter()
    config = IRLConfig() if irl_max_iter is None else IRLConfig(max_iter=irl_max_iter)
    fitted = fit_style(list(train), features, config)
    irl_s = time.perf_counter() - t0
    paper_train = _PaperModel(train, features)
    paper_test = _PaperModel(test, features)
    names = paper_train.names

    def paper_row(key: str, theta: np.ndarray, evals: int, secs: float, start: str) -> ClassResult:
        params = dict(zip(names, map(float, paper_train.gauge(theta)), strict=True))
        tr, te = paper_train.scores(theta), paper_test.scores(theta)
        return _class_result(key, params, tr, te, evals, secs, start)

    theta_irl = np.asarray(fitted.result.theta, float)
    results["paper_irl"] = paper_row("paper_irl", theta_irl, 0, irl_s, "")

    def paper_objective(z: np.ndarray) -> float:
        return paper_train.scores(paper_train.theta_of(z)).objective

    def paper_z(theta: np.ndarray) -> np.ndarray:
        return np.log(paper_train.gauge(theta)[paper_train.free])

    t0 = time.perf_counter()
    theta_start = np.asarray(fitted.result.history[0].theta, float)
    z, evals, start = _fit(
        [("ME-IRL's start", paper_z(theta_start)), ("ME-IRL's θ", paper_z(theta_irl))],
        paper_objective,
        budget,
    )
    secs = time.perf_counter() - t0
    results["paper_nm"] = paper_row("paper_nm", paper_train.theta_of(z), evals, secs, start)

    # ---- the receding-horizon style: the learner, then Nelder–Mead
    def rh_row(key: str, style: DriverStyle, evals: int, secs: float, start: str) -> ClassResult:
        tr, te = _rh_scores(style, train), _rh_scores(style, test)
        params = dict(zip(WEIGHT_NAMES, map(float, style.normalised()), strict=True))
        params["risk"] = style.risk
        return _class_result(key, params, tr, te, evals, secs, start)

    t0 = time.perf_counter()
    learned = learn_driver(list(train), **dict(learn_options or {})).style
    results["rh_learned"] = rh_row("rh_learned", learned, 0, time.perf_counter() - t0, "")

    generic = DriverStyle(tuple(initial_weights()), risk=0.7)
    nominal = RISK_RANGE[0]

    # Nelder–Mead over the weights at the nominal risk, then over weights and risk
    fits = (
        ("rh_cost_nm", nominal, ("normalised weights", "learn_driver's weights")),
        ("rh_chance_nm", None, ("normalised weights, p = 0.7", "learn_driver's style")),
    )
    for name, fixed, labels in fits:
        free_risk = fixed is None

        def objective(z: np.ndarray, fixed: float | None = fixed) -> float:
            return _rh_scores(_style_of(z, fixed), train).objective

        t0 = time.perf_counter()
        z, evals, start = _fit(
            [(labels[0], _z_of(generic, free_risk)), (labels[1], _z_of(learned, free_risk))],
            objective,
            budget,
        )
        style = _style_of(z, fixed)
        results[name] = rh_row(name, style, evals, time.perf_counter() - t0, start)

    driver_d = tuple(_ellipse_margin(d.ev[:, :2], d) for d in test)
    return RiskCapacity(
        risk=float(risk),
        classes=tuple(results[name] for name in CLASSES),
        driver_min_d_test=driver_d,
        seconds=time.perf_counter() - t_risk,
    )


def _demos(risk: float, scenarios: Sequence[ScenarioConfig]) -> list[Demonstration]:
    return [generate_demonstration(risk, sc, SMPCConfig(risk=risk))[0] for sc in scenarios]


def _risk_task(
    risk: float,
    train_scenarios: Sequence[ScenarioConfig],
    test_scenarios: Sequence[ScenarioConfig],
    budget: int,
    learn_options: Mapping[str, Any],
) -> RiskCapacity:
    """Worker: one driver's demonstrations and :func:`capacity_of_risk` (wall time included)."""
    t0 = time.perf_counter()
    train, test = _demos(risk, train_scenarios), _demos(risk, test_scenarios)
    row = capacity_of_risk(risk, train, test, budget, learn_options)
    return RiskCapacity(row.risk, row.classes, row.driver_min_d_test, time.perf_counter() - t0)


def capacity_study(
    risks: Sequence[float],
    n_train: int = 5,
    n_test: int = 4,
    budget: int = 300,
    workers: int = 2,
    learn_options: Mapping[str, Any] | None = None,
    on_risk: Callable[[RiskCapacity], None] | None = None,
) -> CapacityStudy:
    """The capacity table for the drivers SMPC(p), p in ``risks``.

    Training scenarios are ``draw_interactive_scenarios(n_train, seed=0)``, held-out ones
    ``draw_interactive_scenarios(n_test, seed=500)``; every driver drives the same ones.

    Args:
        risks: the drivers' risks p in (0, 1).
        n_train: K, training scenarios (≥ 1).
        n_test: held-out scenarios (≥ 1).
        budget: objective evaluations per Nelder–Mead fit.
        workers: processes (one driver each).
        learn_options: keyword arguments of ``learn_driver`` (default: its defaults).
        on_risk: called with each driver's result as it finishes.

    Returns:
        The study (deterministic: independent of ``workers``).

    Raises:
        CapacityError: no risks, a risk outside (0, 1), or fewer than one scenario.
    """
    risks = tuple(float(p) for p in risks)
    if not risks or not all(0 < p < 1 for p in risks):
        raise CapacityError(f"need one or more risks in (0, 1), got {list(risks)}")
    if n_train < 1 or n_test < 1:
        raise CapacityError(f"need >= 1 training and held-out scenarios, got {n_train}, {n_test}")
    if not (isinstance(budget, int) and budget >= 1):
        raise CapacityError(f"budget must be an integer >= 1, got {budget!r}")
    t0 = time.perf_counter()
    train_sc = tuple(draw_interactive_scenarios(n_train, seed=TRAIN_SEED))
    test_sc = tuple(draw_interactive_scenarios(n_test, seed=TEST_SEED))
    options = dict(learn_options or {})
    tasks = [(p, train_sc, test_sc, budget, options) for p in risks]
    rows = parallel_map(
        _risk_task,
        tasks,
        workers,
        on_result=None if on_risk is None else (lambda _i, row: on_risk(row)),
    )
    return CapacityStudy(
        risks=risks,
        budget=budget,
        train_scenarios=train_sc,
        test_scenarios=test_sc,
        rows=tuple(rows),
        seconds=time.perf_counter() - t0,
        learn_options=options,
    )
