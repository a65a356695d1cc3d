"""Learn the population's style from the recorded benchmark's train split (DESIGN §18).

One style — cost weights, risk and the speed-scaled safety region l_a = s_0 + T·v (DESIGN
§18) — over every lane change of the split (drivestyle/data/benchmark_split.csv), starting from a
driver library's weights. ``--objective closed-loop`` (default): the mean rmse_xy of the
style driven in closed loop through each episode, by Nelder–Mead (``--max-evals``);
``--objective teacher``: the library's one-step input residuals by Levenberg–Marquardt
(``--screen``, ``--restarts``, ``--max-iter``). Writes ``OUT/library.json``: a driver library
with that style and the starting library's risks and temperature, which
``identify-style``, ``mine-styles``, ``predict-trajectory`` and ``evaluate-prediction``
take like any other (``fit`` records the learning: status, residual RMS — the library's
noise floor — iterations, seconds; ``split`` the episodes learned from and those skipped).
Learning is deterministic.

Example:
    drivestyle learn-population --library runs/library --out runs/people
    drivestyle evaluate-prediction --library runs/people --no-simulated --out runs/benchmark_people
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, for_option, positive_int, run_cli
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.irl.driver.driver_fit import DriverFit
from drivestyle.irl.identification.library import load_driver_library
from drivestyle.recorded.benchmark import (
    DEFAULT_DATA_DIR,
    SPLIT_FILE,
    SPLITS,
    check_split_selects,
    read_split,
)
from drivestyle.studies.population_style import (
    OBJECTIVES,
    ClosedLoopFit,
    PopulationSettings,
    learn_closed_loop,
    learn_population,
    population_library,
    split_demos,
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--library", type=Path, required=True, help="the driver library to start from")
    p.add_argument("--out", type=Path, default=Path("runs/people"), help="output folder")
    p.add_argument("--data-dir", type=Path, default=DEFAULT_DATA_DIR,
                   help="folder holding ngsim/ and cats-av-lanechange/")  # fmt: skip
    p.add_argument("--split-file", type=Path, default=SPLIT_FILE, help="the benchmark split (CSV)")
    p.add_argument("--split", choices=SPLITS, default="train", help="the split learned from")
    p.add_argument(
        "--no-region",
        action="store_true",
        help="keep the library's fixed ellipse (no time gap, no standstill axis)",
    )
    p.add_argument("--objective", choices=OBJECTIVES, default="closed-loop",
                   help="what the style is fitted to")  # fmt: skip
    p.add_argument("--max-evals", type=positive_int, default=160,
                   help="closed-loop evaluations (≈ 2–4 s each on 51 episodes)")  # fmt: skip
    p.add_argument("--screen", type=positive_int, default=4, help="starting points scored")
    p.add_argument("--restarts", type=positive_int, default=1, help="Levenberg-Marquardt runs")
    p.add_argument("--max-iter", type=positive_int, default=12, help="iterations per run")
    args = p.parse_args(argv)
    if args.restarts > args.screen:
        p.error(f"--restarts ({args.restarts}) cannot exceed --screen ({args.screen})")
    if args.objective == "closed-loop" and args.no_region:
        p.error("--no-region is an option of --objective teacher")
    return args


def main(argv: list[str] | None = None) -> dict:
    """Learn and write; returns library.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[args.library, args.data_dir, args.split_file])
    library = load_driver_library(args.library, "learn-population")
    with for_option("--split-file"):  # every row checked, the problem named by the option
        rows = read_split(args.split_file)
    try:
        check_split_selects(rows, args.split)
    except ValueError as exc:
        raise ValueError(f"--split-file {args.split_file}: {exc}") from None
    demos, skipped = split_demos(args.data_dir, rows, args.split)
    if not demos:
        raise ValueError(f"the {args.split} split of {args.split_file} has no usable episode")
    settings = PopulationSettings(
        not args.no_region, args.screen, args.restarts, args.max_iter,
        objective=args.objective, max_evals=args.max_evals,
    )  # fmt: skip
    print(f"learning one style from {len(demos)} {args.split} episodes ({len(skipped)} skipped)")
    closed = args.objective == "closed-loop"
    what = "closed-loop evaluations" if closed else "LM iterations"
    with tqdm(desc=f"population style ({what})", unit="it",
              total=args.max_evals if closed else None) as bar:  # fmt: skip

        def tick(_: int, cost: float) -> None:
            bar.update(1)
            bar.set_postfix(cost=f"{cost:.4g}")

        episodes = [d for _, d in demos]
        fit: DriverFit | ClosedLoopFit
        if closed:
            fit = learn_closed_loop(episodes, library, settings, tick)
        else:
            fit = learn_population(episodes, library, settings, tick)
    people = population_library(fit, library, {
        "split": {"file": str(args.split_file), "name": args.split,
                  "episodes": [e for e, _ in demos], "skipped": [list(s) for s in skipped]},
        "started_from": str(args.library),
    })  # fmt: skip
    payload = people.to_json()
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "library.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    st = fit.style
    print(
        f"wrote {args.out}/library.json ({args.objective}): fit {fit.status}, residual rms "
        f"{fit.residual_rms:.2f} "
        f"σ_u over {len(demos)} episodes, risk {st.risk:.2f}, time gap {st.time_gap:.2f} s, "
        f"standstill axis {st.min_gap if st.min_gap is not None else 'scenario'} m, "
        f"{fit.seconds:.0f} s"
    )
    return payload


if __name__ == "__main__":
    run_cli(main)
