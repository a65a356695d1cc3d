"""Benchmark online identification: the latency of one StyleTracker update (goal <= 20 ms median).

Generates ``--vehicles`` SMPC demonstrations of the random scenario family with risks drawn
from U[0.5, 0.95] (``--seed``), then streams each, sample by sample, into a fresh
:class:`~drivestyle.irl.identification.online.StyleTracker` as an observer would: the inputs are
recovered from consecutive states, not read. Every update is timed (the first sample of each vehicle
included: it builds nothing, the planner is cached per process after a warm-up vehicle).
Reports the median, 95th and 99th percentile and maximum [ms], with the load average
before and after (the machine is shared), and writes JSON.

Example:
    python scripts/bench_tracker.py --library runs/library --out runs/bench_tracker.json
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.common.cli import HelpFormatter, count, run_cli, seed
from drivestyle.common.io import check_output_file, write_json
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.irl.identification.library import load_driver_library
from drivestyle.irl.identification.online import StyleTracker
from drivestyle.planning.description import SMPCConfig

GOAL_MS = 20.0
"""Goal of the median update latency [ms] (RESULTS §12, online identification)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--library", type=Path, required=True, help="driver library folder or library.json"
    )
    p.add_argument(
        "--vehicles", type=count(100_000, 2.0, "vehicles"), default=10, help="vehicles to stream"
    )
    p.add_argument("--seed", type=seed, default=0, help="seed of the scenarios and risks")
    p.add_argument("--out", type=Path, default=Path("runs/bench_tracker.json"), help="output JSON")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Benchmark; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out, inputs=[args.library])
    library = load_driver_library(args.library, "online identification")
    rng = np.random.default_rng(args.seed)
    ranges = ScenarioRanges()
    demos = []
    for _ in range(args.vehicles + 1):  # the first warms the planner up (not timed)
        sc = ranges.sample(rng)
        risk = float(rng.uniform(0.5, 0.95))
        demos.append(generate_demonstration(risk, sc, SMPCConfig(risk=risk))[0])
    load_before = os.getloadavg()
    latencies: list[float] = []
    for i, demo in enumerate(demos):
        tracker = StyleTracker(library, demo.scenario)
        vehicles = demo.vehicles
        for k in range(demo.n):
            t0 = time.perf_counter()
            tracker.update(demo.ev[k], vehicles[k])
            if i > 0:
                latencies.append((time.perf_counter() - t0) * 1e3)
    ms = np.array(latencies)
    payload = {
        "updates": int(ms.size),
        "vehicles": args.vehicles,
        "median_ms": float(np.median(ms)),
        "p95_ms": float(np.percentile(ms, 95)),
        "p99_ms": float(np.percentile(ms, 99)),
        "max_ms": float(ms.max()),
        "goal_median_ms": GOAL_MS,
        "goal_met": bool(np.median(ms) <= GOAL_MS),
        "load_before": list(load_before),
        "load_after": list(os.getloadavg()),
        "python": platform.python_version(),
        "cpus": os.cpu_count(),
    }
    write_json(args.out, payload, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"StyleTracker.update: median {payload['median_ms']:.1f} ms, p95 "
        f"{payload['p95_ms']:.1f} ms, max {payload['max_ms']:.1f} ms over {ms.size} updates "
        f"(goal <= {GOAL_MS:g} ms median: {'met' if payload['goal_met'] else 'MISSED'}); "
        f"load {load_before[0]:.2f}"
    )
    return payload


if __name__ == "__main__":
    run_cli(main)
