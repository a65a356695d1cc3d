r"""Benchmark mining a simulated population: throughput, scaling, Ray's overhead, per-demo cost.

Simulates N vehicles (``drivestyle.studies.identification.population``), or takes a folder
of demonstrations (``--demos``), then mines them (with a driver library — the default model — or
a paper-model one) once per ``--runs`` entry — by default the local engine with 1 worker and
with 2, and Ray with 2 actors; ``--runs ray:1,ray:2`` is the scale-out check — the workers
loading each file as ``mine-styles`` does. It reports demonstrations per second (and per core),
the 1 → 2 scaling of each engine run with 1 and 2 workers, Ray's overhead against local where
both ran with 2 (Ray is started before the clock; actor creation and task traffic are timed),
each worker's resident memory over the run (peak; at 10 %, 50 % of the rows and at the end),
the median learning and identification time per demonstration, the median inner spline solve,
and from the 1-worker rate an estimate of the hours for 110,000 vehicles on 1, 8 and 64 cores.

Example:
    python scripts/bench_population.py --vehicles 500 --library runs/library_reactive \\
        --out runs/bench_population.json
    python scripts/bench_population.py --vehicles 1000 --library runs/library \\
        --runs ray:1,ray:2 --out runs/bench_population_ray.json
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, count, run_cli, seed
from drivestyle.common.io import check_output_file, fmt, write_json
from drivestyle.envs.demonstration import load_demonstration
from drivestyle.irl.identification.library import StyleLibrary, load_any_library
from drivestyle.irl.identification.mining import mine
from drivestyle.irl.paper.learner import IRLConfig, MaxEntIRL
from drivestyle.studies.identification.population import simulate_population

TARGET_VEHICLES = 110_000
"""A drone-recorded highway dataset's size: the scale mining is projected to."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--vehicles",
        type=count(1_000_000, 0.7, "demonstrations"),
        default=500,
        help="simulated demonstrations",
    )
    p.add_argument("--library", type=Path, required=True, help="style library folder or json")
    p.add_argument("--seed", type=seed, default=0, help="population seed")
    p.add_argument("--no-ray", action="store_true", help="skip the Ray run")
    p.add_argument(
        "--runs",
        type=_runs,
        default=None,
        help="the timed runs as engine:workers, comma-separated, e.g. ray:1,ray:2 (the scale-out "
        "check); default local:1,local:2,ray:2 (without --no-ray's ray:2)",
    )
    p.add_argument(
        "--demos",
        type=Path,
        default=None,
        help="mine this folder's demonstrations (*.npz) instead of simulating --vehicles",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/bench_population.json"), help="output JSON"
    )
    return p.parse_args(argv)


class WorkerMemory:
    """Samples the resident memory of a mining run's worker processes from ``/proc``.

    Workers are the pool's processes (local: children of this process) or Ray's actor
    processes (descendants whose title names the ``Miner`` actor). Each sample records the
    run's progress (share of rows done) beside the resident set, so the report can say
    whether memory stays flat over the run; the peak is the kernel's high-water mark
    (VmHWM), which also sees peaks between samples. Without ``/proc`` it reports nothing.
    """

    def __init__(self, engine: str, interval_s: float = 1.0) -> None:
        self.engine = engine
        self.interval_s = interval_s
        self.progress = 0.0
        self._series: dict[int, list[tuple[float, float]]] = {}
        self._peak: dict[int, float] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> None:
        """Begin sampling (a daemon thread)."""
        self._thread.start()

    def stop(self) -> None:
        """Take a last sample and stop."""
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        while True:
            self._sample()
            if self._stop.wait(self.interval_s):
                return

    def _workers(self) -> list[int]:
        parents: dict[int, int] = {}
        for entry in Path("/proc").glob("[0-9]*"):
            try:
                stat = (entry / "stat").read_text()
                parents[int(entry.name)] = int(stat[stat.rindex(")") + 2 :].split()[1])
            except (OSError, ValueError):
                continue
        me = os.getpid()
        if self.engine == "local":
            return [pid for pid, ppid in parents.items() if ppid == me and "resource_tracker"
                    not in _cmdline(pid)]  # fmt: skip
        below: set[int] = set()
        frontier = {me}
        while frontier:
            frontier = {pid for pid, ppid in parents.items() if ppid in frontier} - below
            below |= frontier
        return [pid for pid in below if "Miner" in _cmdline(pid)]

    def _sample(self) -> None:
        for pid in self._workers():
            status = _status(pid)
            if "VmRSS" in status:
                self._series.setdefault(pid, []).append((self.progress, status["VmRSS"]))
                self._peak[pid] = max(self._peak.get(pid, 0.0), status.get("VmHWM", 0.0))

    def report(self) -> dict:
        """Per worker: peak; resident at 10 %, 50 % of the rows and at the end [MB]; growth.

        Growth is from 10 % of the rows to the end (start-up allocations excluded); the
        50 % sample tells a plateau from a steady climb.
        """
        workers = []
        for pid, series in self._series.items():

            def at(share: float, series: list = series) -> float:
                later = [rss for done, rss in series if done >= share]
                return later[0] if later else series[-1][1]

            workers.append({
                "peak_mb": self._peak[pid],
                "rss_at_10pct_mb": at(0.1),
                "rss_at_50pct_mb": at(0.5),
                "rss_last_mb": series[-1][1],
                "growth": series[-1][1] / at(0.1) - 1.0,
                "samples": len(series),
            })  # fmt: skip
        return {
            "workers": workers,
            "peak_mb_max": max((w["peak_mb"] for w in workers), default=None),
            "growth_max": max((w["growth"] for w in workers), default=None),
        }


def _cmdline(pid: int) -> str:
    try:
        return (
            Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        )
    except OSError:
        return ""


def _status(pid: int) -> dict[str, float]:
    """VmRSS and VmHWM of a process [MB] (empty when it is gone)."""
    out = {}
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = float(value.split()[0]) / 1024
    except (OSError, ValueError, IndexError):
        pass
    return out


def _runs(text: str) -> list[tuple[str, int]]:
    """``engine:workers,...`` → [(engine, workers)]; a one-line error otherwise."""
    runs = []
    for part in text.split(","):
        engine, _, n = part.strip().partition(":")
        if engine not in ("local", "ray") or not n.isdigit() or int(n) < 1:
            raise argparse.ArgumentTypeError(
                f"a run is engine:workers with engine local or ray and workers >= 1, got {part!r}"
            )
        runs.append((engine, int(n)))
    return runs


def _timed_mining(tasks: list, library, engine: str, workers: int) -> dict:
    bar = tqdm(total=len(tasks), desc=f"{engine} x{workers}", leave=False)
    sampler = WorkerMemory(engine)
    done = [0]

    def on_row(_row: object) -> None:
        done[0] += 1
        sampler.progress = done[0] / len(tasks)
        bar.update(1)

    sampler.start()
    t0 = time.perf_counter()
    try:
        rows = mine(tasks, library, engine, workers, on_row)
    finally:
        wall = time.perf_counter() - t0
        sampler.stop()
        bar.close()
    ok = [r for r in rows if r.status == "ok"]
    return {
        "engine": engine,
        "workers": workers,
        "wall_s": wall,
        "demos_per_s": len(rows) / wall,
        "demos_per_s_per_core": len(rows) / wall / workers,
        "n_ok": len(ok),
        "n_failed": len(rows) - len(ok),
        "learn_s_median": float(np.median([r.learn_s for r in ok])) if ok else None,
        "identify_s_median": float(np.median([r.identify_s for r in ok])) if ok else None,
        "worker_memory": sampler.report(),
    }


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark; returns the JSON payload."""
    args = parse_args(argv)
    check_output_file(args.out, inputs=[args.library, args.demos])
    library = load_any_library(args.library)
    plan = args.runs or [("local", 1), ("local", 2)] + ([] if args.no_ray else [("ray", 2)])
    with tempfile.TemporaryDirectory() as tmp:
        simulate_s = None
        if args.demos is None:
            with tqdm(total=args.vehicles, desc="simulate") as bar:
                pop = simulate_population(args.vehicles, args.seed, tmp, 2, progress=bar.update)
            simulate_s = pop.wall_s
            folder = Path(tmp) / "demos"
        else:
            folder = args.demos
        files = sorted(folder.glob("*.npz"))
        if not files:
            raise ValueError(f"no demonstrations (*.npz) in {folder}")
        # the workers load each file, as mine-styles on a folder does: the driver holds paths
        tasks = [(f.stem, "population", str(f)) for f in files]
        runs = []
        for engine, workers in plan:
            if engine == "ray":
                import ray  # started before the clock: cluster start-up is not per-job work

                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
                try:
                    runs.append(_timed_mining(tasks, library, "ray", workers))
                finally:
                    ray.shutdown()
            else:
                runs.append(_timed_mining(tasks, library, engine, workers))
        inner: list[float] = []
        # the paper model's inner spline solve (a driver library has none: its solves are
        # the planner's NLPs, timed by bench_irl)
        if isinstance(library, StyleLibrary):
            for f in files[:20]:
                try:
                    d = load_demonstration(f)
                    inner += MaxEntIRL(d, library.features, IRLConfig()).learn().inner_solve_ms
                except ValueError:
                    continue
    by_key = {(r["engine"], r["workers"]): r for r in runs}
    scaling = {
        e: by_key[(e, 2)]["demos_per_s"] / by_key[(e, 1)]["demos_per_s"]
        for e in ("local", "ray")
        if (e, 1) in by_key and (e, 2) in by_key
    }
    engine = next(iter(scaling), runs[0]["engine"])
    one = by_key.get((engine, 1), runs[0])
    rate_per_core = one["demos_per_s_per_core"]
    # parallel efficiency measured from 1 to 2 workers, assumed to hold further
    efficiency = scaling[engine] / 2 if engine in scaling else 1.0
    result = {
        "vehicles": len(files),
        "demos_folder": None if args.demos is None else str(args.demos),
        "simulate_wall_s_2_workers": simulate_s,
        "runs": runs,
        "scaling_1_to_2": scaling.get(engine),
        "scaling_1_to_2_by_engine": scaling,
        "ray_overhead": (
            by_key[("local", 2)]["demos_per_s"] / by_key[("ray", 2)]["demos_per_s"] - 1
        )
        if ("local", 2) in by_key and ("ray", 2) in by_key
        else None,
        "learn_s_median": one["learn_s_median"],
        "identify_s_median": one["identify_s_median"],
        "inner_solve_ms_median": float(np.median(inner)) if inner else None,
        "parallel_efficiency": efficiency if engine in scaling else None,
        "parallel_efficiency_by_engine": {e: v / 2 for e, v in scaling.items()},
        "hours_for_110k": {
            str(c): TARGET_VEHICLES / (rate_per_core * c * (1.0 if c == 1 else efficiency)) / 3600
            for c in (1, 8, 64)
        },
        "goal": {
            "demos_per_s_per_core": 20.0,
            "parallel_efficiency": 0.9,
            "ray_overhead": 0.10,
            "learn_s_median": 0.05,
            "identify_s_median": 0.1,
            "inner_solve_ms_median": 1.0,
        },
        "machine": {
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
        },
    }
    write_json(args.out, result, [sys.argv[0], *(argv or sys.argv[1:])])
    for r in runs:
        print(
            f"{r['engine']:5s} x{r['workers']}: {r['demos_per_s']:.2f} demos/s "
            f"({r['demos_per_s_per_core']:.2f} per core), {r['n_failed']} failed"
        )
    for r in runs:
        mem = r["worker_memory"]
        if mem["workers"]:
            print(
                f"{r['engine']:5s} x{r['workers']}: peak RSS per worker "
                + ", ".join(f"{w['peak_mb']:.0f} MB" for w in mem["workers"])
                + f" (growth from 10 % of the run to its end: {fmt(mem['growth_max'])})"
            )
    print(
        f"scaling 1->2: {fmt(result['scaling_1_to_2'])}x (goal 1.8); Ray overhead "
        f"{fmt(result['ray_overhead'])} (goal 0.10); learn {result['learn_s_median']:.3f} s, "
        f"identify {result['identify_s_median']:.3f} s, inner solve "
        f"{fmt(result['inner_solve_ms_median'])} ms (medians); 110k vehicles: "
        + ", ".join(f"{c} cores {h:.1f} h" for c, h in result["hours_for_110k"].items())
        + f"; wrote {args.out}"
    )
    return result


if __name__ == "__main__":
    run_cli(main)
