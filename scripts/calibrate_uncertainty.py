"""Scan the TV-uncertainty scale and the risk p on the paper scenario (DESIGN §3).

For each scale s (multiplying :data:`drivestyle.planning.tv_gaussian.PAPER_TV_UNCERTAINTY`) and each
risk p, runs the SMPC closed loop and records t_trg, min s_e (and where), when the EV
enters the centre lane and where it ends. Writes ``OUT/calibration.json`` and, with
``--plot``, ``OUT/risk_sweep.png``: the EV paths and s_e for each p at scale 1.

Example:
    python scripts/calibrate_uncertainty.py --scales 1.0,0.8,1.2 --out runs/calibration --plot
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, positive_list, risk_list, run_cli, seed
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.studies.paper import uncertainty_scan
from drivestyle.studies.paper.figures import plot_risk_sweep


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--scales",
        type=positive_list,
        default=[0.8, 0.9, 1.0, 1.1, 1.2],
        help="comma-separated factors (> 0) on the calibrated TV uncertainty",
    )
    p.add_argument(
        "--risks",
        type=risk_list,
        default=[0.5, 0.6, 0.7, 0.8, 0.9, 0.95],
        help="comma-separated risk levels p in (0, 1)",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/calibration"), help="output folder (replaced whole)"
    )
    p.add_argument("--plot", action="store_true", help="write risk_sweep.png (scale 1)")
    p.add_argument("--seed", type=seed, default=0, help="env seed")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Run the scan; returns the JSON payload."""
    args = parse_args(argv)
    check_output_dir(args.out)
    bar = tqdm(total=len(args.scales) * len(args.risks), desc="scale x risk")
    scan = uncertainty_scan(args.scales, args.risks, args.seed, lambda: bar.update(1))
    bar.close()
    payload, demos = scan.to_json(), scan.demos
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "calibration.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        if args.plot and demos:
            plot_risk_sweep(demos, tmp / "risk_sweep.png")
    print(
        f"{'scale':>5s} {'p':>5s} {'t_trg':>6s} {'min s_e':>8s} {'at x':>6s} "
        f"{'enter':>6s} {'final y':>8s}"
    )
    for r in payload["rows"]:
        trg = "never" if r["t_trg_s"] is None else f"{r['t_trg_s']:.1f}"
        ent = "never" if r["t_enter_target_lane_s"] is None else f"{r['t_enter_target_lane_s']:.1f}"
        print(
            f"{r['scale']:5.2f} {r['risk']:5.2f} {trg:>6s} {r['min_s_e']:8.2f} "
            f"{r['x_at_min_s_e']:6.0f} {ent:>6s} {r['final_y']:8.2f}"
        )
    print(f"wrote {args.out}/calibration.json" + (" and risk_sweep.png" if args.plot else ""))
    return payload


if __name__ == "__main__":
    run_cli(main)
