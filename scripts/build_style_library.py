r"""Build a style library for identification: the driver model's (default) or the paper's.

Draws K interactive scenarios (the SMPC at the lowest risk triggers) from the
LaneChangeRandom family with ``--seed`` and generates the SMPC demonstration of every risk
in each. ``--model driver`` (default, DESIGN §15) learns the one receding-horizon cost all
of them share (each demonstration with its known risk), then calibrates the likelihood's
temperature on ``--calibration`` further scenarios (seed + 1) with continuous risks drawn
from U[0.5, 0.95]. ``--model paper`` learns per risk one θ of the paper's whole-horizon
model from its K demonstrations jointly and one θ per demonstration (DESIGN §8). Writes
``OUT/library.json``, the demonstrations under ``OUT/demos/`` and, for the paper model,
``OUT/theta_vs_risk.png``. The folder is written atomically: an interrupted build leaves
the previous library (or none), never a mix.

Example:
    python scripts/build_style_library.py --out runs/library
    python scripts/build_style_library.py --model paper --scenarios 10 --features reactive \\
        --out runs/library_reactive
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
from tqdm import tqdm

from drivestyle.agents import SMPCConfig
from drivestyle.agents.demo_generation import (
    draw_interactive_scenarios,
    generate_demonstration,
    generate_demonstrations,
)
from drivestyle.common.cli import HelpFormatter, count, risk_list, run_cli, seed, workers
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs.demonstration import Demonstration, save_demonstration
from drivestyle.envs.tracking import observe
from drivestyle.irl.driver.driver_style import RISK_RANGE
from drivestyle.irl.identification.library import LibraryError, learn_driver_library, learn_library
from drivestyle.irl.identification.posterior import calibrate_temperature
from drivestyle.studies.plotting import plot_theta_vs_risk


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--risks",
        type=risk_list,
        default=[0.5, 0.6, 0.7, 0.8, 0.9, 0.95],
        help="comma-separated SMPC risk levels p in (0, 1), at least two (the driver model: "
        "in [0.5, 0.99])",
    )
    p.add_argument(
        "--model",
        default="driver",
        choices=("driver", "paper"),
        help="the receding-horizon driver model (DESIGN §15) or the paper's whole-horizon one",
    )
    p.add_argument(
        "--scenarios",
        type=count(10_000, 30.0, "scenarios"),
        help="K training scenarios per risk (default: 3 for the driver model, 30 for the paper's)",
    )
    p.add_argument(
        "--calibration",
        type=count(10_000, 30.0, "scenarios"),
        default=12,
        help="driver model: scenarios (one continuous risk each) calibrating the temperature",
    )
    p.add_argument(
        "--features", default="reactive", choices=("reactive", "base"), help="feature set"
    )
    p.add_argument(
        "--tracked",
        action="store_true",
        help="learn from the demonstrations as a tracker records them (positions only, "
        "envs/tracking.py): the library for identifying noisy recordings",
    )
    p.add_argument("--workers", type=workers, default=2, help="worker processes")
    p.add_argument("--seed", type=seed, default=0, help="seed of the training scenario draws")
    p.add_argument(
        "--out", type=Path, default=Path("runs/library"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Build the library; returns library.json's payload."""
    args = parse_args(argv)
    if args.scenarios is None:
        args.scenarios = 3 if args.model == "driver" else 30
    check_output_dir(args.out)
    # each risk's range first, then how many: a risk of 0.995 is out of range, not too few
    lo, hi = RISK_RANGE
    outside = [p for p in args.risks if not lo <= p <= hi]
    if args.model == "driver" and outside:
        raise LibraryError(
            f"--risks {', '.join(f'{p:g}' for p in outside)} outside [{lo}, {hi}], the driver "
            "model's risk range (the risks it infers); use --model paper for other risks"
        )
    if len(args.risks) < 2:
        raise ValueError(
            f"--risks: need at least two risks to tell styles apart, got "
            f"{', '.join(f'{p:g}' for p in args.risks)} (e.g. 0.5,0.7,0.9)"
        )
    if args.model == "driver":
        return _build_driver(args, argv)
    t0 = time.perf_counter()
    scenarios = draw_interactive_scenarios(args.scenarios, args.seed, min(args.risks))
    t_draw = time.perf_counter() - t0
    bar = tqdm(total=2 * len(args.risks), desc="demonstrations, then styles per risk")
    demos = generate_demonstrations(args.risks, scenarios, args.workers, lambda p: bar.update(1))
    demos = _observed(demos, args)

    def progress(rec: dict) -> None:
        bar.update(1)
        bar.set_postfix(p=rec["risk"], iters=rec["iterations"])

    library = learn_library(
        demos,
        args.features,
        args.workers,
        progress,
        meta={  # the training scenarios are recorded from the demonstrations themselves
            "uncertainty": asdict(SMPCConfig().uncertainty),
            "observation": "tracked" if args.tracked else "true",
        },
    )
    bar.close()
    payload = library.to_json() | {
        "seed": args.seed,
        "k_scenarios": args.scenarios,
        "draw_s": t_draw,
        "build_wall_s": time.perf_counter() - t0,
    }
    _write_library(
        args.out, demos, payload, argv,
        lambda tmp: plot_theta_vs_risk({args.features: library}, tmp / "theta_vs_risk.png"),
    )  # fmt: skip
    print(
        f"wrote {args.out}/library.json: {len(args.risks)} styles from {args.scenarios} "
        f"scenarios each in {payload['build_wall_s']:.1f} s"
    )
    return payload


def _build_driver(args: argparse.Namespace, argv: list[str] | None) -> dict:
    """The driver-model library (module docstring)."""
    t0 = time.perf_counter()
    scenarios = draw_interactive_scenarios(args.scenarios, args.seed, min(args.risks))
    bar = tqdm(total=len(args.risks), desc="demonstrations per risk")
    demos = generate_demonstrations(args.risks, scenarios, args.workers, lambda p: bar.update(1))
    bar.close()
    demos = _observed(demos, args)
    t_demos = time.perf_counter() - t0
    with tqdm(desc="learning the shared cost (LM iterations)") as lbar:
        library, fit = learn_driver_library(
            demos,
            meta={
                "uncertainty": asdict(SMPCConfig().uncertainty),
                "observation": "tracked" if args.tracked else "true",
                "training_scenarios": [sc.to_dict() for sc in scenarios],
            },
            progress=lambda it, cost: _tick(lbar, cost),
        )
    t_learn = time.perf_counter() - t0 - t_demos
    rng = np.random.default_rng([args.seed, 1])
    cal_scenarios = draw_interactive_scenarios(args.calibration, args.seed + 1, min(args.risks))
    cal_demos = []
    for sc in tqdm(cal_scenarios, desc="calibration demonstrations"):
        risk = float(np.round(rng.uniform(0.5, 0.95), 3))
        demo, _ = generate_demonstration(risk, sc, SMPCConfig(risk=risk))
        if args.tracked:
            demo = observe(demo, 0.0, rng)
        cal_demos.append(demo)
    calibration = calibrate_temperature(library, cal_demos)
    library = replace(library, temperature=calibration.temperature)
    payload = library.to_json() | {
        "calibration": calibration.to_json(),
        "seed": args.seed,
        "k_scenarios": args.scenarios,
        "demos_s": t_demos,
        "learn_s": t_learn,
        "build_wall_s": time.perf_counter() - t0,
    }
    _write_library(args.out, demos, payload, argv)
    print(
        f"wrote {args.out}/library.json: one driver cost from {len(args.risks)} risks × "
        f"{args.scenarios} scenarios (fit {fit.status}, residual rms {fit.residual_rms:.3f}), "
        f"temperature {calibration.temperature:g} (coverage "
        f"{calibration.coverage[calibration.temperature]:.2f} on {calibration.n_demos} "
        f"calibration demos), {payload['build_wall_s']:.0f} s"
    )
    return payload


def _observed(
    demos: dict[float, list[Demonstration]], args: argparse.Namespace
) -> dict[float, list[Demonstration]]:
    """The demonstrations as learned from: with ``--tracked`` the tracker's view (σ = 0)."""
    if not args.tracked:
        return demos
    rng = np.random.default_rng(args.seed)
    return {p: [observe(d, 0.0, rng) for d in ds] for p, ds in demos.items()}


def _write_library(
    out: Path,
    demos: dict[float, list[Demonstration]],
    payload: dict,
    argv: list[str] | None,
    figure: Callable[[Path], object] | None = None,
) -> None:
    """Write the output folder whole: training demonstrations, ``library.json``, a figure.

    ``figure`` draws into the (temporary) folder it is given.
    """
    with atomic_output_dir(out) as tmp:
        for p, risk_demos in demos.items():
            for i, demo in enumerate(risk_demos):
                save_demonstration(demo, tmp / "demos" / f"p{p:g}_s{i}.npz")
        write_json(tmp / "library.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        if figure is not None:
            figure(tmp)


def _tick(bar: tqdm, cost: float) -> None:
    bar.update(1)
    bar.set_postfix(cost=f"{cost:.3g}")


if __name__ == "__main__":
    run_cli(main)
