"""Benchmark faster solver paths against the product: their time and how far S(p) moves.

The goal (DESIGN §16) is a solver at the floor's scale whose results equal the product's (fatrop
from the previous step's shifted plan): inputs to 1e-6, posteriors to 1e-6. This measures
candidate paths on the risk profile S(p) identification is built from (13 risks,
:func:`drivestyle.irl.driver.risk_profile.risk_profile`) of random-family SMPC demonstrations
(risks alternating 0.6 and 0.9, ``--seed``):

``product``          the compiled fatrop, as identification runs it;
``fatrop``           the same solver interpreted (equal to ``product``; the reference of
                     the option variants, as options are compiled into the generated solver);
``warm_duals``       interpreted fatrop keeping the guess's multipliers
                     (``warm_start_init_point``);
``warm_duals_mu``    … and μ_init 1e-6 with bound pushes 1e-8 (fewer barrier steps);
``continuation``     compiled fatrop, each lower risk's row warm-started from the same step
                     at the next larger risk (continuation in p) instead of from the
                     previous step at its own risk;
``ipm``              the experimental compiled interior-point batch (DESIGN §16), fatrop
                     where it fails (skipped without gcc).

Per path and demonstration: the wall time, the largest relative change of S over the
risks against its reference (``fatrop`` for the option variants, ``product`` for the
others), whether the best risk moved, and for ``ipm`` the share of rows handed to fatrop.
Writes JSON with the command.

Example:
    python scripts/bench_solver_paths.py --demos 4 --out runs/bench_solver_paths.json
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from drivestyle.agents import generate_demonstration
from drivestyle.common.cli import HelpFormatter, count, run_cli, seed
from drivestyle.common.io import check_output_file, write_json
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.irl.driver.driver_learning import teacher_forced
from drivestyle.irl.driver.driver_style import INPUT_SCALE, DriverStyle, check_demo, n_vehicles
from drivestyle.irl.driver.risk_profile import RISK_EVAL, risk_profile
from drivestyle.irl.driver.style_planner import Link, PlanRow, StylePlanner
from drivestyle.planning import smpc_problem as sp
from drivestyle.planning.description import SMPCConfig

STYLE_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
"""The profiled style: the SMPC expert's weights (its drivers are members of the class)."""
DEMO_RISKS = (0.6, 0.9)
"""Risks of the demonstrations, in turn."""
OPTION_PATHS: dict[str, dict[str, Any]] = {
    "fatrop": {},
    "warm_duals": {"warm_start_init_point": True},
    "warm_duals_mu": {
        "warm_start_init_point": True,
        "mu_init": 1e-6,
        "bound_push": 1e-8,
        "bound_frac": 1e-8,
        "warm_start_mult_bound_push": 1e-8,
    },
}
"""Interpreted fatrop with these options merged into the product's."""
EQUAL = 1e-6
"""The equality tolerance of that goal (relative, on S; module docstring)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--demos",
        type=count(10_000, 10.0, "demonstrations"),
        default=4,
        help="random-family demonstrations",
    )
    p.add_argument("--seed", type=seed, default=0, help="seed of the random-family scenarios")
    p.add_argument(
        "--out", type=Path, default=Path("runs/bench_solver_paths.json"), help="output JSON"
    )
    return p.parse_args(argv)


@contextmanager
def _fatrop_options(extra: dict[str, Any]) -> Iterator[None]:
    """Solvers built inside get ``extra`` merged into fatrop's options."""
    original = sp.solver_options

    def options(name: str, config: SMPCConfig, equality: np.ndarray) -> dict:
        out = original(name, config, equality)
        if name == "fatrop":
            out["fatrop"] = {**out["fatrop"], **extra}
        return out

    sp.solver_options = options
    try:
        yield
    finally:
        sp.solver_options = original


def continuation_profile(
    style: DriverStyle, demo: Demonstration, risks: tuple[float, ...], planner: StylePlanner
) -> tuple[float, ...]:
    """S(p) with continuation in p.

    As :func:`risk_profile`, but each lower risk's row is warm-started from the same step at
    the next larger risk instead of from the previous step at its own risk.
    """
    sc = check_demo(demo)
    r_top, active, top = teacher_forced(replace(style, risk=risks[-1]), demo, sc, planner)
    steps = [int(i) for i in np.flatnonzero(active)]
    constant = float(np.sum(r_top[~active] ** 2))
    rows: list[PlanRow] = []
    where: dict[tuple[int, int], int] = {}
    for j in range(len(risks) - 2, -1, -1):
        styled = replace(style, risk=risks[j])
        for k in steps:
            top_row = j == len(risks) - 2
            link = Link(given=top.points(k)) if top_row else Link(copy=where[(k, j + 1)])
            where[(k, j)] = len(rows)
            rows.append(PlanRow(demo.ev[k], demo.vehicles[k], styled, link))
    ssr = [float(np.sum(r_top**2))] * len(risks)
    if rows:
        u0 = planner.solve_rows(rows, sc).u0
        scale = np.asarray(INPUT_SCALE)
        for j in range(len(risks) - 1):
            u = np.array([u0[where[(k, j)]] for k in steps])
            ssr[j] = constant + float(np.sum(((u - demo.u[steps]) / scale) ** 2))
    return tuple(ssr)


def _timed(fn: Callable[[], tuple[float, ...]]) -> tuple[tuple[float, ...], float]:
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def _compare(ssr: tuple[float, ...], ref: tuple[float, ...]) -> dict[str, Any]:
    a, b = np.asarray(ssr), np.asarray(ref)
    rel = float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-12)))
    return {
        "max_rel_change": rel,
        "equal": rel <= EQUAL,
        "best_risk_moved": int(np.argmin(a)) != int(np.argmin(b)),
    }


def measure(demo: Demonstration, style: DriverStyle) -> dict[str, dict[str, Any]]:
    """Every path on one demonstration (module docstring)."""
    sc, M = demo.scenario, n_vehicles(demo)
    risks = RISK_EVAL
    out: dict[str, dict[str, Any]] = {}

    def profile(planner: StylePlanner) -> tuple[float, ...]:
        return risk_profile(style, demo, risks, planner).ssr

    product = StylePlanner(sc, 10, M)
    profile(product)  # warm-up: nothing left to build
    ref, wall = _timed(lambda: profile(product))
    out["product"] = {"wall_s": wall, "ssr": list(ref)}
    planners = {}
    for name, extra in OPTION_PATHS.items():
        with _fatrop_options(extra):
            planners[name] = StylePlanner(sc, 10, M, compiled=False)
    fatrop_ref: tuple[float, ...] = ()
    for name, planner in planners.items():
        profile(planner)
        ssr, wall = _timed(partial(profile, planner))
        if name == "fatrop":  # the interpreted product: equal to the compiled one
            fatrop_ref = ssr
            out[name] = {"wall_s": wall, **_compare(ssr, ref)}
        else:
            out[name] = {"wall_s": wall, **_compare(ssr, fatrop_ref)}
    ssr, wall = _timed(lambda: continuation_profile(style, demo, risks, product))
    out["continuation"] = {"wall_s": wall, **_compare(ssr, ref)}
    ipm = StylePlanner(sc, 10, M, ipm=True)
    if ipm.fast is not None:
        profile(ipm)
        ipm.fallbacks = 0
        solves = [0]
        original = ipm.solve_rows

        def counted(rows: Any, scenario: Any, fallback: bool = True) -> Any:
            solves[0] += len(rows)
            return original(rows, scenario, fallback)

        ipm.solve_rows = counted  # type: ignore[method-assign]
        ssr, wall = _timed(lambda: profile(ipm))
        out["ipm"] = {"wall_s": wall, "fallback_share": ipm.fallbacks / max(solves[0], 1),
                      **_compare(ssr, ref)}  # fmt: skip
    return out


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out)
    rng = np.random.default_rng(args.seed)
    style = DriverStyle(STYLE_WEIGHTS)
    demos = [
        generate_demonstration(DEMO_RISKS[i % len(DEMO_RISKS)], ScenarioRanges().sample(rng))[0]
        for i in range(args.demos)
    ]
    per_demo = [measure(d, style) for d in tqdm(demos, desc="demonstrations")]
    paths = [p for p in per_demo[0] if p != "product"]
    summary = {}
    for name in paths:
        reference = "fatrop" if name in OPTION_PATHS and name != "fatrop" else "product"
        ratios = [d[name]["wall_s"] / d[reference]["wall_s"] for d in per_demo if name in d]
        rows = [d[name] for d in per_demo if name in d]
        summary[name] = {
            "reference": reference,
            "wall_over_reference_median": float(np.median(ratios)),
            "demos_equal": sum(r["equal"] for r in rows),
            "demos_best_risk_moved": sum(r["best_risk_moved"] for r in rows),
            "max_rel_change": max(r["max_rel_change"] for r in rows),
        }
        if name == "ipm":
            summary[name]["fallback_share_range"] = [
                min(r["fallback_share"] for r in rows),
                max(r["fallback_share"] for r in rows),
            ]
    result = {
        "demos": args.demos,
        "seed": args.seed,
        "demo_risks": [float(d.meta.get("risk", float("nan"))) for d in demos],
        "equal_tolerance": EQUAL,
        "summary": summary,
        "per_demo": per_demo,
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                    "python": platform.python_version(), "load": os.getloadavg()},
    }  # fmt: skip
    write_json(args.out, result, [sys.argv[0], *(argv or sys.argv[1:])])
    product_s = float(np.median([d["product"]["wall_s"] for d in per_demo]))
    print(f"product (compiled fatrop): S(p) on 13 risks in {product_s:.2f} s (median)")
    for name, s in summary.items():
        print(
            f"{name:13s} time x{s['wall_over_reference_median']:.2f} of {s['reference']}; "
            f"S(p) equal (<= {EQUAL:g}) on {s['demos_equal']}/{args.demos}, best risk moved on "
            f"{s['demos_best_risk_moved']}, largest relative change {s['max_rel_change']:.2g}"
            + (
                f"; rows to fatrop {s['fallback_share_range'][0]:.0%}–"
                f"{s['fallback_share_range'][1]:.0%}"
                if "fallback_share_range" in s
                else ""
            )
        )
    print(f"wrote {args.out}")
    return result


if __name__ == "__main__":
    run_cli(main)
