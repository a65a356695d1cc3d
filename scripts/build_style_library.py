r"""Build a style library: per SMPC risk level, θ learned from K shared scenarios.

Draws K interactive scenarios (the SMPC at the lowest risk triggers) from the
LaneChangeRandom family with ``--seed``, generates the SMPC demonstration of every risk in
each, learns per risk one θ from its K demonstrations jointly and one θ per demonstration
(in parallel over processes), and writes ``OUT/library.json`` (docs/DESIGN.md §7), the
demonstrations under ``OUT/demos/`` and ``OUT/theta_vs_risk.png``. The folder is written
atomically: an interrupted build leaves the previous library (or none), never a mix.

Example:
    python scripts/build_style_library.py --risks 0.5,0.6,0.7,0.8,0.9,0.95 --scenarios 10 \\
        --features reactive --seed 0 --out runs/library_reactive
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

from drivestyle.agents import SMPCConfig
from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstrations
from drivestyle.agents.studies.figures import plot_theta_vs_risk
from drivestyle.common.cli import positive_int, risk_list, run_cli
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs.demonstration import save_demonstration
from drivestyle.envs.tracking import observe
from drivestyle.irl.library import learn_library


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument(
        "--risks",
        type=risk_list,
        default=[0.5, 0.6, 0.7, 0.8, 0.9, 0.95],
        help="comma-separated SMPC risk levels p in (0, 1)",
    )
    p.add_argument(
        "--scenarios", type=positive_int, default=30, help="K training scenarios per risk"
    )
    p.add_argument(
        "--features", default="reactive", choices=("reactive", "base"), help="feature set"
    )
    p.add_argument(
        "--tracked",
        action="store_true",
        help="learn from the demonstrations as a tracker records them (positions only, "
        "envs/tracking.py): the library for identifying noisy recordings",
    )
    p.add_argument("--workers", type=positive_int, default=2, help="worker processes")
    p.add_argument("--seed", type=int, default=0, help="seed of the training scenario draws")
    p.add_argument(
        "--out", type=Path, default=Path("runs/library"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Build the library; returns library.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out)
    t0 = time.perf_counter()
    scenarios = draw_interactive_scenarios(args.scenarios, args.seed, min(args.risks))
    t_draw = time.perf_counter() - t0
    bar = tqdm(total=2 * len(args.risks), desc="demonstrations, then styles per risk")
    demos = generate_demonstrations(args.risks, scenarios, args.workers, lambda p: bar.update(1))
    if args.tracked:  # σ = 0: the tracker's view of the true positions
        rng = np.random.default_rng(args.seed)
        demos = {p: [observe(d, 0.0, rng) for d in ds] for p, ds in demos.items()}

    def progress(rec: dict) -> None:
        bar.update(1)
        bar.set_postfix(p=rec["risk"], iters=rec["iterations"])

    library = learn_library(
        demos,
        args.features,
        args.workers,
        progress,
        meta={  # the training scenarios are recorded from the demonstrations themselves
            "uncertainty": asdict(SMPCConfig().uncertainty),
            "observation": "tracked" if args.tracked else "true",
        },
    )
    bar.close()
    payload = library.to_json() | {
        "seed": args.seed,
        "k_scenarios": args.scenarios,
        "draw_s": t_draw,
        "build_wall_s": time.perf_counter() - t0,
    }
    with atomic_output_dir(args.out) as tmp:
        for p, risk_demos in demos.items():
            for i, demo in enumerate(risk_demos):
                save_demonstration(demo, tmp / "demos" / f"p{p:g}_s{i}.npz")
        write_json(tmp / "library.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        plot_theta_vs_risk({args.features: library}, tmp / "theta_vs_risk.png")
    print(
        f"wrote {args.out}/library.json: {len(args.risks)} styles from {args.scenarios} "
        f"scenarios each in {payload['build_wall_s']:.1f} s"
    )
    return payload


if __name__ == "__main__":
    run_cli(main)
