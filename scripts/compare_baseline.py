r"""Compare the SMPC demonstration, the spline reproduction r*_θ and an SB3 policy.

For each: the learned cost θᵀf, the feature error vs the demonstration, rmse_y and
rmse_xy vs the demonstration, minimum d_k, collision, and compute time (SMPC solve time of
the closed loop, inner-problem time for the spline, training time for SB3). Writes
``OUT/compare.json``, ``OUT/compare.md`` and ``OUT/compare.png`` (paths and lateral
velocity).

With ``--heldout K`` the comparison runs on K held-out random scenarios against SMPC(p):
``--style`` may then be a driver-style file (the default model, ``learn_style.py``),
reported as ``style`` (its closed-loop reproduction), with ``--spline-style`` a
paper-model style for the ``spline`` entry; a paper-model ``--style`` keeps feeding
``spline`` as before.

Example:
    python scripts/compare_baseline.py --style runs/paper/reactive/style.json \\
        --model runs/baseline --out runs/compare
    python scripts/compare_baseline.py --style runs/driver_p06 --model runs/ppo_p06 \\
        --heldout 6 --risk 0.6 --seed 500 --out runs/heldout_p06
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from drivestyle.agents import SMPCConfig, generate_demonstration
from drivestyle.common.cli import HelpFormatter, count, risk_value, run_cli, seed
from drivestyle.common.io import (
    atomic_output_dir,
    check_output_dir,
    command_line,
    fmt,
    write_json,
    write_text,
)
from drivestyle.envs import load_demonstration
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.paper.style import Style, StyleError, load_style
from drivestyle.studies.compare import (
    LABELS,
    compare_methods,
    comparison_markdown,
    heldout_comparison,
)
from drivestyle.studies.compare.figures import plot_comparison, plot_heldout


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--style",
        type=Path,
        required=True,
        help="style.json (or its folder): a paper-model style, or (--heldout) a driver style",
    )
    p.add_argument(
        "--spline-style",
        type=Path,
        help="a paper-model style.json for the spline entry (--heldout with a driver --style)",
    )
    p.add_argument("--model", type=Path, help="train_baseline.py output folder (optional)")
    p.add_argument("--demo", type=Path, help="demonstration (default: the style's own)")
    p.add_argument(
        "--out", type=Path, default=Path("runs/compare"), help="output folder (replaced whole)"
    )
    p.add_argument(
        "--heldout",
        type=count(10_000, 10.0, "held-out scenarios"),
        metavar="K",
        help="instead: compare on K held-out random scenarios (heldout.json, heldout.png)",
    )
    p.add_argument(
        "--sac-model", type=Path, help="a second (SAC) train_baseline.py folder (--heldout)"
    )
    p.add_argument(
        "--risk", type=risk_value, default=0.7, help="the demonstrator's risk p (--heldout)"
    )
    p.add_argument(
        "--seed", type=seed, default=0, help="seed of the held-out scenarios (--heldout)"
    )
    return p.parse_args(argv)


def _styles(args: argparse.Namespace) -> tuple[Style | None, DriverStyle | None]:
    """(paper-model style, driver style) of ``--style`` and ``--spline-style``."""
    from drivestyle.agents.sb3_baseline import load_reward_style

    first = load_reward_style(args.style)
    driver = first if isinstance(first, DriverStyle) else None
    paper = first if isinstance(first, Style) else None
    if args.spline_style is not None:
        if paper is not None:
            raise StyleError("--spline-style needs a driver-style --style (both are paper styles)")
        second = load_reward_style(args.spline_style)
        if not isinstance(second, Style):
            raise StyleError(f"--spline-style {args.spline_style} is not a paper-model style")
        paper = second
    return paper, driver


def heldout(args: argparse.Namespace, argv_full: list[str]) -> dict:
    """The ``--heldout`` mode."""
    style, driver = _styles(args)
    models = {}
    for name, folder in (("sb3", args.model), ("sac", args.sac_model)):
        if folder is not None:
            models[name] = folder
    with tqdm(total=args.heldout, desc="held-out scenarios") as bar:
        res = heldout_comparison(
            style, models, args.heldout, args.seed, args.risk, bar.update, driver=driver
        )
    payload = {"style": str(args.style), "seed": args.seed, "risk": args.risk}
    if args.spline_style is not None:
        payload["spline_style"] = str(args.spline_style)
    if driver is not None:
        payload["driver_style"] = driver.to_json()
    payload |= res.to_json()
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "heldout.json", payload, argv_full)
        plot_heldout(res, tmp / "heldout.png")
    for name, m in res.summary.items():
        print(
            f"{name:7s} median rmse_y {fmt(m.median_rmse_y_m)} m, rmse_xy "
            f"{fmt(m.median_rmse_xy_m)} m, collisions {m.collisions}/{m.n}, min d_k "
            f"{m.min_d_k:.2f} (enters the ellipse where SMPC does not: {m.enters_ellipse}), "
            f"median cost {fmt(m.median_cost)}, decision {fmt(m.decision_ms, 3)} ms"
        )
    return payload


def main(argv: list[str] | None = None) -> dict:
    """Run the comparison; returns the compare.json payload."""
    args = parse_args(argv)
    argv_full = [sys.argv[0], *(argv or sys.argv[1:])]
    inputs = [args.style, args.spline_style, args.model, args.sac_model, args.demo]
    check_output_dir(args.out, inputs=inputs)
    if args.heldout:
        return heldout(args, argv_full)
    paper_path = args.spline_style or args.style
    style = load_style(paper_path)
    demo_path = args.demo or style.demo_path(paper_path)
    demo = load_demonstration(demo_path)
    smpc_s = None
    risk = demo.meta.get("risk")
    if risk is not None:  # re-run the SMPC closed loop to time it
        rerun, summary = generate_demonstration(risk, demo.scenario, SMPCConfig(risk=risk))
        if rerun.n == demo.n and abs(rerun.ev - demo.ev).max() < 1e-6:
            smpc_s = summary["solve_ms_total"] / 1e3
    res = compare_methods(style, demo, smpc_s, args.model)
    payload = {"style": str(paper_path), "demo": str(demo_path), **res.to_json()}
    with atomic_output_dir(args.out) as tmp:
        plot_comparison(
            demo,
            res.trajectories,
            tmp / "compare.png",
            title=f"driving the learned style ({', '.join(style.names[:3])}, …)",
        )
        write_json(tmp / "compare.json", payload, argv_full)
        write_text(tmp / "compare.md", comparison_markdown(res, command_line(argv_full)))
    for name, m in res.methods.items():
        print(
            f"{LABELS.get(name, name):28s} cost {fmt(m['learned_cost']):>8s}  rmse_y "
            f"{fmt(m['rmse_y_m']):>6s} m  min d_k {m['min_d_k']:.2f}  collision "
            f"{m['collision']}  {m['compute']}: {fmt(m['compute_time_s'], 2)} s"
        )
    return payload


if __name__ == "__main__":
    run_cli(main)
