"""Benchmark ME-IRL on the paper demonstration: whole learning runs and inner solves.

For each feature set (base, reactive) it times ``MaxEntIRL.learn`` (``learn_wall_s``:
the outer loop including every inner solve, excluding interpreter start-up and the
one-off CasADi build, which is reported separately as ``build_s``) and the median inner
solve, over ``--repeats`` runs; the median over runs is reported.

With ``--library DIR`` (a driver library, build-style-library's default, or a paper-model
one) it also times identification (``identify_s_median`` over ``--identify N`` fresh
random-family demonstrations of random grid risks, seeded).

``driver`` (the default style model, DESIGN §15): on every step of the paper demonstration
the planner's NLP is solved by the product solver (fatrop generated as C, cached on disk)
and by IPOPT from the identical guess (``ipopt_over_product``); ``newton_step_floor_ms``
is one compiled Newton step of the same NLP alone (evaluation, Riccati factorisation and
both Mehrotra solves: :mod:`drivestyle.planning.plan_solver`); identification of
``--identify`` random-family demonstrations with an in-memory driver library; a fresh
process's time to its first identification (``second_process_s``, the compiled library
already on disk) and its peak resident memory; ``--learn`` also times ``learn_driver`` on
the paper demonstration (all weights and the risk) and, with the population's cost given
(``fit_weights=False``), the risk of three SMPC drivers of continuous risk.

Example:
    python scripts/bench_irl.py --library runs/library_reactive --out runs/bench_irl.json
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from drivestyle.agents import generate_demonstration
from drivestyle.common.cli import HelpFormatter, positive_int, run_cli, seed
from drivestyle.common.io import check_output_file, write_json
from drivestyle.envs import load_demonstration, save_demonstration
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.irl import FeatureConfig, IRLConfig, MaxEntIRL
from drivestyle.irl.driver.driver_learning import learn_driver
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.driver.style_planner import StylePlanner
from drivestyle.irl.identification.library import DriverLibrary, load_any_library
from drivestyle.irl.identification.posterior import identify
from drivestyle.planning.plan_solver import IPMOptions, bounds_vector, compiled_solver


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--out", type=Path, default=Path("runs/bench_irl.json"), help="output JSON")
    p.add_argument("--demo", type=Path, help="demonstration (default: generate the paper's)")
    p.add_argument("--repeats", type=positive_int, default=5, help="learning runs per feature set")
    p.add_argument("--library", type=Path, help="also time identification with this library")
    p.add_argument(
        "--identify", type=positive_int, default=20, help="demonstrations to identify (--library)"
    )
    p.add_argument("--seed", type=seed, default=0, help="seed of the identified demonstrations")
    p.add_argument(
        "--learn", action="store_true", help="also time learn_driver on the paper demonstration"
    )
    return p.parse_args(argv)


DRIVER_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
"""The SMPC expert's weights: the driver style the benchmark plans with."""
LIBRARY_RISKS = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
"""Risks of the in-memory driver library."""

_SECOND_PROCESS = """
import resource, sys, time
t0 = time.perf_counter()
import numpy as np
from drivestyle.envs import load_demonstration
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.posterior import identify
from drivestyle.irl.identification.library import DriverLibrary
demo = load_demonstration(sys.argv[1])
lib = DriverLibrary(style=DriverStyle(%r, risk=0.7), risks=%r)
t1 = time.perf_counter()
identify(demo, lib)
t2 = time.perf_counter()
print(t1 - t0, t2 - t0, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
"""


def bench_driver(demo, n_identify: int, seed: int, learn: bool) -> dict:
    """The default style model's numbers (module docstring)."""
    style = DriverStyle(DRIVER_WEIGHTS, risk=0.7)
    sc = demo.scenario
    t0 = time.perf_counter()
    planner = StylePlanner(sc, compiled=True)
    build_s = time.perf_counter() - t0
    product, ipopt, diffs = [], [], []
    previous = None
    for k in range(demo.n - 1):
        p = planner.parameters(demo.ev[k], demo.vehicles[k], style, sc)
        guess = planner.guess(demo.ev[k], previous)
        bounds = planner.bounds(sc)
        t0 = time.perf_counter()
        sol = planner.problem.solve("fatrop", p, guess, bounds)
        product.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        ref = planner.problem.solve("ipopt", p, guess, bounds)
        ipopt.append(time.perf_counter() - t0)
        diffs.append(float(np.max(np.abs(sol.point.w[planner.layout.iu[0]]
                                         - ref.point.w[planner.layout.iu[0]]))))  # fmt: skip
        previous = sol.point
    out: dict = {
        "planner_build_s": build_s,
        "compiled": "fatrop" in planner.problem._external,
        "inner_solve_ms_median": 1e3 * float(np.median(product)),
        "ipopt_solve_ms_median": 1e3 * float(np.median(ipopt)),
        "ipopt_over_product": float(np.median(ipopt) / np.median(product)),
        "max_input_difference_to_ipopt": max(diffs),
        "goal": {"inner_solve_ms": 0.1, "identify_s": 0.05, "learn_risk_cost_given_s": 0.03,
                 "second_process_s": 2.0, "rss_mb": 500},
    }  # fmt: skip
    fast = compiled_solver(planner.config, sc, IPMOptions(max_iter=1))
    if fast is not None:
        n = 2000
        states = np.tile(fast.state_from(planner.guess(demo.ev[5], None)), (n, 1))
        P = np.tile(planner.parameters(demo.ev[5], demo.vehicles[5], style, sc), (n, 1))
        bnd = np.tile(bounds_vector(sc), (n, 1))
        zeros = np.zeros(n, np.int32)
        t0 = time.perf_counter()
        fast.solve_batch(states, P, bnd, zeros - 1, zeros, zeros.copy())
        out["newton_step_floor_ms"] = 1e3 * (time.perf_counter() - t0) / n
        out["product_over_floor"] = out["inner_solve_ms_median"] / out["newton_step_floor_ms"]
    rng = np.random.default_rng(seed)
    library = DriverLibrary(style=style, risks=LIBRARY_RISKS)
    demos = [generate_demonstration(float(rng.choice((0.6, 0.9))), ScenarioRanges().sample(rng))[0]
             for _ in range(n_identify)]  # fmt: skip
    identify(demos[0], library)  # first call: nothing left to build
    times = []
    for d in tqdm(demos, desc="identify (driver)", leave=False):
        t0 = time.perf_counter()
        identify(d, library)
        times.append(time.perf_counter() - t0)
    out["identify_s_median"] = float(np.median(times))
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "demo.npz")
        save_demonstration(demos[0], path)
        code = _SECOND_PROCESS % (DRIVER_WEIGHTS, LIBRARY_RISKS)
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", code, path], capture_output=True, text=True,
                              check=True)  # fmt: skip
        total = time.perf_counter() - t0
    ready, first, rss = (float(v) for v in proc.stdout.split())
    out["second_process"] = {"ready_s": ready, "first_identification_s": first,
                             "wall_s": total, "peak_rss_mb": rss}  # fmt: skip
    if learn:
        t0 = time.perf_counter()
        fit = learn_driver([demo])
        out["learn_one_demo_s"] = time.perf_counter() - t0
        out["learned_risk"] = fit.style.risk
        # the unit of the learning goal (RESULTS §15, ≤ 30 ms): one driver's own parameter
        # (its risk) with the population's cost given, on SMPC drivers of continuous risk
        # (off the profile grid)
        personal, errors = [], []
        for _ in tqdm(range(3), desc="learn risk (cost given)", leave=False):
            true = float(rng.uniform(0.55, 0.95))
            d = generate_demonstration(true, ScenarioRanges().sample(rng))[0]
            t0 = time.perf_counter()
            fit = learn_driver([d], initial=style, fit_weights=False)
            personal.append(time.perf_counter() - t0)
            errors.append(abs(fit.style.risk - true))
        out["learn_risk_cost_given_s_median"] = float(np.median(personal))
        out["learn_risk_cost_given_abs_error_max"] = float(max(errors))
    return out


def time_identification(library_dir: Path, n: int, seed: int) -> dict:
    """Median wall time of identification on n new demos.

    (:func:`drivestyle.irl.identification.posterior.identify`)
    """
    library = load_any_library(library_dir)
    rng = np.random.default_rng(seed)
    times = []
    for _ in tqdm(range(n), desc="identify", leave=False):
        scenario = ScenarioRanges().sample(rng)
        risk = float(rng.choice(library.risks))
        demo, _ = generate_demonstration(risk, scenario)
        t0 = time.perf_counter()
        identify(demo, library)
        times.append(time.perf_counter() - t0)
    return {
        "identify_s_median": float(np.median(times)),
        "identify_s_p95": float(np.percentile(times, 95)),
        "n": n,
        "library_build_wall_s": library.meta.get("build_wall_s"),
        "goal": {"identify_s_median": 0.2, "library_build_wall_s": 60.0},
    }


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out, inputs=[args.demo, args.library])
    demo = load_demonstration(args.demo) if args.demo else generate_demonstration(0.7)[0]
    result = {
        "repeats": args.repeats,
        "goal": {"inner_solve_ms_median": 5.0, "learn_wall_s": 1.0},
        "machine": {
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
        },
    }
    for name in ("base", "reactive"):
        walls: list[float] = []
        inner: list[float] = []
        builds: list[float] = []
        iters: list[int] = []
        for _ in tqdm(range(args.repeats), desc=name, leave=False):
            t0 = time.perf_counter()
            learner = MaxEntIRL(demo, FeatureConfig(feature_set=name), IRLConfig())
            builds.append(time.perf_counter() - t0)
            res = learner.learn()
            walls.append(res.wall_time_s)
            inner += res.inner_solve_ms
            iters.append(res.iterations)
        result[name] = {
            "learn_wall_s": float(np.median(walls)),
            "build_s": float(np.median(builds)),
            "inner_solve_ms_median": float(np.median(inner)),
            "inner_solve_ms_p95": float(np.percentile(inner, 95)),
            "n_inner_solves": len(inner) // args.repeats,
            "iterations": int(np.median(iters)),
        }
    if args.library is not None:
        result["identification"] = time_identification(args.library, args.identify, args.seed)
    result["driver"] = bench_driver(demo, args.identify, args.seed, args.learn)
    result["load_average"] = [round(x, 2) for x in os.getloadavg()]
    result["meets_goal"] = all(
        result[n]["inner_solve_ms_median"] <= 5.0 and result[n]["learn_wall_s"] <= 1.0
        for n in ("base", "reactive")
    )
    write_json(args.out, result, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"{'features':9s} {'learn s':>8s} {'build s':>8s} {'inner med ms':>13s} "
        f"{'inner p95 ms':>13s} {'solves':>7s} {'iters':>6s}"
    )
    for name in ("base", "reactive"):
        r = result[name]
        print(
            f"{name:9s} {r['learn_wall_s']:8.3f} {r['build_s']:8.3f} "
            f"{r['inner_solve_ms_median']:13.2f} {r['inner_solve_ms_p95']:13.2f} "
            f"{r['n_inner_solves']:7d} {r['iterations']:6d}"
        )
    print(
        (
            f"identification: median {result['identification']['identify_s_median']:.2f} s "
            f"(goal 0.2 s)\n"
            if "identification" in result
            else ""
        )
        + f"goal (inner median <= 5 ms, learning <= 1 s) "
        f"{'met' if result['meets_goal'] else 'NOT met'}; wrote {args.out}"
    )
    drv = result["driver"]
    print(
        f"driver model: inner solve {drv['inner_solve_ms_median']:.3f} ms (goal 0.1), IPOPT "
        f"{drv['ipopt_solve_ms_median']:.3f} ms (x{drv['ipopt_over_product']:.1f}), Newton-step "
        f"floor {drv.get('newton_step_floor_ms', float('nan')):.4f} ms; identification "
        f"{drv['identify_s_median']:.3f} s (goal 0.05); second process first identification "
        f"{drv['second_process']['first_identification_s']:.2f} s (goal 2), peak RSS "
        f"{drv['second_process']['peak_rss_mb']:.0f} MB (goal 500)"
        + (
            f"; learning a driver's risk with the cost given "
            f"{drv['learn_risk_cost_given_s_median']:.2f} s (goal 0.03)"
            if "learn_risk_cost_given_s_median" in drv
            else ""
        )
    )
    return result


if __name__ == "__main__":
    run_cli(main)
