r"""Benchmark simulating stochastic drivers: episodes per second per core, failed solves.

Draws ``--episodes`` episodes from the prior over stochastic drivers and scenes
(:class:`drivestyle.irl.driver.stochastic_prior.StochasticPrior`, DESIGN §21) with
``--seed`` and simulates each (episode i with seed ``--seed`` + i) on ``--workers`` worker
processes (one BLAS thread each; 1: in this process), with a progress bar. Each worker
first loads the planners (the compiled solvers cached on disk) outside the episodes'
clocks. Reports simulations per second per core (from the wall clock of the whole batch,
planner loading included, and from the episodes' own times), the share of failed solves
(steps whose plan failed and a fallback input was applied), the median and 95th
percentile episode time, the share of episodes that end in the target lane and the share
that are plausible demonstrations (:func:`~drivestyle.envs.plausibility.plausibility_problems`;
each episode's first problem is in ``per_episode``). Needs no files. Prints a summary and
writes JSON.

Example:
    python scripts/bench_stochastic.py --episodes 40 --workers 2 --out runs/bench_stochastic.json
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, count, run_cli, seed, workers
from drivestyle.common.io import check_output_file, write_json
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.plausibility import plausibility_problems
from drivestyle.irl.driver.stochastic import load_planners
from drivestyle.irl.driver.stochastic_prior import EpisodeParams, StochasticPrior, simulate_params


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--out", type=Path, default=Path("runs/bench_stochastic.json"),
                   help="output JSON")  # fmt: skip
    p.add_argument(
        "--episodes",
        type=count(1_000_000, 0.1, "episodes"),
        default=40,
        help="episodes drawn from the prior and simulated",
    )
    p.add_argument("--workers", type=workers, default=1, help="worker processes")
    p.add_argument("--seed", type=seed, default=0, help="seed of the prior's draws")
    return p.parse_args(argv)


def _simulate(raw: dict[str, Any], episode_seed: int) -> dict[str, Any]:
    """Worker: one episode; its time, failed solves, steps and whether it changed lane."""
    params = EpisodeParams.from_json(raw)
    t0 = time.perf_counter()
    demo = simulate_params(params, episode_seed)
    seconds = time.perf_counter() - t0
    sc = demo.scenario
    problems = plausibility_problems(demo)
    return {
        "seconds": seconds,
        "failures": int(demo.meta["failures"]),
        "steps": int(demo.n - 1),
        "in_target_lane": bool(demo.ev[-1, 1] > sc.lane_width * sc.target_lane),
        "implausible": problems[0] if problems else None,
        "ev_speed": float(sc.ev_speed),
        "vehicles": int(demo.vehicles.shape[1]),
    }


def run(episodes: int, n_workers: int, base_seed: int) -> dict[str, Any]:
    """Draw and simulate the episodes; the benchmark's numbers."""
    draws = StochasticPrior().draw(episodes, base_seed)
    tasks = [(d.to_json(), base_seed + i) for i, d in enumerate(draws)]
    with tqdm(total=episodes, desc="stochastic episodes", unit="ep") as bar:
        t0 = time.perf_counter()
        rows = parallel_map(_simulate, tasks, n_workers, lambda _i, _r: bar.update(1),
                            initializer=load_planners)  # fmt: skip
        wall = time.perf_counter() - t0
    seconds = np.array([r["seconds"] for r in rows])
    failures = sum(r["failures"] for r in rows)
    steps = sum(r["steps"] for r in rows)
    return {
        "episodes": episodes,
        "workers": n_workers,
        "seed": base_seed,
        "wall_s": wall,
        "simulations_per_s": episodes / wall,
        "simulations_per_s_per_core": episodes / wall / n_workers,
        "simulations_per_s_per_core_episodes_only": float(1.0 / seconds.mean()),
        "episode_s_median": float(np.median(seconds)),
        "episode_s_p95": float(np.percentile(seconds, 95)),
        "steps": int(steps),
        "failed_solves": int(failures),
        "failed_solves_share": failures / steps,
        "episodes_with_failures": sum(r["failures"] > 0 for r in rows),
        "in_target_lane_share": float(np.mean([r["in_target_lane"] for r in rows])),
        "plausible_share": float(np.mean([r["implausible"] is None for r in rows])),
        "per_episode": rows,
    }


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out)
    load_before = [round(x, 2) for x in os.getloadavg()]
    result = run(args.episodes, args.workers, args.seed)
    result["load_average_before"] = load_before
    result["load_average_after"] = [round(x, 2) for x in os.getloadavg()]
    result["machine"] = {"cpus": os.cpu_count(), "platform": platform.platform(),
                         "python": platform.python_version()}  # fmt: skip
    write_json(args.out, result, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"{result['episodes']} episodes on {result['workers']} worker(s) in "
        f"{result['wall_s']:.1f} s: {result['simulations_per_s_per_core']:.2f} simulations/s/core "
        f"({result['simulations_per_s_per_core_episodes_only']:.2f} from the episodes' own "
        f"times), median episode {1000 * result['episode_s_median']:.0f} ms, failed solves "
        f"{100 * result['failed_solves_share']:.1f} % of {result['steps']} steps, in the target "
        f"lane {100 * result['in_target_lane_share']:.0f} %, plausible "
        f"{100 * result['plausible_share']:.0f} %; load average "
        f"{load_before} before, {result['load_average_after']} after; wrote {args.out}"
    )
    return result


if __name__ == "__main__":
    run_cli(main)
