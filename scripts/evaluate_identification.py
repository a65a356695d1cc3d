r"""Evaluate style identification on held-out scenarios and held-out risk levels.

Draws M interactive scenarios with a seed disjoint from the library's, generates SMPC
demonstrations at every library risk and at risks between the grid points, identifies
each with every scorer, and writes ``OUT/evaluation.json`` + ``OUT/evaluation.md``
(accuracy, MAE, transfer), ``OUT/confusion_<features>_<scorer>.png`` and
``OUT/theta_vs_risk.png``. Pass several libraries (e.g. reactive and base) to compare
feature sets.

Example:
    python scripts/evaluate_identification.py --library runs/library_reactive \\
        --library runs/library_base --scenarios 5 --seed 1000 --out runs/evaluation
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

from tqdm import tqdm

from agents.rollout import draw_interactive_scenarios, generate_demonstrations
from envs.cli import positive_int, risk_list, run_cli
from envs.io import atomic_output_dir, check_output_dir, write_json, write_text
from irl.identification import (
    SCORERS,
    LibraryError,
    evaluate_identification,
    evaluation_markdown,
    load_library,
)
from irl.plotting import plot_confusion, plot_theta_vs_risk


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument(
        "--library",
        type=Path,
        action="append",
        required=True,
        help="library folder or library.json (repeat for several feature sets)",
    )
    p.add_argument(
        "--scenarios", type=positive_int, default=5, help="M held-out interactive scenarios"
    )
    p.add_argument(
        "--between",
        type=risk_list,
        help="held-out risks between grid points (default: midpoints of the library's grid)",
    )
    p.add_argument(
        "--seed", type=int, default=1000, help="held-out scenario seed (not the library's)"
    )
    p.add_argument("--workers", type=positive_int, default=2, help="worker processes")
    p.add_argument(
        "--out", type=Path, default=Path("runs/evaluation"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Evaluate; returns evaluation.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out)
    libraries = {}
    for path in args.library:
        lib = load_library(path)
        if lib.feature_set in libraries:
            raise LibraryError(f"two libraries of the {lib.feature_set!r} feature set given")
        libraries[lib.feature_set] = lib
        if lib.meta.get("seed") == args.seed:
            raise LibraryError(
                f"--seed {args.seed} is the library's own training seed; "
                "use a disjoint seed for held-out scenarios"
            )
    grid = list(next(iter(libraries.values())).risks)
    if any(list(lib.risks) != grid for lib in libraries.values()):
        raise LibraryError("the libraries have different risk grids; compare like with like")
    between = args.between or [round((a + b) / 2, 4) for a, b in itertools.pairwise(grid)]
    scenarios = draw_interactive_scenarios(args.scenarios, args.seed, min(grid))
    risks = [*grid, *[p for p in between if p not in grid]]
    demos_by_risk = generate_demonstrations(risks, scenarios, args.workers)
    demos = [d for p in risks for d in demos_by_risk[p]]
    results = {}
    for name, lib in libraries.items():
        with tqdm(total=len(demos), desc=f"identify ({name})") as bar:
            results[name] = evaluate_identification(lib, demos, grid, bar.update)
    payload = {
        "grid_risks": grid,
        "between_risks": between,
        "seed": args.seed,
        "held_out_scenarios": [sc.to_dict() for sc in scenarios],
        "summary": {n: r["summary"] for n, r in results.items()},
        "records": {n: r["records"] for n, r in results.items()},
    }
    markdown = evaluation_markdown(results)
    with atomic_output_dir(args.out) as tmp:
        for name in results:
            for s in SCORERS:
                plot_confusion(
                    results[name]["records"],
                    grid,
                    s,
                    tmp / f"confusion_{name}_{s}.png",
                    title=f"{name} features, scorer {s}",
                )
        plot_theta_vs_risk(libraries, tmp / "theta_vs_risk.png")
        write_json(tmp / "evaluation.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        write_text(tmp / "evaluation.md", markdown)
    print(markdown)
    return payload


if __name__ == "__main__":
    run_cli(main)
