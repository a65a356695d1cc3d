"""Benchmark ME-IRL on the paper demonstration: whole learning runs and inner solves.

For each feature set (base, reactive) it times ``MaxEntIRL.learn`` (``learn_wall_s``:
the outer loop including every inner solve, excluding interpreter start-up and the
one-off CasADi build, which is reported separately as ``build_s``) and the median inner
solve, over ``--repeats`` runs; the median over runs is reported.

With ``--library DIR`` it also times identification (``identify_s_median`` over
``--identify N`` fresh random-family demonstrations of random grid risks, seeded).

Example:
    python scripts/bench_irl.py --library runs/library_reactive --out runs/bench_irl.json
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from drivestyle.agents import generate_demonstration
from drivestyle.common.cli import positive_int, run_cli
from drivestyle.common.io import check_output_file, write_json
from drivestyle.envs import load_demonstration
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.irl import FeatureConfig, IRLConfig, MaxEntIRL
from drivestyle.irl.identification import identify
from drivestyle.irl.library import load_library


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--out", type=Path, default=Path("runs/bench_irl.json"), help="output JSON")
    p.add_argument("--demo", type=Path, help="demonstration (default: generate the paper's)")
    p.add_argument("--repeats", type=positive_int, default=5, help="learning runs per feature set")
    p.add_argument("--library", type=Path, help="also time identification with this library")
    p.add_argument(
        "--identify", type=positive_int, default=20, help="demonstrations to identify (--library)"
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the identified demonstrations")
    return p.parse_args(argv)


def time_identification(library_dir: Path, n: int, seed: int) -> dict:
    """Median wall time of :func:`drivestyle.irl.identification.identify` on n new demos."""
    library = load_library(library_dir)
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
    check_output_file(args.out)
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
    return result


if __name__ == "__main__":
    run_cli(main)
