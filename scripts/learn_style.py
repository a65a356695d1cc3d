"""Learn a driving style from one or more demonstrations of one driver.

``--model driver`` (default, DESIGN §15): the receding-horizon style model — cost weights,
risk p and (``--fit-speed``) desired speed of one driver, learned from every step of every
demonstration (teacher forcing), then driven in closed loop in each demonstration's
scenario. With ``--cost-from LIBRARY`` the weights are a driver library's (a population's
cost) and only the driver's own risk (and desired speed) is learned. Writes
``OUT/style.json`` (``kind: driver-style``: style, fit status, residuals, per-demonstration
residual RMS and best risk alone, per-demonstration rmse_y_m / rmse_xy_m of the
closed-loop reproduction). When some demonstrations' residuals lie far above the
noise floor (``--residual-floor``: what one driver of the class leaves) and the learned
style's closed loop does not reproduce them (rmse_xy above 0.01 m), no single driver
explains them all — e.g. two drivers of different risks learned together: ``style.json``
is still written, with ``"status": "poor_fit"`` and the disagreeing demonstrations named,
and the script ends with one ``error: poor fit …`` line and exit status 3. A residual
above the threshold whose closed loop reproduces the demonstration is a local minimum of
learning, not a poor fit: one ``note:`` line, and the optimiser's status.

``--model paper``: the paper's whole-horizon model, feature weights θ by ME-IRL. Writes
``OUT/style.json`` (docs/DESIGN.md §7: features, theta, iterations, converged,
status, learning_error, rmse_y_m, rmse_xy_m, rmse_y_reaction_m, wall_time_s,
inner_solve_ms_median, t_trg_s, t_rct_s, omega, feature values, history, reproduced) and,
with ``--plot``, ``OUT/reproduction.png`` and ``OUT/lateral.png``. Learning is
deterministic (no seed). When learning stalls (the inner problem fails at every trial θ),
``style.json`` is still written, with ``"status": "stalled"`` and the last solved θ, and the
script ends with an ``error:`` line and a non-zero exit status.

An option of the other model is refused (exit status 2), not ignored.

Example:
    python scripts/learn_style.py runs/demo/demo.npz --model paper --features reactive \
        --out runs/style
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, positive_float, positive_int, run_cli
from drivestyle.common.inputs import distinct_files
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs import load_demonstration
from drivestyle.irl import FEATURE_SETS, FeatureConfig, IRLConfig
from drivestyle.irl.driver.driver_fit import (
    POOR_FIT_RATIO,
    DriverFit,
    reproduced_note,
    save_driver_style,
)
from drivestyle.irl.driver.driver_learning import learn_driver
from drivestyle.irl.driver.driver_style import RESIDUAL_FLOOR, WEIGHT_NAMES
from drivestyle.irl.identification.library import load_driver_library
from drivestyle.irl.paper.inner import InnerSolveError
from drivestyle.irl.paper.learner import UPDATE_RULES, IterationRecord, check_learnable
from drivestyle.irl.paper.spline import CONTROL_POINT_RULES, demo_control_points
from drivestyle.irl.paper.style import fit_style, locate_demos
from drivestyle.studies.paper.figures import plot_lateral, plot_reproductions

EXIT_POOR_FIT = 3
"""Exit status when the driver model's fit is ``poor_fit`` (``style.json`` is written)."""
PAPER_OPTIONS: dict[str, object] = {
    "features": "reactive",
    "method": "lm",
    "control_point_rule": "kinematic",
    "t_rct": 2.0,
    "alpha": 3e-4,
    "plot": False,
}
"""Options of ``--model paper`` only, with their defaults (None in the parser: given?)."""
DRIVER_OPTIONS: dict[str, object] = {
    "fit_speed": False,
    "residual_floor": RESIDUAL_FLOOR,
    "cost_from": None,
}
"""Options of ``--model driver`` only, with their defaults."""


class _Formatter(HelpFormatter):
    """Defaults in the help, except the model-specific ones (None: says its own default)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default is None:
            return action.help
        return super()._get_help_string(action)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments; an option of the model not chosen is refused.

    Raises:
        ValueError: an option given that does not apply to ``--model`` (one line).
    """
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        formatter_class=_Formatter,
        epilog=f"exit status: 0 learned; 2 bad input (or paper model stalled); "
        f"{EXIT_POOR_FIT} driver model poor_fit (style.json written, the demonstrations "
        "no single driver explains named on stderr)",
    )
    p.add_argument("demos", nargs="+", type=Path, help="demonstration .npz file(s)")
    p.add_argument(
        "--model",
        default="driver",
        choices=("driver", "paper"),
        help="the receding-horizon driver model (one driver across scenarios) or the paper's "
        "whole-horizon ten-feature model",
    )
    p.add_argument(
        "--fit-speed",
        action="store_true",
        default=None,
        help="driver model only: also learn the desired speed (recorded traffic: unknown)",
    )
    p.add_argument(
        "--residual-floor",
        type=positive_float,
        default=None,
        help="driver model only: the residual RMS one driver of the class leaves, in units "
        f"of the input scale σ_u (default {RESIDUAL_FLOOR}: a simulated driver); a "
        f"demonstration above {POOR_FIT_RATIO:g}× it makes the fit poor_fit",
    )
    p.add_argument(
        "--cost-from",
        type=Path,
        default=None,
        help="driver model only: keep this driver library's cost weights (folder or "
        "library.json, e.g. runs/library) and learn only the driver's own risk (and "
        "--fit-speed's desired speed): a recorded vehicle's parameters under the "
        "population's cost",
    )
    p.add_argument(
        "--features",
        choices=sorted(FEATURE_SETS),
        default=None,
        help="paper model only: feature set (default reactive)",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/style"), help="output folder (other files kept)"
    )
    p.add_argument(
        "--method",
        choices=UPDATE_RULES,
        default=None,
        help="paper model only: outer update, Levenberg-Marquardt in log theta or the "
        "paper's rule (default lm)",
    )
    p.add_argument(
        "--control-point-rule",
        "--rule",
        dest="control_point_rule",
        choices=CONTROL_POINT_RULES,
        default=None,
        help="paper model only: how demo velocities/accelerations are computed "
        "(docs/DESIGN.md §4; default kinematic)",
    )
    p.add_argument(
        "--t-rct",
        type=positive_float,
        default=None,
        help="paper model only: reaction window T_rct [s] (default 2.0)",
    )
    p.add_argument(
        "--max-iter",
        type=positive_int,
        help="iterations of each Levenberg-Marquardt run (default: 30 driver; paper 60 lm, "
        "400 paper rule)",
    )
    p.add_argument(
        "--alpha",
        type=positive_float,
        default=None,
        help="paper model only: learning rate of the paper rule (default 0.0003)",
    )
    p.add_argument(
        "--plot",
        action="store_true",
        default=None,
        help="paper model only: write reproduction figures",
    )
    args = p.parse_args(argv)
    own, other = (DRIVER_OPTIONS, PAPER_OPTIONS)
    if args.model == "paper":
        own, other = other, own
    given = [name for name in other if getattr(args, name) is not None]
    if given:
        flags = ", ".join("--" + name.replace("_", "-") for name in given)
        owner = "paper" if args.model == "driver" else "driver"
        raise ValueError(
            f"{flags} {'applies' if len(given) == 1 else 'apply'} to --model {owner} only, "
            f"not to --model {args.model}"
        )
    for name, default in {**own, **other}.items():
        if getattr(args, name) is None:
            setattr(args, name, default)
    return args


class LearningStalledError(RuntimeError):
    """The inner problem failed at every trial θ: the written θ is not a learned style."""


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the script; returns the style payload.

    Raises:
        LearningStalledError: after writing ``style.json``, when learning stalled.
    """
    args = parse_args(argv)
    # a style may sit beside its demonstration (its files are added, none replaced)
    check_output_dir(args.out, replace=False, inputs=[*args.demos, args.cost_from])
    files = distinct_files(args.demos)  # a file or copy given twice would weigh twice
    if files.note:
        print(files.note, file=sys.stderr)
    args.demos = list(files.kept)
    demos = [load_demonstration(p) for p in args.demos]
    if args.model == "driver":
        return _learn_driver(args, demos, argv)
    features = FeatureConfig(feature_set=args.features, t_rct=args.t_rct)
    max_iter = (
        args.max_iter if args.max_iter is not None else (400 if args.method == "paper" else 60)
    )
    config = IRLConfig(method=args.method, max_iter=max_iter, alpha=args.alpha)
    bar = tqdm(total=max_iter, desc=f"ME-IRL ({args.features})", leave=False)

    def progress(entry: IterationRecord) -> None:
        bar.update(1)
        bar.set_postfix(eps=f"{entry.epsilon:.3f}", rmse_y=f"{entry.rmse_y_m:.3f}")

    try:
        fitted = fit_style(
            demos, features, config, args.control_point_rule, [str(p) for p in args.demos], progress
        )
    except InnerSolveError as exc:
        raise RuntimeError(f"learning failed at the initial theta: {exc}") from None
    finally:
        bar.close()
    result, payload = fitted.result, locate_demos(fitted.to_json(), args.out, args.demos)
    with atomic_output_dir(args.out, replace=False) as tmp:
        write_json(tmp / "style.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        if args.plot:
            demo = demos[0]
            C = demo_control_points(demo, args.control_point_rule)
            plot_reproductions(demo, {args.features: result}, C, tmp / "reproduction.png")
            plot_lateral(
                demo,
                result,
                C,
                tmp / "lateral.png",
                title=f"lateral motion, {args.features} features",
            )
    if not fitted.trigger_fired:
        print(
            "note: the trigger never fired in the (first) demonstration: "
            "the reactive features f_sd, f_ed, f_id are inactive"
        )
    react = fitted.rmse_y_reaction_m
    status = {"converged": "converged", "max_iter": "NOT converged: max_iter reached"}
    print(
        f"wrote {args.out / 'style.json'}: {result.iterations} iterations "
        f"({status.get(result.status, result.status.upper())}), learning error "
        f"{result.learning_error:.3f}, rmse_y {fitted.rmse_y_m:.3f} m"
        + (f" (reaction window {react:.3f} m)" if react is not None else "")
        + f", {result.wall_time_s:.2f} s"
    )
    if result.status == "stalled":
        raise LearningStalledError(
            f"learning stalled after {result.iterations} iterations ({result.stop_reason}); "
            f"{args.out / 'style.json'} holds the last solved theta with status 'stalled'"
        )
    return payload


def _learn_driver(args: argparse.Namespace, demos: list, argv: list[str] | None) -> dict[str, Any]:
    """The driver model's learning (module docstring).

    Raises:
        LearningStalledError: after writing ``style.json``, when learning stalled.
        SystemExit: status :data:`EXIT_POOR_FIT` after writing ``style.json``, when no
            single driver explains every demonstration.
    """
    for path, demo in zip(args.demos, demos, strict=True):
        try:
            check_learnable(demo)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None
    max_iter = args.max_iter if args.max_iter is not None else 30
    initial = None
    if args.cost_from:
        initial = load_driver_library(args.cost_from, "--cost-from").style
    with tqdm(desc="driver style (LM iterations)", leave=False) as bar:
        fit = learn_driver(
            demos,
            fit_speed=args.fit_speed,
            max_iter=max_iter,
            progress=lambda it, cost: _tick(bar, cost),
            residual_floor=args.residual_floor,
            initial=initial,
            fit_weights=initial is None,
        )
    # learn_driver drove the learned style in closed loop from each demonstration's start
    reproductions = [d.closed_loop.to_json() for d in fit.per_demo if d.closed_loop is not None]
    with atomic_output_dir(args.out, replace=False) as tmp:
        save_driver_style(fit, tmp / "style.json", [str(p) for p in args.demos], reproductions)
    payload = json.loads((args.out / "style.json").read_text())
    med_y = float(np.median([r["rmse_y_m"] for r in reproductions]))
    med_xy = float(np.median([r["rmse_xy_m"] for r in reproductions]))
    w = ", ".join(f"{n} {v:.3g}" for n, v in zip(WEIGHT_NAMES, fit.style.normalised(), strict=True))
    print(
        f"wrote {args.out / 'style.json'}: risk {fit.style.risk:.3f}, weights [{w}]"
        + (f", desired speed {fit.style.v_ref:.1f} m/s" if fit.style.v_ref else "")
        + f"; {fit.status} after {fit.iterations} iterations, {fit.seconds:.0f} s, residual "
        f"rms {fit.residual_rms:.3g} σ_u (floor {fit.residual_floor:g}); "
        f"closed-loop median rmse_y {med_y:.3f} m, rmse_xy {med_xy:.3f} m over {len(demos)} "
        f"demonstration{'s' if len(demos) > 1 else ''}"
    )
    for d in fit.per_demo:
        if d.reproduced and d.residual_rms > fit.poor_fit_threshold:
            print(f"note: {reproduced_note(d, fit.residual_floor, args.demos[d.index].name)}")
    if fit.optimiser_status == "stalled":
        raise LearningStalledError(
            f"learning stalled ({args.out / 'style.json'} holds the starting style)"
        )
    if fit.status == "poor_fit":
        print(f"error: {_poor_fit_message(fit, args.demos)}", file=sys.stderr)
        sys.exit(EXIT_POOR_FIT)
    return payload


def _poor_fit_message(fit: DriverFit, paths: list[Path]) -> str:
    """One line: which demonstrations the learned driver does not explain, and why."""
    poor = [d for d in fit.per_demo if d.poor] or list(fit.per_demo)
    named = []
    for d in poor:
        alone = "" if d.best_risk is None else f", alone best at p {d.best_risk:.2f}"
        loop = (
            ""
            if d.closed_loop is None
            else f", closed loop rmse_xy {d.closed_loop.rmse_xy_m:.2f} m"
        )
        named.append(f"{paths[d.index].name} (rms {d.residual_rms:.3g}{alone}{loop})")
    return (
        f"poor fit: residual rms above {POOR_FIT_RATIO:g}× the noise floor "
        f"{fit.residual_floor:g} σ_u at the learned risk {fit.style.risk:.3f}, and the closed "
        "loop does not reproduce them, for "
        + ", ".join(named)
        + ": the learned driver does not explain them (drivers of different styles, a "
        "driver outside the class, or a local minimum of learning); style.json has status "
        "'poor_fit'"
    )


def _tick(bar: tqdm, cost: float) -> None:
    bar.update(1)
    bar.set_postfix(cost=f"{cost:.3g}")


if __name__ == "__main__":
    run_cli(main)
