r"""A TV that deviates from its prediction: SMPC, an SB3 policy and the spline plans.

In the style's scenario the TV brakes (or, with a positive ``--accel``, accelerates) from
``--t-start`` for ``--duration`` seconds. Compares the SMPC (re-plans every step), an SB3
policy (closed loop, ``--model``), the spline reproduction planned once and executed
open-loop, and the spline re-planned every ``--replan-every`` samples
(studies/compare/deviation.py). Writes ``OUT/deviation.json`` (per driver: collision, min
d_k, rmse_y against the SMPC) and a gif per driver.

Example:
    python scripts/deviating_tv.py --style runs/paper/reactive/style.json \\
        --model runs/baseline_fixed --out runs/deviating
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.common.cli import (
    HelpFormatter,
    finite_float,
    positive_float,
    positive_int,
    risk_value,
    run_cli,
)
from drivestyle.common.io import atomic_output_dir, check_output_dir, fmt, write_json
from drivestyle.envs.demonstration import load_demonstration
from drivestyle.envs.lane_change import TVDeviation
from drivestyle.irl.paper.style import load_style
from drivestyle.studies.compare.deviation import deviating_tv_study, write_videos


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--style", type=Path, required=True, help="style.json (or its folder)")
    p.add_argument("--model", type=Path, help="train_baseline.py output folder (optional)")
    p.add_argument("--demo", type=Path, help="nominal demonstration (default: the style's own)")
    p.add_argument("--risk", type=risk_value, default=0.7, help="the SMPC's risk p")
    p.add_argument("--t-start", type=positive_float, default=1.5, help="deviation start [s]")
    p.add_argument(
        "--accel", type=finite_float, default=-4.0, help="TV acceleration [m/s²] (< 0: brakes)"
    )
    p.add_argument("--duration", type=positive_float, default=1.5, help="deviation length [s]")
    p.add_argument(
        "--replan-every", type=positive_int, default=5, help="samples between spline re-plans"
    )
    p.add_argument("--no-videos", action="store_true", help="skip the gifs")
    p.add_argument(
        "--out", type=Path, default=Path("runs/deviating"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Run the study; returns deviation.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[args.style, args.model, args.demo])
    style = load_style(args.style)
    nominal = load_demonstration(args.demo or style.demo_path(args.style))
    if nominal.meta.get("risk") not in (None, args.risk):
        nominal, _ = generate_demonstration(args.risk, nominal.scenario)
    deviation = TVDeviation(args.t_start, args.accel, args.duration)
    policy = None
    if args.model is not None:
        from drivestyle.agents.sb3_baseline import SB3Policy

        policy = SB3Policy(args.model).act
    res = deviating_tv_study(style, nominal, deviation, policy, args.replan_every, args.risk)
    payload = {
        "style": str(args.style),
        "model": None if args.model is None else str(args.model),
        **res.to_json(),
    }
    with atomic_output_dir(args.out) as tmp:
        if not args.no_videos:
            payload["videos"] = write_videos(res, nominal.scenario, tmp)
        write_json(tmp / "deviation.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    for name, m in res.methods.items():
        print(
            f"{name:17s} collision {m.collision!s:5s} min d_k {m.min_d_k:6.2f}  "
            f"rmse_y vs SMPC {fmt(m.rmse_y_vs_smpc_m)} m"
        )
    return payload


if __name__ == "__main__":
    run_cli(main)
