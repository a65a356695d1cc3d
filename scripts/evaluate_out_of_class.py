r"""Identify and predict drivers outside the style class whose caution order is known.

Simulates highway-env 1.12 traffic of four IDM + MOBIL driver classes of increasing caution
(agents/highway_drivers.py, ``HIGHWAY_CLASSES``; the study: studies/out_of_class/) on a
straight three-lane road, recorded at 10 Hz and extracted like recorded traffic, until each
class has ``--per-class`` lane changes (at most ``--max-runs`` runs); generates SMPC drivers
of another horizon, TV uncertainty and weights at the ``--risks`` in ``--scenarios``
interactive scenarios each; identifies every lane change's risk p with the driver library
(posterior mean, 90 % interval, verdict) and predicts it after 1, 2 and 3 s (CV, CA,
physics, population, mode, mixture). Writes ``OUT/out_of_class.json`` (every episode, group,
Spearman check, prediction record and summary, with the command) and
``OUT/out_of_class.md``. One process.

``--posterior FILE`` (an estimator ``drivestyle build-posterior`` wrote, its
``posterior.npz``) also identifies every lane change with the amortized posterior over the
stochastic driver's parameters and checks the caution order on the posterior means of p, T
and s_0 (Spearman's ρ over the episodes and the classes' medians, beside the exact ρ of p;
studies/out_of_class/amortized.py): ``out_of_class.json``'s ``amortized`` (every episode's
posterior mean and 90 % interval of every parameter, the checks) and a section of
``out_of_class.md``.

Example:
    drivestyle evaluate-out-of-class --library runs/library --out runs/out_of_class
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from drivestyle.common.cli import (
    HelpFormatter,
    count,
    distinct,
    float_list,
    for_option,
    run_cli,
    seed,
)
from drivestyle.common.io import (
    atomic_output_dir,
    check_output_dir,
    command_line,
    write_json,
    write_text,
)
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.irl.identification.library import load_driver_library
from drivestyle.prediction.physics_calibration import PHYSICS_FILE, load_params
from drivestyle.studies.out_of_class import (
    StudyConfig,
    out_of_class_markdown,
    run_study,
    vehicle_spans,
)
from drivestyle.studies.prediction.observed_times import check_observed_times

_D = StudyConfig()
SMPC_RISKS = (0.5, 1.0)
"""The SMPC variants' risks lie in [0.5, 1): the style class's range (its library's)."""


def smpc_risks(text: str) -> list[float]:
    """An argparse type: comma-separated SMPC risks p in [0.5, 1) (repeats kept: main says)."""
    values = float_list(text)
    lo, hi = SMPC_RISKS
    bad = [p for p in values if not lo <= p < hi]
    if bad:
        raise argparse.ArgumentTypeError(
            f"SMPC risks must lie in [{lo:g}, {hi:g}), got {', '.join(f'{p:g}' for p in bad)}"
        )
    return values


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--library", type=Path, required=True, help="driver library folder or its library.json"
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/out_of_class"), help="output folder (replaced whole)"
    )
    p.add_argument(
        "--seed", type=seed, default=_D.seed, help="seed of the traffic runs and the SMPC scenarios"
    )
    p.add_argument("--per-class", type=count(1000, 12.0, "lane changes per class"),
                   default=_D.per_class,
                   help="highway-env lane changes kept per driver class (≈ 12 s each)")  # fmt: skip
    p.add_argument("--max-runs", type=count(500, 8.0, "traffic runs"), default=_D.max_runs,
                   help="most 60 s traffic runs to find them (≈ 8 s each)")  # fmt: skip
    p.add_argument("--risks", type=smpc_risks, default=list(_D.smpc_risks),
                   help="comma-separated risks p of the SMPC variants, in [0.5, 1), at least "
                   "two distinct (a repeated risk counts once)")  # fmt: skip
    p.add_argument("--scenarios", type=count(1000, 30.0, "scenarios", least=0),
                   default=_D.smpc_scenarios,
                   help="interactive scenarios per SMPC variant and risk (0: none; ≈ 30 s "
                   "each with the default risks)")  # fmt: skip
    p.add_argument("--no-highway", action="store_true", help="no highway-env drivers")
    p.add_argument("--no-prediction", action="store_true", help="identification only")
    p.add_argument("--observe", type=float_list, default=None,
                   help="comma-separated observed times t_obs [s] to predict after: whole "
                   "numbers of T_s = 0.2 s, shorter than the lane changes (highway-env at most "
                   "8 s, SMPC 6 s); a repeated time counts once (default: "
                   f"{','.join(f'{t:g}' for t in _D.t_obs)})")  # fmt: skip
    p.add_argument(
        "--physics",
        type=Path,
        default=None,
        help=f"the physics baseline's parameters (default: {PHYSICS_FILE.name} shipped with "
        "the package)",
    )
    p.add_argument(
        "--posterior",
        type=Path,
        default=None,
        help="an amortized posterior (build-posterior's posterior.npz): also identify every "
        "lane change with it and check the caution order on its p, T and s_0",
    )
    args = p.parse_args(argv)
    # options of the prediction, which --no-prediction skips: refused, not silently ignored
    given = [f"--{name}" for name in ("observe", "physics") if getattr(args, name) is not None]
    if args.no_prediction and given:
        raise ValueError(
            f"{' and '.join(given)} {'apply' if len(given) > 1 else 'applies'} to the "
            "prediction, which --no-prediction skips; drop one or the other"
        )
    args.observe = list(_D.t_obs) if args.observe is None else args.observe
    args.physics = PHYSICS_FILE if args.physics is None else args.physics
    return args


def _config(args: argparse.Namespace) -> StudyConfig:
    """The study's configuration, every option checked (before any output or simulation).

    The observed times by the prediction study's one rule
    (:func:`~drivestyle.studies.prediction.observed_times.check_observed_times`) against this run's
    lane changes; a repeated risk or time counts once, and a note says so.
    """
    if args.no_highway and args.scenarios == 0:
        raise ValueError("--no-highway and --scenarios 0 leave no driver to study")
    risks, risks_twice = distinct(args.risks)
    observe, observe_twice = distinct(args.observe)
    for option, twice in (("--risks", risks_twice), ("--observe", observe_twice)):
        if twice:
            print(
                f"note: {option} lists {', '.join(f'{v:g}' for v in twice)} more than once; "
                "each counts once",
                file=sys.stderr,
            )
    if args.scenarios and len(risks) < 2:
        raise ValueError(
            f"--risks: the SMPC variants need at least two distinct risks to order, got "
            f"{', '.join(f'{p:g}' for p in risks)} (or --scenarios 0: no SMPC variants)"
        )
    config = StudyConfig(
        seed=args.seed,
        per_class=0 if args.no_highway else args.per_class,
        max_runs=args.max_runs,
        smpc_risks=tuple(risks),
        smpc_scenarios=args.scenarios,
        t_obs=tuple(observe),
        predict=not args.no_prediction,
    )
    if config.predict:
        try:
            check_observed_times(config.t_obs, simulated=False, others=vehicle_spans(config))
        except ValueError as exc:
            raise ValueError(f"--observe: {exc}") from None
    return config


def main(argv: list[str] | None = None) -> dict:
    """Run the study; returns out_of_class.json's payload."""
    args = parse_args(argv)
    argv_used = [sys.argv[0], *(argv if argv is not None else sys.argv[1:])]
    config = _config(args)
    estimator = [args.posterior] if args.posterior is not None else []
    check_output_dir(args.out, inputs=[args.library, args.physics, *estimator])
    with for_option("--physics"):
        physics = load_params(args.physics)
    library = load_driver_library(args.library, "identification")
    posterior = open_posterior(args.posterior) if args.posterior is not None else None
    bars: dict[str, tqdm] = {}

    def on_plan(stage: str, n: int) -> None:
        bars[stage] = tqdm(total=n, desc=f"out of class: {stage}", unit="")

    t0 = time.perf_counter()
    try:
        study = run_study(library, config, physics, progress=lambda s, k: bars[s].update(k),
                          on_plan=on_plan, posterior=posterior,
                          estimator=str(args.posterior or ""))  # fmt: skip
    finally:
        for bar in bars.values():
            bar.close()
    wall = time.perf_counter() - t0
    payload = study.to_json() | {"library": str(args.library), "wall_s": wall}
    markdown = out_of_class_markdown(study, command_line(argv_used))
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "out_of_class.json", payload, argv_used)
        write_text(tmp / "out_of_class.md", markdown)
    print(markdown)
    print(f"wall time {wall:.0f} s; wrote {args.out}")
    return payload


if __name__ == "__main__":
    run_cli(main)
