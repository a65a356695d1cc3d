"""Benchmark online identification: the latency of one StyleTracker update (goal <= 20 ms median).

Generates ``--vehicles`` SMPC demonstrations of the random scenario family with risks drawn
from U[0.5, 0.95] (``--seed``), then streams each, sample by sample, into a fresh
:class:`~drivestyle.irl.identification.online.StyleTracker` as an observer would: the inputs are
recovered from consecutive states, not read. Every update is timed (the first sample of each vehicle
included: it builds nothing, the planner is cached per process after a warm-up vehicle).
Reports the median, 95th and 99th percentile and maximum [ms], with the load average
before and after (the machine is shared), and writes JSON.

``--posterior FILE`` (an estimator ``drivestyle build-posterior`` wrote, its
``posterior.npz``) streams the same vehicles into an
:class:`~drivestyle.irl.amortized.tracker.AmortizedTracker` too, on one core (torch on one
thread): each update timed alone (one GRU step) and with the posterior's summary from
``--draws`` draws after it (goal <= 2 ms median, the summary included), under the JSON's
``amortized``. Without ``--library`` only the amortized tracker is timed.

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
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.common.cli import HelpFormatter, count, run_cli, seed
from drivestyle.common.io import check_output_file, write_json
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import one_thread, open_posterior
from drivestyle.irl.amortized.tracker import AmortizedTracker
from drivestyle.irl.identification.library import load_driver_library
from drivestyle.irl.identification.online import StyleTracker
from drivestyle.planning.description import SMPCConfig

GOAL_MS = 20.0
"""Goal of the median update latency [ms] (RESULTS §12, online identification)."""
AMORTIZED_GOAL_MS = 2.0
"""Goal of the amortized tracker's median update with its summary [ms] (the issue's)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--library", type=Path, default=None,
        help="driver library folder or library.json (the exact tracker; needed unless "
        "--posterior is given)",
    )  # fmt: skip
    p.add_argument(
        "--vehicles", type=count(100_000, 2.0, "vehicles"), default=10, help="vehicles to stream"
    )
    p.add_argument("--seed", type=seed, default=0, help="seed of the scenarios and risks")
    p.add_argument("--out", type=Path, default=Path("runs/bench_tracker.json"), help="output JSON")
    p.add_argument(
        "--posterior", type=Path, default=None,
        help="an amortized posterior (build-posterior's posterior.npz): also time the "
        "amortized tracker's updates",
    )  # fmt: skip
    p.add_argument("--draws", type=count(100_000, 0.001, "draws", least=2), default=16,
                   help="posterior draws of the amortized tracker's summary")  # fmt: skip
    args = p.parse_args(argv)
    if args.library is None and args.posterior is None:
        raise ValueError("give --library (the exact tracker), --posterior (the amortized) or both")
    return args


def _percentiles(ms: np.ndarray) -> dict[str, float]:
    return {"median_ms": float(np.median(ms)), "p95_ms": float(np.percentile(ms, 95)),
            "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max())}  # fmt: skip


def bench_amortized(
    posterior: NeuralPosterior, demos: list[Demonstration], draws: int
) -> dict[str, Any]:
    """Time every update of an :class:`AmortizedTracker` per vehicle, alone and with a summary.

    One torch thread. The first vehicle warms up (not timed); each later one is streamed
    twice into a fresh tracker: its updates timed alone, then each update and the summary
    after it.
    """
    alone: list[float] = []
    with_summary: list[float] = []
    with one_thread():
        for i, demo in enumerate(demos):
            vehicles = demo.vehicles
            for summarise, out in ((False, alone), (True, with_summary)):
                tracker = AmortizedTracker(posterior, demo.scenario, draws=draws)
                for k in range(demo.n):
                    t0 = time.perf_counter()
                    tracker.update(demo.ev[k], vehicles[k])
                    if summarise:
                        tracker.summary()
                    if i > 0:
                        out.append((time.perf_counter() - t0) * 1e3)
    both = np.array(with_summary)
    return {
        "updates": len(alone),
        "draws": draws,
        "torch_threads": 1,
        "update": _percentiles(np.array(alone)),
        "update_and_summary": _percentiles(both),
        "goal_median_ms": AMORTIZED_GOAL_MS,
        "goal_met": bool(np.median(both) <= AMORTIZED_GOAL_MS),
        "estimator_sha256": posterior.weights_sha256(),
    }


def main(argv: list[str] | None = None) -> dict:
    """Benchmark; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out, inputs=[f for f in (args.library, args.posterior) if f])
    library = (
        load_driver_library(args.library, "online identification")
        if args.library is not None
        else None
    )
    posterior = open_posterior(args.posterior) if args.posterior is not None else None
    rng = np.random.default_rng(args.seed)
    ranges = ScenarioRanges()
    demos = []
    for _ in range(args.vehicles + 1):  # the first warms the planner up (not timed)
        sc = ranges.sample(rng)
        risk = float(rng.uniform(0.5, 0.95))
        demos.append(generate_demonstration(risk, sc, SMPCConfig(risk=risk))[0])
    load_before = os.getloadavg()
    payload: dict[str, Any] = {}
    if library is not None:
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
            **_percentiles(ms),
            "goal_median_ms": GOAL_MS,
            "goal_met": bool(np.median(ms) <= GOAL_MS),
        }
    amortized = None
    if posterior is not None:
        amortized = bench_amortized(posterior, demos, args.draws)
        payload = {**payload, "vehicles": args.vehicles,
                   "amortized": {"estimator": str(args.posterior), **amortized}}  # fmt: skip
    payload |= {
        "load_before": list(load_before),
        "load_after": list(os.getloadavg()),
        "python": platform.python_version(),
        "cpus": os.cpu_count(),
    }
    write_json(args.out, payload, [sys.argv[0], *(argv or sys.argv[1:])])
    if library is not None:
        print(
            f"StyleTracker.update: median {payload['median_ms']:.1f} ms, p95 "
            f"{payload['p95_ms']:.1f} ms, max {payload['max_ms']:.1f} ms over "
            f"{payload['updates']} updates (goal <= {GOAL_MS:g} ms median: "
            f"{'met' if payload['goal_met'] else 'MISSED'}); load {load_before[0]:.2f}"
        )
    if amortized is not None:
        one, both = amortized["update"], amortized["update_and_summary"]
        print(
            f"AmortizedTracker.update (one torch thread): median {one['median_ms']:.2f} ms, p95 "
            f"{one['p95_ms']:.2f} ms; with a summary of {args.draws} draws: median "
            f"{both['median_ms']:.2f} ms, p95 {both['p95_ms']:.2f} ms over "
            f"{amortized['updates']} updates (goal <= {AMORTIZED_GOAL_MS:g} ms median: "
            f"{'met' if amortized['goal_met'] else 'MISSED'}); load {load_before[0]:.2f}"
        )
    return payload


if __name__ == "__main__":
    run_cli(main)
