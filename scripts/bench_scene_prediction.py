r"""Benchmark predicting a whole recorded minute: every vehicle, every window (goal ≤ 5 min).

Extracts every vehicle's episodes (``extract-episodes --all-vehicles``: lane changes and the
windows without one) of one recording of the shipped NGSIM sample (``--recording``, default
the I-80 minute ``i80_1600_first60s``: 60 s, 77 vehicles) and predicts each at every
``--observe`` time with ``--methods`` (default ``style_joint``: every observed vehicle
identified from its own past by the amortized posterior ``--posterior`` and rolled out
together; ``cv`` and ``joint_physics`` are cheap beside it), in ``--workers`` processes.
Reports the wall time against the goal, the time per prediction (median, 95th percentile),
the load average before and after (the machine may be shared), and writes JSON. The
extraction is timed apart (it is the same for every method).

Example:
    drivestyle bench-scene-prediction --posterior runs/posterior20k/posterior.npz \\
        --out runs/bench_scene_prediction.json
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, float_list, run_cli, workers
from drivestyle.common.io import check_output_file, write_json
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.prediction.joint_physics import JointPhysicsParams
from drivestyle.prediction.joint_physics_calibration import JOINT_PHYSICS_FILE, load_joint_params
from drivestyle.prediction.methods import AMORTIZED_METHODS, METHODS, predict_demo
from drivestyle.prediction.protocol import ForecastError
from drivestyle.recorded.benchmark import DEFAULT_DATA_DIR
from drivestyle.recorded.episodes import extract_episodes
from drivestyle.recorded.readers import read_sample
from drivestyle.recorded.real_data import DATASETS
from drivestyle.recorded.tracks import Recording

GOAL_S = 300.0
"""The goal: a recorded minute, every vehicle and window, predicted within 5 min on 2 cores."""
SCENE_METHODS = ("cv", "joint_physics", *AMORTIZED_METHODS)
"""The methods this bench may time (the library's are the benchmark's, not a scene's)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--posterior", type=Path, required=True, metavar="FILE",
                   help="the amortized posterior (build-posterior's posterior.npz)")  # fmt: skip
    p.add_argument("--recording", default="i80_1600_first60s",
                   help="the NGSIM sample's recording to predict")  # fmt: skip
    p.add_argument(
        "--methods", default="style_joint",
        help=f"comma-separated methods to time (of {', '.join(SCENE_METHODS)})",
    )  # fmt: skip
    p.add_argument("--observe", type=float_list, default=[1.0, 2.0, 3.0],
                   help="comma-separated observed times t_obs [s]")  # fmt: skip
    p.add_argument("--data-dir", type=Path, default=DEFAULT_DATA_DIR,
                   help="folder holding ngsim/")  # fmt: skip
    p.add_argument("--workers", type=workers, default=2, help="worker processes")
    p.add_argument("--out", type=Path, default=Path("runs/bench_scene_prediction.json"),
                   help="output JSON")  # fmt: skip
    return p.parse_args(argv)


@functools.lru_cache(maxsize=1)
def _posterior(path: str) -> NeuralPosterior:
    """The posterior, loaded once per worker."""
    return open_posterior(path)


@functools.lru_cache(maxsize=1)
def _joint_params() -> JointPhysicsParams:
    """The shipped joint physics calibration, read once per worker."""
    return load_joint_params(JOINT_PHYSICS_FILE)


def _task(
    demo: Demonstration, t_obs: tuple[float, ...], methods: tuple[str, ...], posterior: str
) -> tuple[float, int, list[str]]:
    """Worker: one window at every t_obs; (seconds, predictions made, why some were not)."""
    t0 = time.perf_counter()
    amortized = _posterior(posterior) if set(methods) & set(AMORTIZED_METHODS) else None
    params = _joint_params() if "joint_physics" in methods else None
    made, skipped = 0, []
    for t in t_obs:
        try:
            predict_demo(demo, None, t, methods=methods, amortized=amortized,
                         joint_physics=params)  # fmt: skip
            made += 1
        except (ForecastError, ValueError, RuntimeError) as exc:
            skipped.append(f"t_obs {t:g} s: {exc}")
    return time.perf_counter() - t0, made, skipped


def _recording(data_dir: Path, name: str) -> Recording:
    """One recording of the NGSIM sample (the others dropped)."""
    full = read_sample(data_dir / DATASETS["ngsim"])
    roads = [c for c in full.carriageways if c.name == name]
    if not roads:
        known = ", ".join(sorted(c.name for c in full.carriageways))
        raise ValueError(f"--recording {name!r}: not in the NGSIM sample (known: {known})")
    return replace(full, carriageways=tuple(roads))


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Benchmark; returns the JSON payload."""
    args = parse_args(argv)
    methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    unknown = [m for m in methods if m not in SCENE_METHODS]
    if not methods or unknown:
        raise ValueError(
            f"--methods {args.methods!r}: {unknown or 'none'} not of {', '.join(SCENE_METHODS)}"
        )
    methods = tuple(m for m in METHODS if m in methods)
    check_output_file(args.out, inputs=[args.posterior])
    open_posterior(args.posterior)  # read and checked before any work
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    recording = _recording(args.data_dir, args.recording)
    episodes = [e for e in extract_episodes(recording, all_vehicles=True) if e.usable]
    extract_s = time.perf_counter() - t0
    vehicles = len({e.vehicle_id for e in episodes})
    bar = tqdm(total=len(episodes), desc=f"{args.recording}: windows", unit="window")
    t0 = time.perf_counter()
    try:
        out = parallel_map(
            _task,
            [(e.demo, tuple(args.observe), methods, str(args.posterior)) for e in episodes],
            args.workers,
            lambda *_: bar.update(1),
        )
    finally:
        bar.close()
    wall = time.perf_counter() - t0
    seconds = np.array([s for s, _, _ in out])
    made = sum(n for _, n, _ in out)
    per = seconds / np.maximum([n for _, n, _ in out], 1)
    payload = {
        "recording": args.recording,
        "methods": list(methods),
        "t_obs_s": list(args.observe),
        "vehicles": vehicles,
        "windows": len(episodes),
        "predictions": made,
        "skipped": [s for _, _, ss in out for s in ss][:20],
        "extract_s": extract_s,
        "wall_s": wall,
        "goal_s": GOAL_S,
        "met": bool(wall + extract_s <= GOAL_S),
        "prediction_s": {"median": float(np.median(per)), "p95": float(np.percentile(per, 95))},
        "workers": args.workers,
        "load_before": list(load_before),
        "load_after": list(os.getloadavg()),
    }
    write_json(args.out, payload, [sys.argv[0], *(argv if argv is not None else sys.argv[1:])])
    verdict = "met" if payload["met"] else "missed"
    print(
        f"{args.recording}: {vehicles} vehicles, {len(episodes)} windows, {made} predictions "
        f"({', '.join(methods)}) in {wall + extract_s:.0f} s on {args.workers} workers "
        f"(extraction {extract_s:.0f} s; a prediction {payload['prediction_s']['median']:.2f} s "
        f"median): goal {GOAL_S:.0f} s {verdict}; wrote {args.out}"
    )
    return payload


if __name__ == "__main__":
    run_cli(main)
