"""Benchmark the Gymnasium envs as a training loop's hot path: environment steps per second.

One process, the default wrappers of ``gym.make``; the actions are drawn beforehand with
``--seed`` (uniformly over the action space, as an untrained policy acts, or ``--actions
gentle``: the steering scaled by 0.1, so most episodes run to the horizon) and the env is
reset after every episode end, resets included in the time. Cases:

- ``lane_change``: ``gym.make("drivestyle/LaneChange-v0")`` (goal >= 20,000 steps/s);
- ``traffic``: ``gym.make("drivestyle/Traffic-v0")`` (goal >= 8,000);
- ``style_paper``: LaneChange-v0 with the paper model's learned-style reward
  (``LearnedStyleReward``, per-step feature increments) of a style with known weights
  (goal >= 5,000);
- ``style_driver``: LaneChange-v0 with the driver model's stage cost as the reward
  (``DriverCostReward``, ``DriverStyle(weights=(0.2, 50, 0.2, 1, 10), risk=0.7)``)
  (goal >= 5,000).

Each case is timed ``--trials`` times over ``--steps`` steps and the median over trials is
reported, with the load average before and after (the machine is shared). Needs no files:
the styles are constructed here. Prints a table and writes JSON.

Examples:
    python scripts/bench_env.py --out runs/bench_env.json
    python scripts/bench_env.py --steps 5000 --profile 15 --cases style_paper
"""

from __future__ import annotations

import argparse
import cProfile
import io
import os
import platform
import pstats
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import drivestyle.envs  # noqa: F401  (registers the ids)
from drivestyle.common.cli import HelpFormatter, count, nonnegative_int, positive_int, run_cli, seed
from drivestyle.common.io import check_output_file, write_json
from drivestyle.irl.driver.driver_cost import DriverCostReward
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.paper.features import FEATURES, FeatureConfig
from drivestyle.irl.paper.style import Style
from drivestyle.irl.paper.style_reward import LearnedStyleReward

PAPER_THETA = (0.8, 2.0, 0.05, 0.6, 0.3, 1.5, 0.2, 4.0, 3.0, 0.7)
"""Weights of the benchmark's paper-model style (FEATURES order; any positive θ costs the same)."""
DRIVER_STYLE = DriverStyle(weights=(0.2, 50.0, 0.2, 1.0, 10.0), risk=0.7)
"""The benchmark's driver style."""
GOALS = {"lane_change": 20_000, "traffic": 8_000, "style_paper": 5_000, "style_driver": 5_000}
"""Goal per case [steps/s] (RESULTS §11, the env as a training loop's hot path)."""


def paper_style() -> Style:
    """A reactive paper-model style with known weights (no learning, no file)."""
    return Style(FEATURES, np.array(PAPER_THETA), FeatureConfig(), "kinematic", {})


CASES: dict[str, Callable[[], gym.Env]] = {
    "lane_change": lambda: gym.make("drivestyle/LaneChange-v0"),
    "traffic": lambda: gym.make("drivestyle/Traffic-v0"),
    "style_paper": lambda: LearnedStyleReward(gym.make("drivestyle/LaneChange-v0"), paper_style()),
    "style_driver": lambda: DriverCostReward(gym.make("drivestyle/LaneChange-v0"), DRIVER_STYLE),
}


def case_list(text: str) -> list[str]:
    """Comma-separated case names (argparse type)."""
    names = [c.strip() for c in text.split(",") if c.strip()]
    unknown = [c for c in names if c not in CASES]
    if not names or unknown:
        raise argparse.ArgumentTypeError(
            f"unknown case(s) {unknown or text!r}; choose from {', '.join(CASES)}"
        )
    return names


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--out", type=Path, default=Path("runs/bench_env.json"), help="output JSON")
    p.add_argument(
        "--steps", type=count(10**9, 5e-5, "env steps"), default=20_000, help="env steps per trial"
    )
    p.add_argument(
        "--trials",
        type=positive_int,
        default=3,
        help="timed repetitions per case; the reported steps/s is their median",
    )
    p.add_argument("--seed", type=seed, default=0, help="seed of the actions and the resets")
    p.add_argument(
        "--actions",
        default="random",
        choices=("random", "gentle"),
        help="uniform over the action space, or with the steering scaled by 0.1 "
        "(episodes mostly run to the horizon)",
    )
    p.add_argument(
        "--cases",
        type=case_list,
        default=list(CASES),
        help=f"comma-separated cases to time ({', '.join(CASES)})",
    )
    p.add_argument(
        "--profile",
        type=nonnegative_int,
        default=0,
        metavar="N",
        help="also run each case once under cProfile and print its N most expensive "
        "functions (by own time; 0: no profile)",
    )
    return p.parse_args(argv)


def draw_actions(env: gym.Env, n: int, seed: int, mode: str) -> np.ndarray:
    """``n`` actions drawn uniformly over the env's action space (``gentle``: steering / 10)."""
    space = env.action_space
    if not isinstance(space, gym.spaces.Box):  # every drivestyle env acts on a Box
        raise TypeError(f"expected a Box action space, got {space}")
    low, high = space.low.astype(np.float64), space.high.astype(np.float64)
    actions = np.random.default_rng(seed).uniform(low, high, (n, 2))
    if mode == "gentle":
        actions[:, 1] *= 0.1
    return actions


def run_steps(env: gym.Env, actions: np.ndarray, seed: int) -> tuple[float, int]:
    """Step through ``actions``, resetting at every episode end; (seconds, episodes)."""
    env.reset(seed=seed)
    episodes = 1
    step, reset = env.step, env.reset
    t0 = time.perf_counter()
    for a in actions:
        _, _, terminated, truncated, _ = step(a)
        if terminated or truncated:
            reset()
            episodes += 1
    return time.perf_counter() - t0, episodes


def time_case(name: str, args: argparse.Namespace) -> dict[str, Any]:
    """Median steps/s of one case over the trials."""
    env = CASES[name]()
    actions = draw_actions(env, args.steps, args.seed, args.actions)
    run_steps(env, actions[: min(500, args.steps)], args.seed)  # warm-up (first-step checks)
    rates, episodes = [], 0
    for _ in range(args.trials):
        seconds, episodes = run_steps(env, actions, args.seed)
        rates.append(args.steps / seconds)
    env.close()
    rate = float(np.median(rates))
    return {
        "steps_per_s": rate,
        "us_per_step": 1e6 / rate,
        "trial_steps_per_s": rates,
        "episodes_per_trial": episodes,
        "mean_episode_steps": args.steps / episodes,
        "goal_steps_per_s": GOALS[name],
        "meets_goal": rate >= GOALS[name],
    }


def profile_case(name: str, args: argparse.Namespace) -> str:
    """Profile one pass of a case (cProfile): its ``args.profile`` most expensive functions."""
    env = CASES[name]()
    actions = draw_actions(env, args.steps, args.seed, args.actions)
    run_steps(env, actions[: min(500, args.steps)], args.seed)
    profiler = cProfile.Profile()
    profiler.enable()
    run_steps(env, actions, args.seed)
    profiler.disable()
    env.close()
    out = io.StringIO()
    pstats.Stats(profiler, stream=out).sort_stats("tottime").print_stats(args.profile)
    return out.getvalue()


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out)
    load_before = [round(x, 2) for x in os.getloadavg()]
    cases = {name: time_case(name, args) for name in args.cases}
    load_after = [round(x, 2) for x in os.getloadavg()]
    result = {
        "cases": cases,
        "steps": args.steps,
        "trials": args.trials,
        "seed": args.seed,
        "actions": args.actions,
        "meets_goal": all(c["meets_goal"] for c in cases.values()),
        "load_average_before": load_before,
        "load_average_after": load_after,
        "machine": {
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "gymnasium": gym.__version__,
        },
    }
    write_json(args.out, result, [sys.argv[0], *(argv or sys.argv[1:])])
    print(f"{'case':14s} {'steps/s':>9s} {'us/step':>8s} {'goal':>7s} {'met':>4s} {'ep len':>7s}")
    for name, c in cases.items():
        print(
            f"{name:14s} {c['steps_per_s']:9.0f} {c['us_per_step']:8.1f} "
            f"{c['goal_steps_per_s']:7d} {'yes' if c['meets_goal'] else 'NO':>4s} "
            f"{c['mean_episode_steps']:7.1f}"
        )
    print(
        f"{args.steps} steps x {args.trials} trials per case ({args.actions} actions); load "
        f"average {load_before} before, {load_after} after; wrote {args.out}"
    )
    if args.profile:
        for name in args.cases:
            print(f"\n---- profile: {name}\n{profile_case(name, args)}")
    return result


if __name__ == "__main__":
    run_cli(main)
