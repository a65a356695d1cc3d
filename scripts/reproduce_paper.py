"""Reproduce the paper's simulation study end to end (the project's main job).

1. Generate the p = 0.7 SMPC demonstration on the paper scenario (Fig. 2).
2. Learn its style with the base (6) and the reactive (10) features.
3. Draw Fig. 3 (reproduced paths at iterations 1, 11, 21 and the last; base on top,
   reactive below) and Fig. 4 (lateral velocity and acceleration, reactive).
4. Write ``results.json`` and ``results.md`` beside the paper's numbers, including the
   paper's own update rule and the effect of the control-point rule (DESIGN §4).

Example:
    python scripts/reproduce_paper.py --out runs/paper
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

from tqdm import tqdm

from drivestyle.common.cli import (
    HelpFormatter,
    count,
    positive_float,
    risk_value,
    run_cli,
    seed,
)
from drivestyle.common.io import atomic_output_dir, check_output_dir
from drivestyle.studies.paper import (
    baseline_study,
    paper_console,
    paper_study,
    write_paper_results,
    write_paper_study,
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--out", type=Path, default=Path("runs/paper"), help="output folder (replaced whole)"
    )
    p.add_argument("--risk", type=risk_value, default=0.7, help="SMPC risk p of the demonstration")
    p.add_argument("--t-rct", type=positive_float, default=2.0, help="reaction window T_rct [s]")
    p.add_argument(
        "--with-baseline",
        action="store_true",
        help="also train an SB3 policy on the reactive style, compare it with the spline "
        "reproduction and the SMPC demo, and render videos (needs the rl and video extras)",
    )
    p.add_argument("--baseline-algo", default="ppo", choices=("ppo", "sac"), help="SB3 algorithm")
    p.add_argument(
        "--baseline-timesteps",
        type=count(100_000_000, 4e-3, "training env steps"),
        default=60_000,
        help="SB3 budget (60 000 PPO steps take about 4 min on 2 cores)",
    )
    p.add_argument(
        "--skip-ablations",
        action="store_true",
        help="skip the paper-rule and control-point-rule comparisons",
    )
    p.add_argument("--seed", type=seed, default=0, help="env and training seed")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Run the study; returns the results payload."""
    args = parse_args(argv)
    argv_full = [sys.argv[0], *(argv or sys.argv[1:])]
    check_output_dir(args.out)
    if args.with_baseline:
        try:
            import stable_baselines3  # noqa: F401

            import drivestyle.envs.video  # noqa: F401
        except ImportError as exc:
            raise RuntimeError(
                f"{exc}; --with-baseline needs: pip install -c constraints-cpu.txt -e '.[rl,video]'"
            ) from None
    t_start = time.perf_counter()
    steps = tqdm(total=4 if args.skip_ablations else 7, desc="reproduce_paper")
    study = paper_study(
        args.risk,
        args.t_rct,
        args.seed,
        ablations=not args.skip_ablations,
        progress=lambda: steps.update(1),
        demo_path=args.out / "demo" / "demo.npz",
    )
    steps.close()
    with atomic_output_dir(args.out) as tmp:
        write_paper_study(study, tmp, argv_full)
        if args.with_baseline:
            baseline = baseline_study(
                tmp / "reactive" / "style.json",
                study.demo,
                study.demo_summary["solve_ms_total"] / 1e3,
                tmp,
                args.baseline_algo,
                args.baseline_timesteps,
                args.seed,
                argv_full,
            )
            study = replace(study, baseline=baseline)
        study = replace(study, wall_time_total_s=time.perf_counter() - t_start)
        write_paper_results(study, tmp, argv_full)
    print(
        f"wrote {args.out}/results.json, results.md and figures ({study.wall_time_total_s:.1f} s)"
    )
    print(paper_console(study))
    return study.to_json()


if __name__ == "__main__":
    run_cli(main)
