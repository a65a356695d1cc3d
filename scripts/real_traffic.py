"""Learn and compare driving styles on recorded lane changes (NGSIM or CATS).

For every used episode: a personal style (reactive and base features), a general style
learned from the other episodes (leave-one-out) and constant-velocity extrapolation are
compared with the recording (rmse_y, rmse_xy, final displacement error). Writes
``OUT/real_traffic.json``, ``OUT/real_traffic.md`` and one figure per episode under
``OUT/episodes/`` (the study itself: studies/real_traffic/; deterministic, so
there is no ``--seed``). On CATS it also compares the
computer-driven (AV) and human-driven (HV) lane changes and runs a leave-one-out
classifier on the learned styles.

``--model driver`` (or ``both``, the default) also learns the receding-horizon driver model
(irl/driver/driver_style.py) per episode — weights, risk and desired speed free — and reproduces it
in closed loop against the recorded vehicles; where a vehicle has several episodes (CATS:
the computer- and the human-driven ego car) its style learned from all but one reproduces
the held-out one, beside the general style of the other vehicles' episodes. Its results are
``real_traffic.json``'s ``driver`` entry, ``real_traffic.md``'s last section and
``OUT/driver_styles.png``; ``--model driver`` skips the paper model (and its keys).

The data are read from ``--data``; they are not part of this repository.

Example:
    python scripts/real_traffic.py --dataset ngsim --data ../shared/data/ngsim --out runs/ngsim
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, positive_int, run_cli, workers
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json, write_text
from drivestyle.irl.driver.driver_learning import RESTARTS, SCREEN_CANDIDATES
from drivestyle.recorded.real_data import load_cats, load_ngsim
from drivestyle.studies.real_traffic import (
    DriverSettings,
    driver_traffic_markdown,
    real_traffic_markdown,
    run_driver_study,
    run_study,
)
from drivestyle.studies.real_traffic.figures import plot_driver_traffic


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--dataset", required=True, choices=("ngsim", "cats"), help="which recording")
    p.add_argument("--data", type=Path, required=True, help="the dataset's folder")
    p.add_argument(
        "--out", type=Path, default=Path("runs/real_traffic"), help="output folder (replaced whole)"
    )
    p.add_argument("--workers", type=workers, default=2, help="worker processes")
    p.add_argument(
        "--limit", type=positive_int, help="only the first N used episodes (default: all)"
    )
    p.add_argument(
        "--no-neighbours",
        action="store_true",
        help="drop the further vehicles (only the EV and its target vehicle, as before traffic)",
    )
    p.add_argument(
        "--model",
        choices=("driver", "paper", "both"),
        default="both",
        help="style model(s): the receding-horizon driver model, the paper's spline model",
    )
    p.add_argument(
        "--screen",
        type=positive_int,
        default=SCREEN_CANDIDATES,
        help="driver model: starting points scored per fit",
    )
    p.add_argument(
        "--restarts",
        type=positive_int,
        default=RESTARTS,
        help="driver model: Levenberg-Marquardt runs per fit",
    )
    p.add_argument(
        "--max-iter",
        type=positive_int,
        default=30,
        help="driver model: Levenberg-Marquardt iterations per run",
    )
    p.add_argument(
        "--min-episodes",
        type=positive_int,
        default=3,
        help="driver model: episodes a vehicle needs for its leave-one-out test (>= 2)",
    )
    p.add_argument(
        "--fit-region",
        action="store_true",
        help="driver model: also learn the speed-scaled safety region (time gap, standstill axis)",
    )
    p.add_argument(
        "--scenario-line",
        action="store_true",
        help="driver model: aim at the target lane's centre, not the EV's own final line",
    )
    args = p.parse_args(argv)
    if args.min_episodes < 2:
        p.error(f"--min-episodes must be >= 2 (one learns, one held out), not {args.min_episodes}")
    if args.restarts > args.screen:
        p.error(f"--restarts ({args.restarts}) cannot exceed --screen ({args.screen})")
    if args.fit_region and args.model == "paper":
        p.error("--fit-region is an option of the driver model (--model driver or both)")
    return args


def main(argv: list[str] | None = None) -> dict:
    """Run the study; returns real_traffic.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[args.data])
    loader = load_ngsim if args.dataset == "ngsim" else load_cats
    episodes = loader(args.data, neighbours=not args.no_neighbours)
    with atomic_output_dir(args.out) as tmp:
        n_used = sum(e.used for e in episodes)
        n = n_used if args.limit is None else min(args.limit, n_used)
        study = driver = None
        if args.model in ("paper", "both"):
            with tqdm(total=n, desc=f"{args.dataset} episodes (paper model)") as bar:
                study = run_study(
                    episodes, args.dataset, args.workers, tmp / "episodes", args.limit, bar.update
                )
        if args.model in ("driver", "both"):
            settings = DriverSettings(
                args.screen, args.restarts, not args.scenario_line, args.max_iter, args.fit_region
            )
            with tqdm(desc=f"{args.dataset} driver-model fits", unit="fit") as bar:
                driver = run_driver_study(
                    episodes,
                    args.dataset,
                    args.workers,
                    args.limit,
                    bar.update,
                    settings,
                    args.min_episodes,
                    on_plan=lambda k: bar.reset(total=k),
                )
        payload = {"dataset": args.dataset} if study is None else study.to_json()
        payload["model"] = args.model
        payload["neighbours"] = not args.no_neighbours
        payload["n_neighbours_per_episode"] = [
            int(e.demo.other_vehicles.shape[1]) for e in episodes if e.used and e.demo is not None
        ]
        markdown = "" if study is None else real_traffic_markdown(study)
        if driver is not None:
            payload["driver"] = driver.to_json()
            markdown += driver_traffic_markdown(driver, study)
            plot_driver_traffic(driver, study, tmp / "driver_styles.png")
        write_json(tmp / "real_traffic.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        write_text(tmp / "real_traffic.md", markdown)
    print("\n".join(markdown.splitlines()[:10]))
    return payload


if __name__ == "__main__":
    run_cli(main)
