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

A driver library (``build_style_library.py``'s default, DESIGN §15) is evaluated with its
one scorer, ``likelihood`` (one risk profile per demonstration), under the name
``driver``; ``--continuous K`` adds K demonstrations per scenario with true risks drawn
from U[0.5, 0.95]. Every evaluation reports the *path ceiling* beside identification: the
SMPC(q) paths of the grid risks in the demonstration's own scenario (the held-out
demonstrations themselves: the expert is deterministic), the accuracy of picking the
closest, and the *identifiable* grid demonstrations — those whose neighbouring grid risks'
closed-loop paths lie ≥ 5 cm RMS from the true risk's — with identification's accuracy on
them (``OUT/estimates_driver.png``: continuous and grid risks with their intervals).

``--posterior FILE`` (the estimator ``build-posterior`` writes, ``OUT/posterior.npz``;
needs a driver library and the ``sbi`` extra) reads the very same demonstrations, as
observed at every noise level, with the amortized posterior beside the exact one
(studies/identification/amortized.py): its risk error, coverage, grid and identifiable
accuracy by the exact's rule, its agreement with the exact posterior, the noise's cost and
its time per episode, and its other parameters against the SMPC expert's values — in
``evaluation.json``'s ``amortized`` section, ``evaluation.md`` and
``OUT/estimates_amortized.png``.

Example:
    python scripts/evaluate_identification.py --library runs/library_reactive \\
        --scenarios 10 --seed 2000 --noise 0,0.05,0.1,0.2,0.3 --references --out runs/test
    python scripts/evaluate_identification.py --library runs/library --scenarios 10 \\
        --continuous 3 --seed 2000 --noise 0,0.1 --out runs/test_driver
    python scripts/evaluate_identification.py --library runs/library --scenarios 10 \\
        --continuous 3 --seed 2000 --noise 0,0.1 --posterior runs/posterior/posterior.npz \\
        --out runs/test_amortized
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
from drivestyle.common.cli import (
    HelpFormatter,
    count,
    nonnegative_list,
    risk_list,
    run_cli,
    seed,
    workers,
)
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json, write_text
from drivestyle.envs.scenario import ScenarioConfig, ScenarioRanges
from drivestyle.envs.traffic import TrafficRanges, TrafficScene
from drivestyle.irl.amortized.estimator import (
    EstimatorFileError,
    NeuralPosterior,
    load_posterior,
)
from drivestyle.irl.amortized.simulations import check_episode_estimator
from drivestyle.irl.identification.library import (
    DriverLibrary,
    LibraryError,
    StyleLibrary,
    load_any_library,
)
from drivestyle.studies.identification import (
    Evaluation,
    continuous_demonstrations,
    draw_continuous_risks,
    driver_evaluation_markdown,
    evaluate_identification,
    evaluation_markdown,
    identification_references,
    noise_curve_json,
    noise_markdown,
    references_markdown,
)
from drivestyle.studies.identification.amortized import evaluate_beside_exact
from drivestyle.studies.identification.figures import (
    plot_beside_exact,
    plot_confusion,
    plot_noise_curve,
)
from drivestyle.studies.identification.report import amortized_markdown
from drivestyle.studies.plotting import plot_population, plot_theta_vs_risk

DRIVER = "driver"
"""The name a driver library is evaluated and reported under."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--library",
        type=Path,
        action="append",
        required=True,
        help="library folder or library.json (repeat for several feature sets; a driver "
        "library is evaluated beside them)",
    )
    p.add_argument(
        "--scenarios", type=count(10_000, 60.0, "scenarios"), default=5, help="M held-out scenarios"
    )
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
        "--continuous",
        type=count(1000, 20.0, "continuous-risk demonstrations per scenario", least=0),
        default=0,
        help="per scenario, this many more demonstrations with true risks drawn from "
        "U[0.5, 0.95] (continuous-risk MAE and coverage)",
    )
    p.add_argument(
        "--seed", type=seed, default=1000, help="held-out scenario seed (not the library's)"
    )
    p.add_argument("--workers", type=workers, default=2, help="worker processes")
    p.add_argument(
        "--noise",
        type=nonnegative_list,
        default=[0.0],
        help="comma-separated position noise levels sigma [m] (0: true states)",
    )
    p.add_argument(
        "--references",
        action="store_true",
        help="also run the ceiling that knows the expert and a k-NN baseline without IRL",
    )
    p.add_argument(
        "--posterior",
        type=Path,
        default=None,
        metavar="FILE",
        help="an amortized posterior (build-posterior's OUT/posterior.npz) evaluated beside "
        "the driver library's exact one on the same demonstrations",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/evaluation"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Evaluate; returns evaluation.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[*args.library, args.posterior])
    if args.references and args.draw == "traffic":
        raise ValueError(
            "--references simulates single-TV scenarios (the ceiling re-simulation); with "
            "--draw traffic the path ceiling of every evaluation is the reference"
        )
    libraries: dict[str, StyleLibrary | DriverLibrary] = {}
    for path in args.library:
        lib = load_any_library(path)
        name = DRIVER if isinstance(lib, DriverLibrary) else lib.feature_set
        if name in libraries:
            raise LibraryError(f"two {name!r} libraries given")
        libraries[name] = lib
        if lib.meta.get("seed") == args.seed:
            raise LibraryError(
                f"--seed {args.seed} is the library's own training seed; "
                "use a disjoint seed for held-out scenarios"
            )
    posterior = None if args.posterior is None else _load_posterior(args.posterior, libraries)
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
    continuous_risks = draw_continuous_risks(len(scenarios), args.continuous, args.seed)
    if args.continuous:
        demos += continuous_demonstrations(scenarios, continuous_risks, args.workers)
    results: dict[str, Evaluation] = {}
    curves: dict[str, list[Evaluation]] = {}
    for name, lib in libraries.items():
        curves[name] = []
        for sigma in args.noise:
            with tqdm(total=len(demos), desc=f"identify ({name}, noise {sigma:g} m)") as bar:
                res = evaluate_identification(
                    lib, demos, grid, bar.update, args.workers, sigma, args.seed, ceiling=True
                )
            results.setdefault(name, res)  # the first noise level is the headline
            curves[name].append(res)
    payload = {
        "grid_risks": grid,
        "between_risks": between,
        "continuous_risks": continuous_risks if args.continuous else [],
        "seed": args.seed,
        "draw": args.draw,
        "held_out_scenarios": [sc.to_dict() for sc in scenarios],
        "summary": {n: r.summary.to_json() for n, r in results.items()},
        "noise_curve": {n: noise_curve_json(cs) for n, cs in curves.items()},
        "records": {n: [rec.to_json() for rec in r.records] for n, r in results.items()},
    }
    beside = None
    if posterior is not None:
        driver = libraries[DRIVER]
        assert isinstance(driver, DriverLibrary)  # _load_posterior checked it
        with tqdm(total=len(demos) * len(args.noise), desc="amortized posterior") as bar:
            beside = evaluate_beside_exact(
                posterior, args.posterior, demos, driver, curves[DRIVER], args.seed,
                progress=bar.update,
            )  # fmt: skip
        payload["amortized"] = beside.to_json()
    paper = {n: lib for n, lib in libraries.items() if isinstance(lib, StyleLibrary)}
    paper_results = {n: r for n, r in results.items() if n in paper}
    paper_curves = {n: c for n, c in curves.items() if n in paper}
    extra = noise_markdown(paper_curves) if len(args.noise) > 1 and paper else []
    refs = None
    if args.references:
        dirs = {
            n: Path(p).parent if Path(p).suffix else Path(p)
            for n, p in zip(libraries, args.library, strict=True)
            if n in paper
        }
        refs = identification_references(paper, dirs, demos, grid)
        payload["references"] = refs.to_json()
        if paper:
            extra += references_markdown(refs, paper_results)
    markdown = evaluation_markdown(paper_results, extra) if paper else ""
    if DRIVER in results:
        markdown += driver_evaluation_markdown(curves[DRIVER], refs)
    if beside is not None:
        markdown += amortized_markdown(beside)
    with atomic_output_dir(args.out) as tmp:
        for name in results:
            scorer = results[name].scorer
            plot_confusion(
                results[name].records,
                grid,
                scorer,
                tmp / f"confusion_{name}.png",
                title=f"{name} {'model' if name == DRIVER else 'features'}, scorer {scorer}",
            )
            if len(args.noise) > 1:
                plot_noise_curve(
                    noise_curve_json(curves[name]),
                    tmp / f"noise_curve_{name}.png",
                    f"{name} {'model' if name == DRIVER else 'features'}",
                )
        if paper:
            plot_theta_vs_risk(paper, tmp / "theta_vs_risk.png")
        if DRIVER in results:
            plot_population(
                _estimate_rows(results[DRIVER]),
                tmp / f"estimates_{DRIVER}.png",
                "driver model: posterior mean and 90 % interval vs the true risk",
            )
        if beside is not None:
            plot_beside_exact(
                beside,
                tmp / "estimates_amortized.png",
                "p: the exact posterior and the amortized one, mean and 90 % interval",
            )
        write_json(tmp / "evaluation.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        write_text(tmp / "evaluation.md", markdown)
    print(markdown)
    return payload


def _load_posterior(
    path: Path, libraries: dict[str, StyleLibrary | DriverLibrary]
) -> NeuralPosterior:
    """The ``--posterior`` estimator, verified, before any work (one-line errors)."""
    if DRIVER not in libraries:
        raise LibraryError(
            "--posterior is evaluated beside a driver library's exact posterior: give one "
            "with --library"
        )
    try:
        posterior = check_episode_estimator(load_posterior(path), path)
    except EstimatorFileError as exc:
        raise EstimatorFileError(f"--posterior {exc}") from None
    except ImportError as exc:
        raise LibraryError(f"--posterior {path}: {exc}") from None
    return posterior


def _estimate_rows(evaluation: Evaluation) -> list[dict]:
    """The records as :func:`plot_population`'s rows (posterior mean, interval, truth)."""
    rows = []
    for r in evaluation.records:
        if not r.ok:
            continue
        ident = r.by_scorer[evaluation.scorer]
        lo, hi = ident.risk_interval
        rows.append(
            {
                "status": "ok",
                "risk_mean": ident.risk_interpolated,
                "true_risk": r.risk,
                "risk_lo": lo,
                "risk_hi": hi,
            }
        )
    return rows


if __name__ == "__main__":
    run_cli(main)
