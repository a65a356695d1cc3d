r"""Compare the SMPC demonstration, the spline reproduction r*_θ and an SB3 policy.

For each: the learned cost θᵀf, the feature error vs the demonstration, rmse_y and
rmse_xy vs the demonstration, minimum d_k, collision, and compute time (SMPC solve time of
the closed loop, inner-problem time for the spline, training time for SB3). Writes
``OUT/compare.json``, ``OUT/compare.md`` and ``OUT/compare.png`` (paths and lateral
velocity).

Example:
    python scripts/compare_baseline.py --style runs/paper/reactive/style.json \\
        --model runs/baseline --out runs/compare
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from agents import SMPCConfig, generate_demonstration
from agents.compare import LABELS, compare_methods, comparison_markdown, plot_comparison
from envs import load_demonstration
from envs.demonstration import DemonstrationError
from envs.io import fmt, write_json
from irl.style import StyleError, load_style


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--style", type=Path, required=True, help="style.json (or its folder)")
    p.add_argument("--model", type=Path, help="train_baseline.py output folder (optional)")
    p.add_argument("--demo", type=Path, help="demonstration (default: the style's own)")
    p.add_argument("--out", type=Path, default=Path("runs/compare"))
    p.add_argument("--seed", type=int, default=0)
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Run the comparison; returns the compare.json payload."""
    args = parse_args(argv)
    argv_full = [sys.argv[0], *(argv or sys.argv[1:])]
    try:
        style = load_style(args.style)
        demo_path = args.demo or Path(style.raw["demos"][0]["path"])
        demo = load_demonstration(demo_path)
    except (FileNotFoundError, StyleError, DemonstrationError, KeyError, TypeError) as exc:
        sys.exit(f"error: {exc}")
    smpc_s = None
    risk = demo.meta.get("risk")
    if risk is not None:  # re-run the SMPC closed loop to time it
        rerun, summary = generate_demonstration(risk, demo.scenario, SMPCConfig(risk=risk))
        if rerun.n == demo.n and abs(rerun.ev - demo.ev).max() < 1e-6:
            smpc_s = summary["solve_ms_total"] / 1e3
    try:
        res = compare_methods(style, demo, smpc_s, args.model)
    except FileNotFoundError as exc:
        sys.exit(f"error: {exc}")
    plot_comparison(
        demo,
        res["trajectories"],
        args.out / "compare.png",
        title=f"driving the learned style ({', '.join(style.names[:3])}, …)",
    )
    payload = {"style": str(args.style), "demo": str(demo_path), "methods": res["methods"]}
    path = write_json(args.out / "compare.json", payload, argv_full)
    import json

    command = json.loads(path.read_text())["command"]
    (args.out / "compare.md").write_text(comparison_markdown(res["methods"], command))
    for name, m in res["methods"].items():
        print(
            f"{LABELS.get(name, name):28s} cost {fmt(m['learned_cost']):>8s}  rmse_y "
            f"{fmt(m['rmse_y_m']):>6s} m  min d_k {m['min_d_k']:.2f}  collision "
            f"{m['collision']}  {m['compute']}: {fmt(m['compute_time_s'], 2)} s"
        )
    return payload


if __name__ == "__main__":
    main()
