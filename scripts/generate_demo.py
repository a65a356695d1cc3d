"""Generate an SMPC demonstration in the lane-change env (DESIGN §7).

Writes ``OUT/demo.npz`` (arrays t, ev, tv, u, meta) and ``OUT/demo.json`` (risk, t_trg_s,
min_s_e, min_d_k, collision, solver timing, …); with ``--plot`` also ``OUT/demo.png``, the
equivalent of the paper's Fig. 2.

Example:
    python scripts/generate_demo.py --risk 0.7 --scenario paper --out runs/demo --plot
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from drivestyle.agents import SMPCConfig, generate_demonstration
from drivestyle.agents.demo_generation import TRAFFIC_VEHICLES, generate_traffic_demonstration
from drivestyle.common.cli import (
    HelpFormatter,
    finite_float,
    nonnegative_int,
    positive_float,
    risk_value,
    run_cli,
    seed,
)
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs import SCENARIOS, get_scenario, save_demonstration
from drivestyle.envs.traffic import DEFAULT_TRAFFIC
from drivestyle.studies.formatting import seconds
from drivestyle.studies.plotting import plot_demonstration

TRAFFIC_CHOICES = ("traffic", "traffic-random")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--risk", type=risk_value, default=0.7, help="risk parameter p in (0, 1)")
    p.add_argument(
        "--scenario",
        default="paper",
        choices=[*sorted(SCENARIOS), *TRAFFIC_CHOICES],
        help="named base scenario; 'traffic': the default traffic scene, 'traffic-random': "
        "a scene drawn with --seed",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/demo"), help="output folder (replaced whole)"
    )
    p.add_argument(
        "--ev-speed", type=positive_float, help="EV initial speed [m/s] (default: the scenario's)"
    )
    p.add_argument("--tv-speed", type=positive_float, help="TV speed [m/s] (default: scenario's)")
    p.add_argument(
        "--tv-gap", type=finite_float, help="initial gap x_TV - x_EV [m] (default: scenario's)"
    )
    p.add_argument(
        "--tv-lane", type=nonnegative_int, help="TV lane index, 0 = right (default: scenario's)"
    )
    p.add_argument(
        "--horizon-s", type=positive_float, help="episode length [s] (default: scenario's)"
    )
    p.add_argument(
        "--solver", default="fatrop", choices=("fatrop", "ipopt"), help="NLP solver of the SMPC"
    )
    p.add_argument(
        "--jit", action="store_true", help="compile the NLP with gcc (faster solves, ~5 s compile)"
    )
    p.add_argument("--plot", action="store_true", help="write demo.png (paper Fig. 2)")
    p.add_argument("--seed", type=seed, default=0, help="env seed")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Run the script; returns the summary written to demo.json."""
    args = parse_args(argv)
    check_output_dir(args.out)
    overrides = {
        k: v
        for k, v in {
            "ev_speed": args.ev_speed,
            "tv_speed": args.tv_speed,
            "tv_gap": args.tv_gap,
            "tv_lane": args.tv_lane,
            "horizon_s": args.horizon_s,
        }.items()
        if v is not None
    }
    if args.scenario in TRAFFIC_CHOICES:
        smpc = SMPCConfig(
            risk=args.risk, solver=args.solver, jit=args.jit, max_vehicles=TRAFFIC_VEHICLES
        )
        scene = DEFAULT_TRAFFIC
        if overrides:
            scene = dataclasses.replace(scene, base=scene.base.with_overrides(**overrides))
        demo, summary = generate_traffic_demonstration(
            args.risk, scene, smpc, args.seed, args.scenario == "traffic-random", progress=True
        )
        scenario = demo.scenario
        summary["scene"] = demo.meta["scene"]
    else:
        scenario = get_scenario(args.scenario).with_overrides(**overrides)
        smpc = SMPCConfig(risk=args.risk, solver=args.solver, jit=args.jit)
        demo, summary = generate_demonstration(
            args.risk, scenario, smpc, seed=args.seed, progress=True
        )
    summary["scenario"] = scenario.to_dict()
    summary["seed"] = args.seed
    # replaced whole: a demo.png (or a style) of an earlier run must not sit beside this demo
    with atomic_output_dir(args.out) as tmp:
        save_demonstration(demo, tmp / "demo.npz")
        write_json(tmp / "demo.json", summary, [sys.argv[0], *(argv or sys.argv[1:])])
        if args.plot:
            plot_demonstration(
                demo, tmp / "demo.png", title=f"SMPC demonstration, p = {args.risk:g}"
            )
    trg = summary["t_trg_s"]
    print(f"wrote {args.out / 'demo.npz'} and demo.json" + (" and demo.png" if args.plot else ""))
    print(
        f"  t_trg = {seconds(trg)}, min s_e = "
        f"{summary['min_s_e']:.3f} at x = {summary['x_at_min_s_e']:.1f} m, min d_k = "
        f"{summary['min_d_k']:.3f}, collision = {summary['collision']}, final lane = "
        f"{summary['final_lane']}"
    )
    print(
        f"  SMPC ({summary['solver']}): median {summary['solve_ms_median']:.2f} ms, "
        f"p95 {summary['solve_ms_p95']:.2f} ms, failures {summary['n_solver_failures']}"
    )
    if trg is None:
        print("  note: s_e never drops below lambda: the reactive features will be inactive")
    return summary


if __name__ == "__main__":
    run_cli(main)
