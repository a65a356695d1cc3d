"""Capacity of the style model classes: the best parameters of each, fitted to one driver.

For each driver SMPC(p), the paper's whole-horizon model and the receding-horizon style
model are fitted directly to the reproductions of K training demonstrations (Nelder–Mead)
and learned by their learners (ME-IRL, ``learn_driver``), then scored in-sample and on
held-out scenarios (median rmse_y and rmse_xy). Writes ``OUT/capacity.json`` and
``OUT/capacity.md`` and prints the table (RESULTS §10;
``drivestyle.studies.capacity``).

Example:
    python scripts/capacity_study.py --risks 0.6,0.9 --train 5 --test 4 --out runs/capacity
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drivestyle.common.cli import HelpFormatter, count, risk_list, run_cli, workers
from drivestyle.common.io import (
    atomic_output_dir,
    check_output_dir,
    command_line,
    write_json,
    write_text,
)
from drivestyle.studies.capacity import RiskCapacity, capacity_markdown, capacity_study
from drivestyle.studies.formatting import seconds


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--risks",
        type=risk_list,
        default=[0.6, 0.9],
        help="comma-separated risks p of the SMPC drivers, in (0, 1)",
    )
    p.add_argument(
        "--train",
        type=count(1000, 90.0, "training scenarios"),
        default=5,
        help="K training scenarios (interactive draws, seed 0)",
    )
    p.add_argument(
        "--test",
        type=count(10_000, 5.0, "held-out scenarios"),
        default=4,
        help="held-out scenarios (interactive draws, seed 500)",
    )
    p.add_argument(
        "--budget",
        type=count(100_000, 2.0, "objective evaluations"),
        default=300,
        help="objective evaluations per Nelder–Mead fit (each one reproduces every "
        "training demonstration)",
    )
    p.add_argument("--workers", type=workers, default=2, help="processes (one driver each)")
    p.add_argument(
        "--out", type=Path, default=Path("runs/capacity"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Run the study; returns the ``capacity.json`` payload."""
    args = parse_args(argv)
    check_output_dir(args.out)
    command = [sys.argv[0], *(sys.argv[1:] if argv is None else argv)]

    def done(row: RiskCapacity) -> None:
        print(f"p = {row.risk:g} done in {seconds(row.seconds)}", flush=True)

    study = capacity_study(
        args.risks, args.train, args.test, args.budget, args.workers, on_risk=done
    )
    payload = study.to_json()
    report = capacity_markdown(study, command_line(command))
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "capacity.json", payload, command)
        write_text(tmp / "capacity.md", report)
    print(report)
    print(f"wrote {args.out}/capacity.json and capacity.md")
    return payload


if __name__ == "__main__":
    run_cli(main)
