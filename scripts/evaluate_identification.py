r"""Evaluate style identification on held-out scenarios, risks and measurement noise.

Draws M scenarios of the random family with a seed disjoint from the library's (use one
seed for validation, where designs are chosen, and another for the final test, run once),
generates SMPC demonstrations at every library risk and at the midpoints between them,
identifies each with every scorer and writes ``OUT/evaluation.json`` + ``OUT/evaluation.md``
(accuracy among informative demonstrations, MAE, interval coverage, pooling, transfer),
``OUT/confusion_<features>.png`` and ``OUT/theta_vs_risk.png``. ``--noise`` repeats the
identification with tracked noisy positions (envs/tracking.py) and draws
``OUT/noise_curve.png``; ``--references`` adds the ceiling that knows the expert and a
supervised k-NN baseline without IRL.

Example:
    python scripts/evaluate_identification.py --library runs/library_reactive \\
        --scenarios 10 --seed 2000 --noise 0,0.05,0.1,0.2,0.3 --references --out runs/test
"""

from __future__ import annotations

import argparse
import itertools
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from tqdm import tqdm

from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstrations
from drivestyle.agents.studies.ceiling import identification_references
from drivestyle.agents.studies.figures import plot_confusion, plot_noise_curve, plot_theta_vs_risk
from drivestyle.agents.studies.identification import (
    Evaluation,
    evaluate_identification,
    noise_curve_json,
)
from drivestyle.agents.studies.reports import (
    evaluation_markdown,
    noise_markdown,
    references_markdown,
)
from drivestyle.common.cli import float_list, positive_int, risk_list, run_cli
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json, write_text
from drivestyle.envs.scenario import ScenarioConfig, ScenarioRanges
from drivestyle.envs.traffic import TrafficRanges, TrafficScene
from drivestyle.irl.identification import DEFAULT_SCORER
from drivestyle.irl.library import LibraryError, load_library


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
    p.add_argument("--scenarios", type=positive_int, default=5, help="M held-out scenarios")
    p.add_argument(
        "--draw",
        default="random",
        choices=("random", "interactive", "traffic"),
        help="scenarios: any of the random family, only those where SMPC(lowest p) triggers, "
        "or random traffic scenes (TrafficRandom-v0)",
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
        "--noise",
        type=float_list,
        default=[0.0],
        help="comma-separated position noise levels sigma [m] (0: true states)",
    )
    p.add_argument(
        "--references",
        action="store_true",
        help="also run the ceiling that knows the expert and a k-NN baseline without IRL",
    )
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
    if any(not (np.isfinite(s) and s >= 0) for s in args.noise):
        raise ValueError(f"--noise levels must be finite and >= 0, got {args.noise}")
    grid = list(next(iter(libraries.values())).risks)
    if any(list(lib.risks) != grid for lib in libraries.values()):
        raise LibraryError("the libraries have different risk grids; compare like with like")
    between = args.between or [round((a + b) / 2, 4) for a, b in itertools.pairwise(grid)]
    scenarios: Sequence[ScenarioConfig | TrafficScene]
    if args.draw == "interactive":
        scenarios = draw_interactive_scenarios(args.scenarios, args.seed, min(grid))
    else:
        rng = np.random.default_rng(args.seed)
        ranges = TrafficRanges() if args.draw == "traffic" else ScenarioRanges()
        scenarios = [ranges.sample(rng) for _ in range(args.scenarios)]
    risks = [*grid, *[p for p in between if p not in grid]]
    demos_by_risk = generate_demonstrations(risks, scenarios, args.workers)
    demos = [d for p in risks for d in demos_by_risk[p]]
    results: dict[str, Evaluation] = {}
    curves: dict[str, list[Evaluation]] = {}
    for name, lib in libraries.items():
        curves[name] = []
        for sigma in args.noise:
            with tqdm(total=len(demos), desc=f"identify ({name}, noise {sigma:g} m)") as bar:
                res = evaluate_identification(
                    lib, demos, grid, bar.update, args.workers, sigma, args.seed
                )
            results.setdefault(name, res)  # the first noise level is the headline
            curves[name].append(res)
    payload = {
        "grid_risks": grid,
        "between_risks": between,
        "seed": args.seed,
        "draw": args.draw,
        "held_out_scenarios": [sc.to_dict() for sc in scenarios],
        "summary": {n: r.summary.to_json() for n, r in results.items()},
        "noise_curve": {n: noise_curve_json(cs) for n, cs in curves.items()},
        "records": {n: [rec.to_json() for rec in r.records] for n, r in results.items()},
    }
    extra = noise_markdown(curves) if len(args.noise) > 1 else []
    if args.references:
        dirs = {
            n: Path(p).parent if Path(p).suffix else Path(p)
            for n, p in zip(libraries, args.library, strict=True)
        }
        refs = identification_references(libraries, dirs, demos, grid)
        payload["references"] = refs.to_json()
        extra += references_markdown(refs, results)
    markdown = evaluation_markdown(results, extra)
    with atomic_output_dir(args.out) as tmp:
        for name in results:
            plot_confusion(
                results[name].records,
                grid,
                DEFAULT_SCORER,
                tmp / f"confusion_{name}.png",
                title=f"{name} features, scorer {DEFAULT_SCORER}",
            )
            if len(args.noise) > 1:
                plot_noise_curve(
                    noise_curve_json(curves[name]),
                    tmp / f"noise_curve_{name}.png",
                    f"{name} features",
                )
        plot_theta_vs_risk(libraries, tmp / "theta_vs_risk.png")
        write_json(tmp / "evaluation.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        write_text(tmp / "evaluation.md", markdown)
    print(markdown)
    return payload


if __name__ == "__main__":
    run_cli(main)
