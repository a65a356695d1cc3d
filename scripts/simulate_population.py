r"""Simulate a population of SMPC vehicles with known risks (the ground truth for mining).

Vehicle i gets a risk p ~ U[0.5, 0.95] and a scene of the random family (a traffic scene with
probability ``--traffic-share``), both drawn from the seed and i alone, and drives one SMPC
demonstration. Writes ``OUT/demos/v000000.npz`` … and ``OUT/population.json`` (each
vehicle's id, true risk, scene family, file and status). The folder is written atomically.

Example:
    python scripts/simulate_population.py --vehicles 200 --seed 0 --out runs/population
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, count, run_cli, seed, workers
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.studies.identification.population import simulate_population


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--vehicles",
        type=count(1_000_000, 0.7, "vehicles"),
        required=True,
        help="population size N",
    )
    p.add_argument("--seed", type=seed, default=0, help="population seed")
    p.add_argument(
        "--traffic-share", type=float, default=0.0, help="share of traffic scenes, in [0, 1]"
    )
    p.add_argument("--workers", type=workers, default=2, help="worker processes")
    p.add_argument("--jit", action="store_true", help="compile the SMPC with gcc (faster)")
    p.add_argument(
        "--out", type=Path, default=Path("runs/population"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Simulate; returns population.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out)
    t0 = time.perf_counter()
    with atomic_output_dir(args.out) as tmp:
        with tqdm(total=args.vehicles, desc="vehicles") as bar:
            payload = simulate_population(
                args.vehicles,
                args.seed,
                tmp,
                args.workers,
                args.traffic_share,
                args.jit,
                progress=bar.update,
            ).to_json()
        payload["wall_s"] = time.perf_counter() - t0
        write_json(tmp / "population.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"wrote {args.out}: {payload['n_ok']} demonstrations ({payload['n_failed']} failed) "
        f"in {payload['wall_s']:.1f} s"
    )
    return payload


if __name__ == "__main__":
    run_cli(main)
