r"""Build a style library: one learned θ per SMPC risk level from K shared scenarios.

Draws K interactive scenarios (the SMPC at the lowest risk triggers) from the
LaneChangeRandom family with ``--seed``, generates the SMPC demonstration of every risk in
each, learns one θ per risk from its K demonstrations jointly (in parallel over
processes), and writes ``OUT/library.json`` (risk → θ, training scenarios, per-demo fit),
the demonstrations under ``OUT/demos/`` and ``OUT/theta_vs_risk.png``.

Example:
    python scripts/build_style_library.py --risks 0.5,0.6,0.7,0.8,0.9,0.95 --scenarios 10 \\
        --features reactive --seed 0 --out runs/library_reactive
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from agents.style_library import build_library, draw_interactive_scenarios
from envs.results import write_json
from irl.plotting import plot_theta_vs_risk


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--risks", type=_floats, default=[0.5, 0.6, 0.7, 0.8, 0.9, 0.95])
    p.add_argument("--scenarios", type=int, default=10, help="K scenarios per risk")
    p.add_argument("--features", default="reactive", choices=("reactive", "base"))
    p.add_argument("--workers", type=int, default=2, help="processes")
    p.add_argument("--seed", type=int, default=0, help="seed of the training scenarios")
    p.add_argument("--out", type=Path, default=Path("runs/library"))
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Build the library; returns library.json's payload."""
    args = parse_args(argv)
    if not args.risks or any(not 0 < p < 1 for p in args.risks):
        sys.exit(f"error: --risks must be values in (0, 1), got {args.risks}")
    if args.scenarios < 1:
        sys.exit("error: --scenarios must be >= 1")
    t0 = time.perf_counter()
    scenarios = draw_interactive_scenarios(args.scenarios, args.seed, min(args.risks))
    t_draw = time.perf_counter() - t0
    bar = tqdm(total=len(args.risks), desc="risk levels")

    def progress(rec: dict) -> None:
        bar.update(1)
        bar.set_postfix(p=rec["risk"], iters=rec["iterations"])

    library = build_library(args.risks, scenarios, args.features, args.workers, args.out, progress)
    bar.close()
    payload = library.to_json() | {
        "seed": args.seed,
        "k_scenarios": args.scenarios,
        "draw_s": t_draw,
        "build_wall_s": time.perf_counter() - t0,
    }
    write_json(args.out / "library.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    plot_theta_vs_risk({args.features: library}, args.out / "theta_vs_risk.png")
    print(
        f"wrote {args.out}/library.json: {len(args.risks)} styles from {args.scenarios} "
        f"scenarios each in {payload['build_wall_s']:.1f} s"
    )
    return payload


if __name__ == "__main__":
    main()
