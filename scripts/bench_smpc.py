"""Benchmark the SMPC expert: milliseconds per closed-loop step.

Times every solver call (``SMPCExpert.plan(obs).report.solve_ms``: the NLP solve including
CasADi's argument handling, not the Python around it) over repeated closed loops of the
paper scenario and over a batch of random scenarios, for fatrop (structure-exploiting)
and, in the same run, plain warm-started IPOPT on the identical NLP. The whole measurement
is repeated ``--trials`` times and each statistic is the median over trials. Prints a
table and writes JSON with median_ms, p95_ms, n_steps, solver, ipopt_median_ms,
speedup_vs_ipopt.

With ``--robustness N`` it instead counts solver failures, retries and fallbacks over N
random-family scenarios × the six grid risks and the five midpoints (``--scenario traffic``:
N random traffic scenes × the six grid risks, four vehicles constrained) (``n_demos``,
``n_solver_failures``, ``n_fallbacks``, ``n_retries``, ``n_collisions``, step times).

Examples:
    python scripts/bench_smpc.py --out runs/bench_smpc.json
    python scripts/bench_smpc.py --robustness 100 --seed 0 --out runs/bench_smpc_robustness.json
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

from drivestyle.agents import SMPCConfig, SMPCExpert, rollout_expert
from drivestyle.agents.demo_generation import ROBUSTNESS_RISKS, smpc_robustness
from drivestyle.common.cli import (
    HelpFormatter,
    nonnegative_int,
    positive_int,
    risk_value,
    run_cli,
    seed,
    workers,
)
from drivestyle.common.io import check_output_file, write_json
from drivestyle.envs import LaneChangeEnv, ScenarioRanges


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--out", type=Path, default=Path("runs/bench_smpc.json"), help="output JSON")
    p.add_argument("--risk", type=risk_value, default=0.7, help="SMPC risk p")
    p.add_argument(
        "--repeats", type=positive_int, default=5, help="closed loops of the paper scenario"
    )
    p.add_argument("--random", type=nonnegative_int, default=10, help="random scenarios")
    p.add_argument("--seed", type=seed, default=0, help="seed of the random scenarios")
    p.add_argument(
        "--trials",
        type=positive_int,
        default=3,
        help="independent repetitions of the whole measurement; the reported "
        "numbers are medians over trials (shared VMs drift by ±40 %%)",
    )
    p.add_argument(
        "--robustness",
        type=positive_int,
        metavar="N",
        help="count failures over N random scenarios x 11 risks instead of timing",
    )
    p.add_argument("--workers", type=workers, default=2, help="processes (--robustness only)")
    p.add_argument(
        "--scenario",
        default="single",
        choices=("single", "traffic"),
        help="--robustness: the single-TV family, or traffic scenes with 4 vehicles "
        "(grid risks only)",
    )
    p.add_argument(
        "--no-jit",
        action="store_true",
        help="do not compile the NLP functions with gcc (slower solves)",
    )
    return p.parse_args(argv)


def _stats(ms: list[float]) -> dict[str, float]:
    return {
        "median_ms": float(np.median(ms)),
        "p95_ms": float(np.percentile(ms, 95)),
        "max_ms": float(np.max(ms)),
        "n_steps": len(ms),
    }


def time_solvers(
    solvers: tuple[str, ...], jit: bool, risk: float, repeats: int, n_random: int, seed: int
) -> dict[str, dict]:
    """Per-step solve times of each solver over the paper loops and random scenarios.

    Each solver runs its closed loops as one block, as a controller would run alone:
    interleaving the solvers evicts each other's caches and adds ≈0.3 ms per fatrop solve.
    """
    env = LaneChangeEnv()
    ranges = ScenarioRanges()
    rng = np.random.default_rng(seed)
    jobs = [None] * repeats + [ranges.sample(rng) for _ in range(n_random)]
    times: dict[str, dict[str, list[float]]] = {
        name: {"paper": [], "random": []} for name in solvers
    }
    failures = dict.fromkeys(solvers, 0)
    build_s = {}
    for name in solvers:
        t0 = time.perf_counter()
        expert = SMPCExpert(SMPCConfig(risk=risk, solver=name, jit=jit))
        build_s[name] = time.perf_counter() - t0
        for i, sc in enumerate(tqdm(jobs, desc=f"{name} closed loops")):
            options = None if sc is None else {"scenario": sc}
            _, steps = rollout_expert(env, expert, seed=seed, options=options)
            times[name]["paper" if i < repeats else "random"] += [s["solve_ms"] for s in steps]
            failures[name] += sum(not s["success"] for s in steps)
        del expert
    env.close()
    out = {}
    for name in solvers:
        out[name] = {
            "solver": name,
            "jit": jit,
            "build_s": build_s[name],
            **_stats(times[name]["paper"]),
            "failures": failures[name],
        }
        if times[name]["random"]:
            r = _stats(times[name]["random"])
            out[name] |= {f"random_{k}": v for k, v in r.items()}
    return out


def robustness(args: argparse.Namespace, jit: bool, argv: list[str]) -> dict:
    """The ``--robustness`` mode: failure counts over many demonstrations."""
    traffic = args.scenario == "traffic"
    risks = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95) if traffic else ROBUSTNESS_RISKS
    bar = tqdm(total=len(risks), desc=f"risks x {args.robustness} scenes")
    result = smpc_robustness(
        args.robustness,
        args.seed,
        risks,
        workers=args.workers,
        jit=jit,
        progress=lambda p: bar.update(1),
        traffic=traffic,
    )
    bar.close()
    limit_ms = 2.0 if traffic else 1.0
    result["goal"] = {
        "n_solver_failures": 0,
        "n_fallbacks": 0,
        "n_collisions": 0,
        "step_ms_median": limit_ms,
    }
    result["meets_goal"] = (
        result["n_solver_failures"] == 0
        and result["n_fallbacks"] == 0
        and result["n_collisions"] == 0
        and result["step_ms_median"] <= limit_ms
    )
    write_json(args.out, result, argv)
    print(f"{'risk':>6s} {'demos':>6s} {'failures':>9s} {'retries':>8s} {'fallbacks':>10s}")
    for p, c in result["by_risk"].items():
        print(
            f"{p:>6s} {c['n_demos']:6d} {c['n_solver_failures']:9d} {c['n_retries']:8d} "
            f"{c['n_fallbacks']:10d}"
        )
    print(
        f"{result['n_demos']} demonstrations, {result['n_steps']} steps: "
        f"{result['n_solver_failures']} failures, {result['n_retries']} retries, "
        f"{result['n_fallbacks']} fallbacks, {result['n_collisions']} collisions; step median "
        f"{result['step_ms_median']:.2f} ms (jit={jit}); goal "
        f"{'met' if result['meets_goal'] else 'NOT met'}; wrote {args.out}"
    )
    return result


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out)
    jit = not args.no_jit
    if args.robustness:
        return robustness(args, jit, [sys.argv[0], *(argv or sys.argv[1:])])
    trials = [
        time_solvers(("fatrop", "ipopt"), jit, args.risk, args.repeats, args.random, args.seed)
        for _ in range(args.trials)
    ]

    def combine(name: str) -> dict:
        runs = [t[name] for t in trials]
        out = dict(runs[0])
        for key in runs[0]:
            if key.endswith("_ms") or key == "build_s":
                out[key] = float(np.median([r[key] for r in runs]))
            elif key.endswith("n_steps") or key == "failures":
                out[key] = sum(r[key] for r in runs)
        out["trial_median_ms"] = [r["median_ms"] for r in runs]
        return out

    fat, ipo = combine("fatrop"), combine("ipopt")
    result = {
        **fat,
        "ipopt_median_ms": ipo["median_ms"],
        "ipopt_p95_ms": ipo["p95_ms"],
        "ipopt_random_median_ms": ipo.get("random_median_ms"),
        "ipopt_failures": ipo["failures"],
        "speedup_vs_ipopt": ipo["median_ms"] / fat["median_ms"],
        "risk": args.risk,
        "repeats": args.repeats,
        "random_scenarios": args.random,
        "trials": args.trials,
        "ipopt_trial_median_ms": ipo["trial_median_ms"],
        "goal": {"median_ms": 1.0, "p95_ms": 3.0},
        "meets_goal": fat["median_ms"] <= 1.0 and fat["p95_ms"] <= 3.0,
        "machine": {
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
        },
    }
    write_json(args.out, result, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"{'solver':8s} {'jit':>4s} {'median ms':>10s} {'p95 ms':>8s} {'random med':>11s} "
        f"{'random p95':>11s} {'steps':>6s} {'fail':>5s}"
    )
    for s in (fat, ipo):
        print(
            f"{s['solver']:8s} {s['jit']!s:>4s} {s['median_ms']:10.3f} {s['p95_ms']:8.3f} "
            f"{s.get('random_median_ms', float('nan')):11.3f} "
            f"{s.get('random_p95_ms', float('nan')):11.3f} {s['n_steps']:6d} {s['failures']:5d}"
        )
    print(f"fatrop per-trial medians [ms]: {np.round(fat['trial_median_ms'], 3).tolist()}")
    print(
        f"speed-up vs IPOPT: {result['speedup_vs_ipopt']:.2f}x; goal (median <= 1 ms, "
        f"p95 <= 3 ms) {'met' if result['meets_goal'] else 'NOT met'}; wrote {args.out}"
    )
    return result


if __name__ == "__main__":
    run_cli(main)
