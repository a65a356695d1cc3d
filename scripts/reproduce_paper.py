"""Reproduce the paper's simulation study end to end (the project's main job).

1. Generate the p = 0.7 SMPC demonstration on the paper scenario (Fig. 2).
2. Learn its style with the base (6) and the reactive (10) features.
3. Draw Fig. 3 (reproduced paths at iterations 1, 11, 21 and the last; base on top,
   reactive below) and Fig. 4 (lateral velocity and acceleration, reactive).
4. Write ``results.json`` and ``results.md`` beside the paper's numbers, including the
   paper's own update rule and the effect of the control-point rule (DESIGN §4).

Example:
    python scripts/reproduce_paper.py --out runs/paper
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from agents import SMPCConfig, generate_demonstration
from envs import save_demonstration
from envs.io import fmt, write_json
from envs.plotting import plot_demonstration
from irl import FeatureConfig, IRLConfig
from irl.features import feature_basis, feature_values
from irl.plotting import plot_lateral, plot_reproductions
from irl.spline import demo_control_points
from irl.style import fit_style

PAPER = {
    "t_trg_s": 3.0,
    "iterations": {"base": 26, "reactive": 37},
    "reaction_window_x_m": [150.0, 220.0],
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--out", type=Path, default=Path("runs/paper"))
    p.add_argument("--risk", type=float, default=0.7)
    p.add_argument("--t-rct", type=float, default=2.0, help="reaction window T_rct [s]")
    p.add_argument(
        "--with-baseline",
        action="store_true",
        help="also train an SB3 policy on the reactive style, compare it with the spline "
        "reproduction and the SMPC demo, and render videos (needs the rl and video extras)",
    )
    p.add_argument("--baseline-algo", default="ppo", choices=("ppo", "sac"))
    p.add_argument(
        "--baseline-timesteps",
        type=int,
        default=60_000,
        help="SB3 budget (60 000 PPO steps take about 4 min on 2 cores)",
    )
    p.add_argument(
        "--skip-ablations",
        action="store_true",
        help="skip the paper-rule and control-point-rule comparisons",
    )
    p.add_argument("--seed", type=int, default=0)
    return p.parse_args(argv)


def _ay_first_segment_share(demo, rule: str) -> float:
    C = demo_control_points(demo, rule)
    full = feature_basis(demo, FeatureConfig())
    cut = feature_basis(demo, FeatureConfig(ay_first_segment_weight=0.0))
    f = feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), full, names=("ay",))[0]
    g = feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), cut, names=("ay",))[0]
    return float((f - g) / f)


def _summary(payload: dict) -> dict:
    keys = (
        "iterations",
        "converged",
        "learning_error",
        "rmse_y_m",
        "rmse_xy_m",
        "rmse_y_reaction_m",
        "wall_time_s",
        "inner_solve_ms_median",
    )
    return {k: payload[k] for k in keys} | {"theta_normalised": payload["theta_normalised"]}


def write_markdown(path: Path, res: dict) -> None:
    """results.md: the comparison table."""
    lm, paper_rule = res["learning"], res.get("paper_rule", {})
    lines = [
        "# Reproduction of the paper's simulation study",
        "",
        f"Command: `{res['command']}`",
        "",
        "## Demonstration (p = 0.7)",
        "",
        f"t_trg = {fmt(res['demo']['t_trg_s'], 1)} s (paper: 3.0 s); min s_e = "
        f"{res['demo']['min_s_e']:.2f} at x = {res['demo']['x_at_min_s_e']:.0f} m; min d_k = "
        f"{res['demo']['min_d_k']:.2f}; collision: {res['demo']['collision']}.",
        "",
        "## Learning (default: Levenberg–Marquardt in log θ)",
        "",
        "| features | iterations (paper) | converged | learning error | rmse_y [m] | "
        "rmse_y reaction window [m] | rmse_xy [m] | wall time [s] | inner solve median [ms] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name in ("base", "reactive"):
        s = lm[name]
        lines.append(
            f"| {name} | {s['iterations']} ({PAPER['iterations'][name]}) | {s['converged']} | "
            f"{s['learning_error']:.3f} | {s['rmse_y_m']:.3f} | {fmt(s['rmse_y_reaction_m'])} | "
            f"{s['rmse_xy_m']:.3f} | {s['wall_time_s']:.2f} | {s['inner_solve_ms_median']:.2f} |"
        )
    if paper_rule:
        lines += [
            "",
            f"## The paper's update rule (α = {res['paper_rule_alpha']:g}, "
            "ε̄ = 0.01, at most 400 iterations)",
            "",
            "| features | iterations | converged | learning error | rmse_y [m] | "
            "rmse_y reaction [m] | wall time [s] |",
            "|---|---|---|---|---|---|---|",
        ]
        for name in ("base", "reactive"):
            s = paper_rule[name]
            lines.append(
                f"| {name} | {s['iterations']} | {s['converged']} | "
                f"{s['learning_error']:.3f} | {s['rmse_y_m']:.3f} | "
                f"{fmt(s['rmse_y_reaction_m'])} | {s['wall_time_s']:.2f} |"
            )
    if "control_point_rule" in res:
        cp = res["control_point_rule"]
        lines += [
            "",
            "## Control-point rule (DESIGN §4)",
            "",
            "| rule | share of f_ay in segment 0 | base rmse_y [m] | reactive rmse_y [m] "
            "| reactive rmse_y reaction [m] |",
            "|---|---|---|---|---|",
        ]
        for rule, s in cp.items():
            lines.append(
                f"| {rule} | {s['ay_first_segment_share']:.0%} | "
                f"{s['base']['rmse_y_m']:.3f} | {s['reactive']['rmse_y_m']:.3f} | "
                f"{fmt(s['reactive']['rmse_y_reaction_m'])} |"
            )
    lines += [
        "",
        "Figures: `demo/demo.png` (Fig. 2), `fig3_reproductions.png` (Fig. 3), "
        "`fig4_lateral.png` (Fig. 4).",
        "",
    ]
    path.write_text("\n".join(lines))


def run_baseline(
    args: argparse.Namespace, demo, smpc_solve_s: float, out: Path, argv_full: list[str]
) -> dict:
    """Train the SB3 baseline, compare it, render videos (the ``--with-baseline`` step)."""
    import json

    try:
        from agents.compare import (
            compare_methods,
            comparison_markdown,
            plot_comparison,
            policy_frames,
        )
        from agents.sb3_baseline import TrainConfig, train_baseline
    except ImportError as exc:
        sys.exit(
            f"error: {exc}; --with-baseline needs: pip install -c constraints-cpu.txt "
            "-e '.[rl,video]'"
        )
    from envs.video import write_video
    from irl.style import load_style

    style = load_style(out / "reactive" / "style.json")
    train = train_baseline(
        style,
        out / "baseline",
        TrainConfig(algo=args.baseline_algo, timesteps=args.baseline_timesteps, seed=args.seed),
    )
    res = compare_methods(style, demo, smpc_solve_s, out / "baseline")
    plot_comparison(
        demo,
        res["trajectories"],
        out / "compare" / "compare.png",
        title="driving the learned reactive style",
    )
    path = write_json(out / "compare" / "compare.json", {"methods": res["methods"]}, argv_full)
    (out / "compare" / "compare.md").write_text(
        comparison_markdown(res["methods"], json.loads(path.read_text())["command"])
    )
    videos = {}
    for kind in ("expert", "spline", "sb3"):
        frames = policy_frames(
            kind, demo.scenario, args.risk, style, demo, out / "baseline", args.seed
        )
        videos[kind] = str(write_video(frames, out / "videos" / f"{kind}.mp4"))
    videos["expert_gif"] = str(
        write_video(
            policy_frames("expert", demo.scenario, args.risk), out / "videos" / "expert.gif"
        )
    )
    return {"train": train, "compare": res["methods"], "videos": videos}


def main(argv: list[str] | None = None) -> dict:
    """Run the study; returns the results payload."""
    args = parse_args(argv)
    argv_full = [sys.argv[0], *(argv or sys.argv[1:])]
    t_start = time.perf_counter()
    out = args.out
    steps = tqdm(total=4 if args.skip_ablations else 8, desc="reproduce_paper")
    try:
        demo, summary = generate_demonstration(
            args.risk, "paper", SMPCConfig(risk=args.risk), seed=args.seed
        )
    except ValueError as exc:
        sys.exit(f"error: {exc}")
    save_demonstration(demo, out / "demo" / "demo.npz")
    write_json(out / "demo" / "demo.json", summary, argv_full)
    plot_demonstration(
        demo, out / "demo" / "demo.png", title=f"SMPC demonstration, p = {args.risk:g} (Fig. 2)"
    )
    steps.update(1)

    results, payloads = {}, {}
    for name in ("base", "reactive"):
        fc = FeatureConfig(feature_set=name, t_rct=args.t_rct)
        res, _, payload = fit_style(
            demo, fc, IRLConfig(), demo_paths=[str(out / "demo" / "demo.npz")]
        )
        write_json(out / name / "style.json", payload, argv_full)
        results[name], payloads[name] = res, payload
        steps.update(1)
    C = demo_control_points(demo)
    ev = payloads["reactive"]
    window = None
    if ev["t_trg_s"] is not None:
        i0 = int(np.argmin(np.abs(demo.t - ev["t_trg_s"])))
        i1 = int(np.argmin(np.abs(demo.t - min(ev["t_trg_s"] + args.t_rct, demo.t[-1]))))
        window = (float(demo.ev[i0, 0]), float(demo.ev[i1, 0]))
    plot_reproductions(demo, results, C, out / "fig3_reproductions.png", window)
    plot_lateral(
        demo,
        results["reactive"],
        C,
        out / "fig4_lateral.png",
        title="lateral motion with the reactive features (Fig. 4)",
    )
    steps.update(1)

    payload = {
        "paper": PAPER,
        "demo": {
            k: summary[k]
            for k in (
                "risk",
                "t_trg_s",
                "min_s_e",
                "x_at_min_s_e",
                "min_d_k",
                "collision",
                "final_lane",
            )
        },
        "learning": {n: _summary(p) for n, p in payloads.items()},
        "reaction_window_x_m": window,
        "reactive_closer_in_reaction_window": (
            ev["rmse_y_reaction_m"] is not None
            and ev["rmse_y_reaction_m"] < payloads["base"]["rmse_y_reaction_m"]
        ),
        "reactive_closer_overall": ev["rmse_y_m"] < payloads["base"]["rmse_y_m"],
    }
    if not args.skip_ablations:
        alpha = IRLConfig().alpha
        payload["paper_rule_alpha"] = alpha
        payload["paper_rule"] = {}
        for name in ("base", "reactive"):
            fc = FeatureConfig(feature_set=name, t_rct=args.t_rct)
            _, _, p = fit_style(demo, fc, IRLConfig(method="paper", max_iter=400, alpha=alpha))
            payload["paper_rule"][name] = _summary(p)
            steps.update(1)
        payload["control_point_rule"] = {}
        for rule, weight in (
            ("kinematic", 1.0),
            ("paper", 1.0),
            ("kinematic", 0.0),
            ("paper", 0.0),
        ):
            label = rule if weight == 1.0 else f"{rule}, segment 0 excluded from f_ay"
            entry = {
                "ay_first_segment_share": _ay_first_segment_share(demo, rule)
                if weight == 1.0
                else 0.0
            }
            for name in ("base", "reactive"):
                if rule == "kinematic" and weight == 1.0:
                    entry[name] = payload["learning"][name]
                    continue
                fc = FeatureConfig(
                    feature_set=name, t_rct=args.t_rct, ay_first_segment_weight=weight
                )
                _, _, p = fit_style(demo, fc, IRLConfig(), control_point_rule=rule)
                entry[name] = _summary(p)
            payload["control_point_rule"][label] = entry
        steps.update(1)
    steps.close()
    if args.with_baseline:
        payload["baseline"] = run_baseline(
            args, demo, summary["solve_ms_total"] / 1e3, out, argv_full
        )
    payload["wall_time_total_s"] = time.perf_counter() - t_start
    path = write_json(out / "results.json", payload, argv_full)
    import json

    write_markdown(out / "results.md", json.loads(path.read_text()))
    lm = payload["learning"]
    print(
        f"wrote {out}/results.json, results.md and figures ({payload['wall_time_total_s']:.1f} s)"
    )
    print(f"  t_trg = {summary['t_trg_s']} s (paper 3.0 s)")
    for name in ("base", "reactive"):
        s = lm[name]
        print(
            f"  {name:8s}: {s['iterations']:3d} iterations, rmse_y {s['rmse_y_m']:.3f} m, "
            f"reaction window {fmt(s['rmse_y_reaction_m'])} m, {s['wall_time_s']:.2f} s"
        )
    return payload


if __name__ == "__main__":
    main()
