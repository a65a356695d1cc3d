"""The population's style learned from recorded drivers (DESIGN §18).

The driver library of :mod:`drivestyle.irl.identification.library` carries the SMPC expert's cost:
built from simulated SMPC(p) lane changes, it was never fitted to people. Here one style — the
cost weights, the risk and the speed-scaled safety region (T, s_0) — is learned by teacher
forcing over every lane change of the recorded benchmark's *train* split (docs/
benchmark_split.csv), each episode in the one recorded view
(:func:`~drivestyle.recorded.real_data.recorded_view`: the target lane's centre, no own-line
shift). The result is written as a driver library with
the same risk grid and temperature as the library it started from, so identification,
prediction and mining use it unchanged: ``drivestyle evaluate-prediction --library
runs/people`` compares it on the validation split.

Two objectives (:data:`OBJECTIVES`). ``teacher``: the one-step input residuals of
:func:`~drivestyle.irl.driver.driver_learning.learn_driver`, the library's own objective. On
recorded traffic it learned the inputs' noise (residual 8.1 σ_u, the speed weight driven to
0.0002) and predicted worse than constant velocity. ``closed-loop``: the style is driven
from each episode's first state against the recorded vehicles
(:func:`~drivestyle.irl.driver.driver_style.reproduce`) and the mean of the episodes' rmse_xy
(each capped at :data:`CLOSED_LOOP_CAP_M`, so one diverging episode cannot dominate) is
minimised over the log weights, p, T and s_0 by Nelder–Mead — what a predictor needs, at
the price of a derivative-free search over 7 coordinates.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.driver.driver_fit import DriverFit
from drivestyle.irl.driver.driver_learning import (
    learn_driver,
    step_residuals,
    style_from_coordinates,
)
from drivestyle.irl.driver.driver_style import (
    GAUGE,
    MIN_GAP_RANGE,
    DriverStyle,
    DriverStyleError,
    reproduce,
)
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.recorded.benchmark import SplitRow, check_sample_split, load_recorded
from drivestyle.recorded.real_data import DATASETS, recorded_view

__all__ = [
    "CLOSED_LOOP_CAP_M",
    "OBJECTIVES",
    "ClosedLoopFit",
    "PopulationSettings",
    "closed_loop_cost",
    "learn_closed_loop",
    "learn_population",
    "population_library",
    "split_demos",
]

OBJECTIVES = ("teacher", "closed-loop")
"""What the population's style is fitted to (module docstring)."""
CLOSED_LOOP_CAP_M = 20.0
"""An episode's rmse_xy counts at most this much in the closed-loop objective [m]."""


@dataclass(frozen=True)
class PopulationSettings:
    """How the population's style is learned."""

    fit_region: bool = True
    """Learn the speed-scaled region (T, s_0); False: the library's fixed ellipse."""
    screen: int = 4
    """Starting points scored (:func:`learn_driver`)."""
    restarts: int = 1
    """Levenberg–Marquardt runs."""
    max_iter: int = 12
    """Iterations per run."""
    start_risk: float = 0.7
    """The risk the weights start from."""
    objective: str = "closed-loop"
    """A name of :data:`OBJECTIVES`."""
    max_evals: int = 160
    """Closed-loop objective evaluations of the simplex search."""

    def __post_init__(self) -> None:
        for name in ("screen", "restarts", "max_iter"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.restarts > self.screen:
            raise ValueError(f"restarts ({self.restarts}) cannot exceed screen ({self.screen})")
        if not (math.isfinite(self.start_risk) and 0.5 <= self.start_risk <= 0.99):
            raise ValueError(f"start_risk must lie in [0.5, 0.99], got {self.start_risk!r}")
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {OBJECTIVES}, got {self.objective!r}")
        if not (isinstance(self.max_evals, int) and self.max_evals >= 1):
            raise ValueError(f"max_evals must be a positive integer, got {self.max_evals!r}")


def split_demos(
    data_dir: str | Path, rows: Sequence[SplitRow], split: str = "train"
) -> tuple[list[tuple[str, Demonstration]], list[tuple[str, str]]]:
    """The split's episodes as the predictor sees them, and those it cannot use.

    Returns:
        ([(episode id, demonstration)], [(episode id, why skipped)]).
    """
    check_sample_split(data_dir, rows)  # each row's vehicle its episode's, in one split
    demos, skipped = [], []
    for ds in DATASETS:
        ids = [r.episode_id for r in rows if r.dataset == ds and r.split == split]
        for eid, raw in load_recorded(data_dir, ds, ids):
            try:
                demos.append((eid, recorded_view(raw)))
            except ValueError as exc:  # the view re-validates the demonstration
                skipped.append((eid, str(exc)))
    return demos, skipped


def learn_population(
    demos: Sequence[Demonstration],
    library: DriverLibrary,
    settings: PopulationSettings | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> DriverFit:
    """One style for every driver of ``demos``, from the library's weights.

    Raises:
        DriverStyleError: no demonstrations (or :func:`learn_driver`'s errors).
    """
    s = settings or PopulationSettings()
    start = replace(library.style, risk=s.start_risk)
    return learn_driver(
        list(demos), initial=start, fit_region=s.fit_region, screen=s.screen,
        restarts=s.restarts, max_iter=s.max_iter, progress=progress,
    )  # fmt: skip


@dataclass(frozen=True)
class ClosedLoopFit:
    """The population's style fitted to closed-loop paths (:func:`learn_closed_loop`)."""

    style: DriverStyle
    cost: float
    """Mean capped rmse_xy over the episodes at the result [m]."""
    start_cost: float
    """The same at the starting style [m]."""
    evaluations: int
    residual_rms: float
    """The result's teacher-forced residual RMS over the episodes [σ_u units]: the noise
    floor the written library carries (DESIGN §15)."""
    seconds: float
    status: str
    """``converged`` (the simplex met its tolerances) or ``max_evals``."""


def closed_loop_cost(style: DriverStyle, demos: Sequence[Demonstration]) -> float:
    """Mean over ``demos`` of the reproduction's rmse_xy, each capped at the cap [m].

    An episode whose reproduction fails counts the cap.
    """
    errs = []
    for d in demos:
        try:
            errs.append(min(reproduce(style, d).errors(d)[1], CLOSED_LOOP_CAP_M))
        except DriverStyleError:
            errs.append(CLOSED_LOOP_CAP_M)
    return float(np.mean(errs)) if errs else float("nan")


def learn_closed_loop(
    demos: Sequence[Demonstration],
    library: DriverLibrary,
    settings: PopulationSettings | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> ClosedLoopFit:
    """One style minimising :func:`closed_loop_cost` (module docstring).

    Coordinates: the four free log weights (w_a = 1), p, T and s_0, from the library's
    weights, ``settings.start_risk``, T = 0 and s_0 = the demonstrations' median l_a (the
    fixed ellipse); clipped to the class's ranges inside the objective. Deterministic.

    Raises:
        DriverStyleError: no demonstrations.
    """
    from scipy.optimize import minimize

    s = settings or PopulationSettings()
    demos = list(demos)
    if not demos:
        raise DriverStyleError("need at least one demonstration")
    w0 = np.asarray(library.style.weights, float) / library.style.weights[GAUGE]
    free = [i for i in range(w0.size) if i != GAUGE]
    s0 = float(np.median([d.scenario.l_a for d in demos]))

    def unpack(z: np.ndarray) -> DriverStyle:
        return style_from_coordinates(
            z, library.style, fit_risk=True, fit_speed=False, fit_region=True
        )

    calls = [0]

    def f(z: np.ndarray) -> float:
        cost = closed_loop_cost(unpack(z), demos)
        calls[0] += 1
        if progress is not None:
            progress(calls[0], cost)
        return cost

    t0 = time.perf_counter()
    z0 = np.r_[np.log(w0[free]), s.start_risk, 0.0, np.clip(s0, *MIN_GAP_RANGE)]
    start_cost = f(z0)
    options = {"maxfev": max(s.max_evals - 1, 1), "xatol": 1e-3, "fatol": 1e-3}
    res = minimize(f, z0, method="Nelder-Mead", options=options)
    style = unpack(res.x)
    r = np.concatenate([step_residuals(style, d)[0].ravel() for d in demos])
    return ClosedLoopFit(
        style, float(res.fun), start_cost, calls[0], float(np.sqrt(np.mean(r**2))),
        time.perf_counter() - t0, "converged" if res.success else "max_evals",
    )  # fmt: skip


def population_library(
    fit: DriverFit | ClosedLoopFit, library: DriverLibrary, meta: dict[str, Any] | None = None
) -> DriverLibrary:
    """The learned style as a driver library with ``library``'s risks and temperature.

    ``meta["fit"]`` records the fit (its ``residual_rms`` sets the noise floor, DESIGN §15).
    """
    fit_meta: dict[str, Any] = {"status": fit.status, "residual_rms": fit.residual_rms,
                                "seconds": fit.seconds}  # fmt: skip
    if isinstance(fit, ClosedLoopFit):
        fit_meta |= {"objective": "closed-loop", "closed_loop_rmse_xy_m": fit.cost,
                     "start_rmse_xy_m": fit.start_cost, "evaluations": fit.evaluations}  # fmt: skip
    else:
        fit_meta |= {"objective": "teacher", "n_residuals": fit.n_residuals,
                     "iterations": fit.iterations}  # fmt: skip
    return DriverLibrary(
        fit.style, library.risks, library.temperature,
        {**(meta or {}), "fit": fit_meta, "source": "recorded train split"},
    )  # fmt: skip
