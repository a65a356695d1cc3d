"""Learn a driving style (feature weights θ) from one or more demonstrations by ME-IRL.

Writes ``OUT/style.json`` (docs/DESIGN.md §7: features, theta, iterations, converged,
status, learning_error, rmse_y_m, rmse_xy_m, rmse_y_reaction_m, wall_time_s,
inner_solve_ms_median, t_trg_s, t_rct_s, omega, feature values, history, reproduced) and,
with ``--plot``, ``OUT/reproduction.png`` and ``OUT/lateral.png``. Learning is
deterministic (no seed). When learning stalls (the inner problem fails at every trial θ),
``style.json`` is still written, with ``"status": "stalled"`` and the last solved θ, and the
script ends with an ``error:`` line and a non-zero exit status.

Example:
    python scripts/learn_style.py runs/demo/demo.npz --features reactive --out runs/style
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from tqdm import tqdm

from drivestyle.agents.studies.figures import plot_lateral, plot_reproductions
from drivestyle.common.cli import positive_float, positive_int, run_cli
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs import load_demonstration
from drivestyle.irl import FEATURE_SETS, FeatureConfig, IRLConfig
from drivestyle.irl.inner import InnerSolveError
from drivestyle.irl.learner import UPDATE_RULES, IterationRecord
from drivestyle.irl.spline import CONTROL_POINT_RULES, demo_control_points
from drivestyle.irl.style import fit_style


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("demos", nargs="+", type=Path, help="demonstration .npz file(s)")
    p.add_argument(
        "--features", default="reactive", choices=sorted(FEATURE_SETS), help="feature set"
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/style"), help="output folder (other files kept)"
    )
    p.add_argument(
        "--method",
        default="lm",
        choices=UPDATE_RULES,
        help="outer update: Levenberg-Marquardt in log theta, or the paper's rule",
    )
    p.add_argument(
        "--control-point-rule",
        "--rule",
        dest="control_point_rule",
        default="kinematic",
        choices=CONTROL_POINT_RULES,
        help="how demo velocities/accelerations are computed (docs/DESIGN.md §4)",
    )
    p.add_argument("--t-rct", type=positive_float, default=2.0, help="reaction window T_rct [s]")
    p.add_argument(
        "--max-iter", type=positive_int, help="outer iterations (default: 60 lm, 400 paper)"
    )
    p.add_argument(
        "--alpha", type=positive_float, default=3e-4, help="learning rate of the paper rule"
    )
    p.add_argument("--plot", action="store_true", help="write reproduction figures")
    return p.parse_args(argv)


class LearningStalledError(RuntimeError):
    """The inner problem failed at every trial θ: the written θ is not a learned style."""


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the script; returns the style payload.

    Raises:
        LearningStalledError: after writing ``style.json``, when learning stalled.
    """
    args = parse_args(argv)
    check_output_dir(args.out, replace=False)  # a style may sit beside its demonstration
    demos = [load_demonstration(p) for p in args.demos]
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
    result, payload = fitted.result, fitted.to_json()
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


if __name__ == "__main__":
    run_cli(main)
