"""Profile the inner solvers: where the time of an inner solve goes today (DESIGN §16).

Three measurements, each as shares of its wall time (the machine is shared: shares are
steadier than absolute times, and the load average is recorded with them):

(a) the paper model on the paper demonstration: ``MaxEntIRL.learn`` with its damped-Newton
    inner problem (``drivestyle.irl.paper.inner``), split into CasADi evaluation of the value,
    gradient and Hessian, line-search trial evaluations, the Cholesky factorisations and
    solves, the sensitivity (feature Jacobian and H⁻¹Jᵀ), the numpy copies around each
    CasADi call and the remaining Python; with the Newton steps per inner solve and the
    top functions of a cProfile run.
(b1) the default driver model: ``step_residuals`` of a fixed style on the paper
    demonstration, per NLP solve: fatrop's iterations and its own timers (function
    evaluation, search direction, initialisation, the rest), CasADi's call around fatrop,
    and the Python around the call (warm start, parameters, bounds, constraint check, …).
(b2) driver-model identification: ``identify_driver`` with an in-memory driver library of
    the same style on random-family demonstrations (risks alternating 0.6 and 0.9):
    solves per identification and the same split.

(b3) ``--recorded N``: the same as (b2) for the first N recorded CATS lane changes of the
    benchmark's extraction of ``--data-dir``'s CATS sample, seen as identification sees them
    (the driver model's recorded bounds beyond the scenario's heading bound).

(b1) and (b2) run with the uncompiled planner and with the gcc-compiled (jit) one.
The timers are wrappers installed around the solvers' functions for the profiled calls
only (the solvers' code is not changed); ``instrumentation_overhead`` compares with
uninstrumented runs of the same work.

The script is one concept at ≈ 700 lines, a measurement, and nothing in it belongs in the
library: its timers (``_Clock``, ``_patched``, ``_SolverProbe``) are wrappers around
private functions of the code measured (``InnerProblem``'s Newton loop and Cholesky calls,
``BufferedFunction``, ``SMPCProblem._solver_call`` and fatrop's stats, the module globals of
:mod:`drivestyle.irl.driver.style_planner`), correct only for those call graphs and used by
no library code or other command, and its breakdowns and tables name this profile's own
categories.

Example:
    python scripts/profile_inner.py --out runs/profile_inner.json
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from drivestyle.agents import generate_demonstration
from drivestyle.common.cli import HelpFormatter, nonnegative_int, positive_int, run_cli, seed
from drivestyle.common.io import check_output_file, write_json
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.irl import FeatureConfig, IRLConfig, MaxEntIRL
from drivestyle.irl.driver import style_planner as splan
from drivestyle.irl.driver.driver_learning import step_residuals
from drivestyle.irl.driver.driver_style import DriverStyle, n_vehicles
from drivestyle.irl.driver.risk_profile import refined_profile
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.posterior import identify_driver
from drivestyle.irl.paper import inner as inner_mod
from drivestyle.planning import smpc_problem as sp
from drivestyle.planning.buffered import BufferedFunction
from drivestyle.recorded.benchmark import DEFAULT_DATA_DIR
from drivestyle.recorded.real_data import check_data_dir

STYLE_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
"""The driver style profiled: the SMPC expert's own cost weights [w_y, w_φ, w_v, w_a, w_δ]."""
LIBRARY_RISKS = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
"""Risk grid of the in-memory driver library (the default build's)."""
DEMO_RISKS = (0.6, 0.9)
"""Risks of the identified demonstrations, in turn."""
TOP = 12
"""cProfile entries kept (by own time)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--out", type=Path, default=Path("runs/profile_inner.json"), help="output JSON")
    p.add_argument(
        "--repeats",
        type=positive_int,
        default=5,
        help="profiled runs of each measurement (learning; step_residuals); medians reported",
    )
    p.add_argument(
        "--identify",
        type=positive_int,
        default=4,
        help="random-family demonstrations identified (risks alternate 0.6, 0.9)",
    )
    p.add_argument("--seed", type=seed, default=0, help="seed of the random-family scenarios")
    p.add_argument(
        "--recorded",
        type=nonnegative_int,
        default=0,
        help="also profile the identification of this many recorded CATS lane changes (the "
        "benchmark's extraction, seen as identification sees them), jit planner",
    )
    p.add_argument(
        "--data-dir",
        type=Path,
        default=DEFAULT_DATA_DIR,
        help="folder holding cats-av-lanechange/ (--recorded)",
    )
    p.add_argument(
        "--no-jit",
        action="store_true",
        help="profile the uncompiled driver planner only (no gcc build)",
    )
    return p.parse_args(argv)


# ---------------------------------------------------------------------------- timers
class _Clock:
    """Exclusive wall time per category of nested timed calls.

    A timed call's time is its own minus that of the timed calls inside it, so the
    categories of one measured region add up to the region's time minus untimed code.
    """

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)
        self._children: list[float] = []

    def timed(self, fn: Callable, category: str | Callable[[tuple], str]) -> Callable:
        """``fn`` wrapped to add its exclusive time to ``category`` (or ``category(args)``)."""

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            children = self._children
            children.append(0.0)
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                dt = time.perf_counter() - t0
                nested = children.pop()
                name = category if isinstance(category, str) else category(args)
                self.seconds[name] += dt - nested
                self.calls[name] += 1
                if children:
                    children[-1] += dt

        return wrapper

    def total(self) -> float:
        """Sum over categories [s]."""
        return float(sum(self.seconds.values()))


@contextmanager
def _patched(patches: list[tuple[Any, str, Callable]]) -> Iterator[None]:
    """Set ``obj.name = value`` for each patch for the block, then restore the originals."""
    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in patches]
    try:
        for obj, name, value in patches:
            setattr(obj, name, value)
        yield
    finally:
        for obj, name, value in reversed(saved):
            setattr(obj, name, value)


def _cprofile_top(fn: Callable[[], Any], n: int = TOP) -> dict[str, Any]:
    """Run ``fn`` under cProfile: its total and the ``n`` functions with most own time."""
    prof = cProfile.Profile()
    prof.enable()
    fn()
    prof.disable()
    stats = pstats.Stats(prof)
    rows = []
    for (file, line, func), (_, ncalls, tottime, cumtime, _) in stats.stats.items():  # type: ignore[attr-defined]
        where = func if file == "~" else f"{Path(file).name}:{line}({func})"
        rows.append(
            {"function": where, "calls": ncalls, "tottime_s": tottime, "cumtime_s": cumtime}
        )
    rows.sort(key=lambda r: -r["tottime_s"])
    total = float(stats.total_tt)  # type: ignore[attr-defined]
    for r in rows:
        r["share"] = r["tottime_s"] / total if total > 0 else float("nan")
    return {"total_s": total, "top": rows[:n]}


def _shares(parts: dict[str, float], total: float) -> dict[str, dict[str, float]]:
    return {
        k: {"s": v, "share": v / total if total > 0 else float("nan")} for k, v in parts.items()
    }


# ---------------------------------------------------------------------------- (a) paper model
def profile_paper(demo: Demonstration, repeats: int) -> dict[str, Any]:
    """Where ``MaxEntIRL.learn``'s inner solves spend their time (module docstring, (a))."""
    t0 = time.perf_counter()
    learner = MaxEntIRL(demo, FeatureConfig(), IRLConfig())
    build_s = time.perf_counter() - t0
    learner.learn()  # warm-up: first calls allocate
    plain = [learner.learn().wall_time_s for _ in range(repeats)]

    clock = _Clock()
    newton_steps: list[int] = []  # per group solve
    solve_steps: list[int] = []  # per inner solve (both groups)
    in_newton = [False]

    def where() -> str:
        """Inside the Newton iterations, or after them (the sensitivity ∂f/∂θ)."""
        return "newton" if in_newton[0] else "sens"

    kind_of: dict[int, str] = {}  # id(BufferedFunction) -> "fgh" | "fJ" | "f"
    patches: list[tuple[Any, str, Callable]] = []
    for problem in learner.problems:
        for fns in problem._fns.values():
            for buffered in fns:
                kind = buffered.fn.name().split("_")[0]
                kind_of[id(buffered)] = kind
                timed = clock.timed(buffered._eval, lambda a, k=kind: f"eval_{k}_{where()}")  # type: ignore[misc]
                patches.append((buffered, "_eval", timed))
    original_newton = inner_mod.newton_minimize
    original_solve = inner_mod.InnerProblem.solve

    def newton(*args: Any, **kwargs: Any) -> tuple[np.ndarray, int, bool]:
        in_newton[0] = True
        try:
            z, it, ok = original_newton(*args, **kwargs)
        finally:
            in_newton[0] = False
        newton_steps.append(it)
        return z, it, ok

    def solve(*args: Any, **kwargs: Any) -> inner_mod.InnerSolution:
        sol = original_solve(*args, **kwargs)
        solve_steps.append(sol.iterations)
        return sol

    def copy_category(args: tuple) -> str:
        return f"copy_{kind_of.get(id(args[0]), 'other')}_{where()}"

    patches += [
        (inner_mod, "newton_minimize", clock.timed(newton, "python_newton")),
        (inner_mod, "cho_factor", clock.timed(inner_mod.cho_factor, lambda a: f"chol_{where()}")),
        (inner_mod, "cho_solve", clock.timed(inner_mod.cho_solve, lambda a: f"chol_{where()}")),
        (BufferedFunction, "__call__", clock.timed(BufferedFunction.__call__, copy_category)),
        (
            inner_mod.InnerProblem,
            "features_of",
            clock.timed(inner_mod.InnerProblem.features_of, "features_exact"),
        ),
        (inner_mod.InnerProblem, "solve", clock.timed(solve, "python_solve")),
    ]
    walls, inner_ms, solves_per_learn = [], [], []  # type: ignore[var-annotated]
    first: list[int] = []  # index of each run's first solve (from the demonstration)
    with _patched(patches):
        for _ in range(repeats):
            first.append(len(solve_steps))
            res = learner.learn()
            walls.append(res.wall_time_s)
            inner_ms += res.inner_solve_ms
            solves_per_learn.append(len(res.inner_solve_ms))
    inner_total = clock.total()
    s = clock.seconds
    parts = {
        "casadi_eval_value_gradient_hessian": s["eval_fgh_newton"],
        "line_search_trial_values": s["eval_f_newton"] + s["copy_f_newton"],
        "cholesky_newton": s["chol_newton"],
        "numpy_copies_around_casadi": s["copy_fgh_newton"],
        "python_newton_loop": s["python_newton"],
        "sensitivity_casadi_eval": s["eval_fgh_sens"] + s["eval_fJ_sens"],
        "sensitivity_cholesky_and_copies": s["chol_sens"] + s["copy_fgh_sens"] + s["copy_fJ_sens"],
        "exact_features_numpy": s["features_exact"],
        "python_inner_solve": s["python_solve"],
    }
    n_newton = max(sum(newton_steps), 1)
    cprof = _cprofile_top(learner.learn)
    return {
        "features": list(learner.names),
        "build_s": build_s,
        "learn_s_median": float(np.median(walls)),
        "learn_s_plain_median": float(np.median(plain)),
        "instrumentation_overhead": float(np.median(walls) / np.median(plain) - 1.0),
        "inner_solves_per_learn": int(np.median(solves_per_learn)),
        "inner_solve_ms_median": float(np.median(inner_ms)),
        "inner_share_of_learn": inner_total / float(sum(walls)),
        "outer_loop_s_per_learn": (float(sum(walls)) - inner_total) / repeats,
        "newton_steps_per_group_median": float(np.median(newton_steps)),
        "newton_steps_per_solve_median": float(np.median(solve_steps)),
        "newton_steps_per_solve_max": int(np.max(solve_steps)),
        "newton_steps_first_solve": int(np.median([solve_steps[i] for i in first])),
        "line_search_trials_per_newton_step": clock.calls["eval_f_newton"] / n_newton,
        "calls": dict(clock.calls),
        "inner_total_s": inner_total,
        "breakdown": _shares(parts, inner_total),
        "groups": {
            "evaluation": (
                parts["casadi_eval_value_gradient_hessian"] + parts["sensitivity_casadi_eval"]
            )
            / inner_total,
            "factorisation": (s["chol_newton"] + s["chol_sens"]) / inner_total,
            "line_search": parts["line_search_trial_values"] / inner_total,
            "python_overhead": (
                parts["numpy_copies_around_casadi"]
                + s["copy_fgh_sens"]
                + s["copy_fJ_sens"]
                + parts["python_newton_loop"]
                + parts["python_inner_solve"]
            )
            / inner_total,
            "exact_features_numpy": parts["exact_features_numpy"] / inner_total,
        },
        "cprofile": cprof,
    }


# ---------------------------------------------------------------------------- (b) driver model
class _SolverProbe:
    """Records every NLP solver call: its wall time, iterations and fatrop's own timers."""

    def __init__(self, clock: _Clock) -> None:
        self.clock = clock
        self.records: list[dict[str, Any]] = []
        self._proxies: dict[tuple[int, str], tuple] = {}
        self._last_eval_s = float("nan")
        self._cumulative: dict[tuple[int, str], dict[str, float]] = {}

    def solver_call(self, original: Callable) -> Callable:
        """A replacement of ``SMPCProblem._solver_call`` returning timed proxies."""

        def call(problem: sp.SMPCProblem, name: str) -> tuple:
            key = (id(problem), name)
            if key not in self._proxies:
                buffer, evaluate = original(problem, name)
                try:
                    self._cumulative[key] = self._casadi_times(buffer.stats())
                except RuntimeError:  # a solver that has not run yet has no stats
                    self._cumulative[key] = {}
                self._proxies[key] = (
                    self._Stats(self, buffer, key, name),
                    self._timed(evaluate, name),
                )
            return self._proxies[key]

        return call

    def _timed(self, evaluate: Callable, name: str) -> Callable:
        inner = self.clock.timed(evaluate, f"solver_{name}")

        def run() -> None:
            t0 = time.perf_counter()
            try:
                inner()
            finally:
                self._last_eval_s = time.perf_counter() - t0

        return run

    @staticmethod
    def _casadi_times(stats: dict) -> dict[str, float]:
        return {k: float(v) for k, v in stats.items() if k.startswith("t_wall_nlp_")}

    class _Stats:
        """Stands in for the solver's buffer: ``stats()`` is timed and recorded."""

        def __init__(self, probe: _SolverProbe, buffer: Any, key: tuple, name: str) -> None:
            self.probe, self.buffer, self.key, self.name = probe, buffer, key, name
            self.stats = probe.clock.timed(self._stats, "solver_stats")

        def _stats(self) -> dict:
            stats = self.buffer.stats()
            probe = self.probe
            now = probe._casadi_times(stats)
            before = probe._cumulative[self.key]
            probe._cumulative[self.key] = now
            probe.records.append(
                {
                    "solver": self.name,
                    "wall_s": probe._last_eval_s,
                    "iterations": int(stats.get("iter_count", -1)),
                    "success": bool(stats.get("success", False)),
                    "fatrop": dict(stats.get("fatrop", {})),
                    "casadi_fn_s": sum(now[k] - before.get(k, 0.0) for k in now),
                }
            )
            return stats


def _driver_patches(clock: _Clock, probe: _SolverProbe) -> list[tuple[Any, str, Callable]]:
    planner = splan.StylePlanner
    return [
        (planner, "plan", clock.timed(planner.plan, "python_plan")),
        (planner, "bounds", clock.timed(planner.bounds, "bounds")),
        (splan, "constrained_vehicles", clock.timed(splan.constrained_vehicles, "parameters")),
        (splan, "nlp_parameters", clock.timed(splan.nlp_parameters, "parameters")),
        (splan, "warm_start", clock.timed(splan.warm_start, "warm_start")),
        (
            splan,
            "constraint_violation",
            clock.timed(splan.constraint_violation, "constraint_violation"),
        ),
        (sp.SMPCProblem, "solve", clock.timed(sp.SMPCProblem.solve, "python_smpc_solve")),
        (sp.SMPCProblem, "_solver_call", probe.solver_call(sp.SMPCProblem._solver_call)),
    ]


def _driver_breakdown(clock: _Clock, probe: _SolverProbe, total: float) -> dict[str, Any]:
    """Shares of ``total`` and per-solve statistics of one profiled driver region."""
    fat = [r for r in probe.records if r["solver"] == "fatrop"]
    f = {
        k: float(sum(r["fatrop"].get(k, 0.0) for r in fat))
        for k in (
            "time_total",
            "eval_hess_time",
            "eval_jac_time",
            "eval_cv_time",
            "eval_grad_time",
            "eval_obj_time",
            "compute_sd_time",
            "initialization_time",
        )
    }
    f_eval = sum(v for k, v in f.items() if k.startswith("eval_"))
    s = clock.seconds
    parts = {
        "fatrop_function_evaluation": f_eval,
        "fatrop_search_direction": f["compute_sd_time"],
        "fatrop_initialisation": f["initialization_time"],
        "fatrop_rest_line_search_updates": f["time_total"]
        - f_eval
        - f["compute_sd_time"]
        - f["initialization_time"],
        "casadi_nlpsol_call_around_fatrop": s["solver_fatrop"] - f["time_total"],
        "ipopt_retries": s["solver_ipopt"],
        "solver_stats_dict": s["solver_stats"],
        "python_smpc_solve_copies_checks": s["python_smpc_solve"],
        "warm_start": s["warm_start"],
        "parameters_vehicles": s["parameters"],
        "bounds": s["bounds"],
        "constraint_violation": s["constraint_violation"],
        "python_plan": s["python_plan"],
        "python_loop": s["python_loop"],
        "posterior": s["posterior"],
    }
    evaluation = {
        k.removeprefix("eval_").removesuffix("_time"): v
        for k, v in f.items()
        if k.startswith("eval_")
    }
    solver = s["solver_fatrop"] + s["solver_ipopt"]
    iters = [r["iterations"] for r in fat]
    walls = [r["wall_s"] * 1e3 for r in fat]
    return {
        "total_s": total,
        "solves": len(probe.records),
        "fatrop_solves": len(fat),
        "ipopt_retries": len(probe.records) - len(fat),
        "fatrop_failures": sum(not r["success"] for r in fat),
        "iterations_median": float(np.median(iters)) if iters else float("nan"),
        "iterations_mean": float(np.mean(iters)) if iters else float("nan"),
        "iterations_p95": float(np.percentile(iters, 95)) if iters else float("nan"),
        "solve_ms_median": float(np.median(walls)) if walls else float("nan"),
        "solve_ms_p95": float(np.percentile(walls, 95)) if walls else float("nan"),
        "ms_per_iteration": float(np.sum(walls) / max(np.sum(iters), 1)),
        "solver_share": solver / total,
        "python_share": 1.0 - solver / total,
        "fatrop_evaluation_by_function_s": evaluation,
        "casadi_t_wall_nlp_functions_s": float(sum(r["casadi_fn_s"] for r in fat)),
        "breakdown": _shares(parts, total),
        "unattributed_s": total - clock.total(),
    }


def profile_step_residuals(
    demo: Demonstration, style: DriverStyle, jit: bool, repeats: int
) -> dict[str, Any]:
    """(b1): ``step_residuals`` of ``style`` on ``demo`` with the planner of ``jit``."""
    t0 = time.perf_counter()
    # the interpreted fatrop (compiled=False): its stats carry the iteration counts and timers
    planner = splan.StylePlanner(demo.scenario, style.horizon, 1, jit=jit, compiled=False)
    build_s = time.perf_counter() - t0
    step_residuals(style, demo, planner)  # warm-up
    plain = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        step_residuals(style, demo, planner)
        plain.append(time.perf_counter() - t0)
    clock = _Clock()
    probe = _SolverProbe(clock)
    region = clock.timed(step_residuals, "python_loop")
    walls = []
    with _patched(_driver_patches(clock, probe)):
        for _ in range(repeats):
            t0 = time.perf_counter()
            region(style, demo, planner)
            walls.append(time.perf_counter() - t0)
    out = _driver_breakdown(clock, probe, float(sum(walls)))
    out["cprofile"] = _cprofile_top(lambda: step_residuals(style, demo, planner))
    return {
        "jit": planner.config.jit,
        "build_s": build_s,
        "steps": demo.n - 1,
        "wall_s_median": float(np.median(walls)),
        "wall_s_plain_median": float(np.median(plain)),
        "instrumentation_overhead": float(np.median(walls) / np.median(plain) - 1.0),
        "solves_per_call": len(probe.records) // repeats,
        **out,
    }


def profile_identification(
    demos: list[Demonstration], library: DriverLibrary, jit: bool
) -> dict[str, Any]:
    """(b2): ``identify_driver`` of each demonstration (refined profile, ``jit``'s planner)."""
    planners = [
        splan.StylePlanner(d.scenario, library.style.horizon, n_vehicles(d), jit=jit,
                           compiled=False)
        for d in demos
    ]  # fmt: skip

    identify = [identify_driver]  # timed as "posterior" while profiled

    def identification(demo: Demonstration, planner: splan.StylePlanner) -> None:
        profile = refined_profile(library.style, demo, planner=planner)
        identify[0](demo, library, profiles=[profile])

    identification(demos[0], planners[0])  # warm-up
    plain = []
    for d, pl in zip(demos, planners, strict=True):
        t0 = time.perf_counter()
        identification(d, pl)
        plain.append(time.perf_counter() - t0)
    clock = _Clock()
    probe = _SolverProbe(clock)
    region = clock.timed(identification, "python_loop")
    walls, solves = [], []
    identify[0] = clock.timed(identify_driver, "posterior")
    with _patched(_driver_patches(clock, probe)):
        for d, pl in zip(demos, planners, strict=True):
            before = len(probe.records)
            t0 = time.perf_counter()
            region(d, pl)
            walls.append(time.perf_counter() - t0)
            solves.append(len(probe.records) - before)
    out = _driver_breakdown(clock, probe, float(sum(walls)))
    return {
        "jit": planners[0].config.jit,
        "demos": len(demos),
        "demo_risks": [float(d.meta.get("risk", float("nan"))) for d in demos],
        "identify_s_median": float(np.median(walls)),
        "identify_s_plain_median": float(np.median(plain)),
        "instrumentation_overhead": float(np.median(walls) / np.median(plain) - 1.0),
        "solves_per_identification": solves,
        **out,
    }


# ---------------------------------------------------------------------------- report
_PAPER_ROWS = {
    "casadi_eval_value_gradient_hessian": "Newton: CasADi value, gradient, Hessian",
    "line_search_trial_values": "Newton: line-search trial values",
    "cholesky_newton": "Newton: Cholesky factorise + solve",
    "numpy_copies_around_casadi": "Newton: numpy copies around CasADi",
    "python_newton_loop": "Newton: Python loop",
    "sensitivity_casadi_eval": "sensitivity: CasADi Hessian + feature Jacobian",
    "sensitivity_cholesky_and_copies": "sensitivity: Cholesky H⁻¹Jᵀ, copies",
    "exact_features_numpy": "exact features of r* (numpy)",
    "python_inner_solve": "Python: InnerProblem.solve",
}
_DRIVER_ROWS = {
    "fatrop_function_evaluation": "fatrop: function evaluation",
    "fatrop_search_direction": "fatrop: search direction (Riccati)",
    "fatrop_initialisation": "fatrop: initialisation",
    "fatrop_rest_line_search_updates": "fatrop: rest (line search, updates)",
    "casadi_nlpsol_call_around_fatrop": "CasADi nlpsol call around fatrop",
    "ipopt_retries": "IPOPT retries",
    "solver_stats_dict": "solver stats() dict",
    "python_smpc_solve_copies_checks": "SMPCProblem.solve: checks, copies",
    "warm_start": "warm start construction",
    "parameters_vehicles": "parameter packing (vehicles, p)",
    "bounds": "bounds lookup",
    "constraint_violation": "constraint_violation",
    "python_plan": "Python: StylePlanner.plan",
    "python_loop": "Python: loop (step_residuals / risk_profile)",
    "posterior": "identify_driver: posterior from the profile",
}


def _print(result: dict[str, Any]) -> None:
    a = result["paper"]
    print(
        f"(a) paper model, {len(a['features'])} features: learn {a['learn_s_median']:.3f} s "
        f"(plain {a['learn_s_plain_median']:.3f} s), {a['inner_solves_per_learn']} inner solves, "
        f"median {a['inner_solve_ms_median']:.2f} ms, Newton steps/solve "
        f"{a['newton_steps_per_solve_median']:.1f} (first {a['newton_steps_first_solve']}, "
        f"max {a['newton_steps_per_solve_max']}), "
        f"inner = {a['inner_share_of_learn']:.0%} of learning"
    )
    for key, label in _PAPER_ROWS.items():
        print(f"  {label:46s} {a['breakdown'][key]['share']:6.1%}")
    driver = result["driver"]
    cols = list(driver)
    parts = [("step_residuals", "(b1) step_residuals"), ("identification", "(b2)")]
    if "recorded" in result:
        parts.append(("recorded", "(b3) recorded CATS"))
    for part, title in parts:
        if part == "recorded":
            names, runs = ["jit" if result["recorded"]["jit"] else "no_jit"], [result["recorded"]]
        else:
            names, runs = cols, [driver[c][part] for c in cols]
        if part == "step_residuals":
            calls = [
                f"{r['solves_per_call']} solves in {r['wall_s_median'] * 1e3:.1f} ms" for r in runs
            ]
        else:
            calls = [
                f"{np.median(r['solves_per_identification']):.0f} solves per identification "
                f"in {r['identify_s_median']:.3f} s"
                for r in runs
            ]
        print(
            f"{title}: "
            + "; ".join(
                f"jit={r['jit']}: {c}, iterations/solve {r['iterations_median']:.0f} "
                f"(mean {r['iterations_mean']:.1f}), {r['solve_ms_median']:.2f} ms/solve, "
                f"{r['ms_per_iteration'] * 1e3:.0f} µs/iteration, in the solver "
                f"{r['solver_share']:.0%}"
                for r, c in zip(runs, calls, strict=True)
            )
        )
        print(f"  {'':46s} " + " ".join(f"{c:>10s}" for c in names))
        for key, label in _DRIVER_ROWS.items():
            shares = [r["breakdown"][key]["share"] for r in runs]
            print(f"  {label:46s} " + " ".join(f"{x:10.1%}" for x in shares))
    print(f"load average {result['load_average_before']} -> {result['load_average_after']}")


def main(argv: list[str] | None = None) -> dict:
    """Run the profile; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out, inputs=[args.data_dir if args.recorded > 0 else None])
    if args.recorded > 0:  # found before the work, not after it
        check_data_dir(args.data_dir, ("cats",), DEFAULT_DATA_DIR, ", or drop --recorded")
    load_before = [round(x, 2) for x in os.getloadavg()]
    demo = generate_demonstration(0.7)[0]
    result: dict[str, Any] = {
        "repeats": args.repeats,
        "seed": args.seed,
        "style": {"weights": list(STYLE_WEIGHTS), "risk": 0.7},
        "load_average_before": load_before,
        "machine": {
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
        },
    }
    bar = tqdm(total=1 + 2 * (1 if args.no_jit else 2), desc="profile", leave=False)
    result["paper"] = profile_paper(demo, args.repeats)
    bar.update(1)
    rng = np.random.default_rng(args.seed)
    demos = [
        generate_demonstration(DEMO_RISKS[i % len(DEMO_RISKS)], ScenarioRanges().sample(rng))[0]
        for i in range(args.identify)
    ]
    style = DriverStyle(weights=STYLE_WEIGHTS, risk=0.7)
    library = DriverLibrary(style=style, risks=LIBRARY_RISKS)
    result["driver"] = {}
    for jit in (False,) if args.no_jit else (False, True):
        key = "jit" if jit else "no_jit"
        entry = {"step_residuals": profile_step_residuals(demo, style, jit, args.repeats)}
        bar.update(1)
        entry["identification"] = profile_identification(demos, library, jit)
        bar.update(1)
        result["driver"][key] = entry
    if args.recorded > 0:
        from drivestyle.recorded.benchmark import recorded_episodes
        from drivestyle.recorded.real_data import recorded_view

        episodes = recorded_episodes(str(args.data_dir), "cats")[: args.recorded]
        rec = [recorded_view(d) for _, _, d in episodes]
        result["recorded"] = profile_identification(rec, library, jit=not args.no_jit)
        result["recorded"]["episodes"] = [e for e, _, _ in episodes]
    bar.close()
    result["load_average_after"] = [round(x, 2) for x in os.getloadavg()]
    write_json(args.out, result, [sys.argv[0], *(argv or sys.argv[1:])])
    _print(result)
    print(f"wrote {args.out}")
    return result


if __name__ == "__main__":
    run_cli(main)
