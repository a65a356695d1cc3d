"""The paper's simulation study end to end (§IV; the project's main job).

1. The p = 0.7 SMPC demonstration on the paper scenario (Fig. 2).
2. Its style learned with the base (6) and the reactive (10) features.
3. Fig. 3 (reproduced paths over the iterations) and Fig. 4 (lateral motion).
4. Ablations: the paper's own update rule and the control-point rule (DESIGN §4, §6).
5. Optionally, the SB3 baseline trained on the reactive style, compared and rendered.

:func:`paper_study` returns data; :func:`write_paper_study` draws and writes it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.agents.smpc import SMPCConfig
from drivestyle.agents.studies.figures import plot_demonstration, plot_lateral, plot_reproductions
from drivestyle.envs.demonstration import Demonstration, save_demonstration
from drivestyle.irl.features import FeatureConfig, feature_basis, feature_values
from drivestyle.irl.learner import IRLConfig, LearningResult
from drivestyle.irl.spline import demo_control_points
from drivestyle.irl.style import fit_style

from drivestyle.common.io import command_line, fmt, write_json, write_text

__all__ = [
    "PAPER_REPORTED",
    "ay_first_segment_share",
    "baseline_study",
    "paper_study",
    "study_markdown",
    "write_paper_results",
    "write_paper_study",
]

PAPER_REPORTED = {
    "t_trg_s": 3.0,
    "iterations": {"base": 26, "reactive": 37},
    "reaction_window_x_m": [150.0, 220.0],
}
"""The paper's own numbers for its study (§IV)."""

SUMMARY_KEYS = (
    "iterations",
    "converged",
    "learning_error",
    "rmse_y_m",
    "rmse_xy_m",
    "rmse_y_reaction_m",
    "wall_time_s",
    "inner_solve_ms_median",
)


def ay_first_segment_share(demo: Demonstration, control_point_rule: str) -> float:
    """Share of the demonstration's f_ay that its first spline segment carries (DESIGN §4)."""
    C = demo_control_points(demo, control_point_rule)
    full = feature_basis(demo, FeatureConfig())
    cut = feature_basis(demo, FeatureConfig(ay_first_segment_weight=0.0))
    f = feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), full, names=("ay",))[0]
    g = feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), cut, names=("ay",))[0]
    return float((f - g) / f)


def _summary(payload: dict[str, Any]) -> dict[str, Any]:
    return {k: payload[k] for k in SUMMARY_KEYS} | {"theta_normalised": payload["theta_normalised"]}


def paper_study(
    risk: float = 0.7,
    t_rct: float = 2.0,
    seed: int = 0,
    ablations: bool = True,
    progress: Callable[[], None] | None = None,
    demo_path: str | Path | None = None,
) -> dict[str, Any]:
    """Run the paper's study and return its data.

    Args:
        risk: the SMPC's risk p.
        t_rct: reaction window T_rct [s].
        seed: env seed.
        ablations: also learn with the paper's update rule and with the other
            control-point rules.
        progress: called after each step (1 demo + 2 styles + 2 + 1 ablation steps).
        demo_path: where the demonstration will be saved, recorded in the styles.

    Returns:
        ``payload`` (results.json without the command), ``demo``, ``demo_summary``,
        ``results`` (LearningResult per feature set) and ``styles`` (style.json payloads).
    """
    tick = progress or (lambda: None)
    demo, summary = generate_demonstration(risk, "paper", SMPCConfig(risk=risk), seed=seed)
    tick()
    results: dict[str, LearningResult] = {}
    styles: dict[str, dict[str, Any]] = {}
    for name in ("base", "reactive"):
        fc = FeatureConfig(feature_set=name, t_rct=t_rct)
        fitted = fit_style(
            demo, fc, IRLConfig(), demo_paths=[str(demo_path)] if demo_path else None
        )
        results[name], styles[name] = fitted.result, fitted.to_json()
        tick()
    ev = styles["reactive"]
    window = None
    if ev["t_trg_s"] is not None:
        i0 = int(np.argmin(np.abs(demo.t - ev["t_trg_s"])))
        i1 = int(np.argmin(np.abs(demo.t - min(ev["t_trg_s"] + t_rct, demo.t[-1]))))
        window = (float(demo.ev[i0, 0]), float(demo.ev[i1, 0]))
    demo_keys = ("risk", "t_trg_s", "min_s_e", "x_at_min_s_e", "min_d_k", "collision", "final_lane")
    payload: dict[str, Any] = {
        "paper": PAPER_REPORTED,
        "demo": {k: summary[k] for k in demo_keys},
        "learning": {n: _summary(p) for n, p in styles.items()},
        "reaction_window_x_m": window,
        "reactive_closer_in_reaction_window": (
            ev["rmse_y_reaction_m"] is not None
            and ev["rmse_y_reaction_m"] < styles["base"]["rmse_y_reaction_m"]
        ),
        "reactive_closer_overall": ev["rmse_y_m"] < styles["base"]["rmse_y_m"],
    }
    if ablations:
        alpha = IRLConfig().alpha
        payload["paper_rule_alpha"] = alpha
        payload["paper_rule"] = {}
        for name in ("base", "reactive"):
            fc = FeatureConfig(feature_set=name, t_rct=t_rct)
            p = fit_style(demo, fc, IRLConfig(method="paper", max_iter=400, alpha=alpha)).to_json()
            payload["paper_rule"][name] = _summary(p)
            tick()
        payload["control_point_rule"] = {}
        for rule, weight in (
            ("kinematic", 1.0),
            ("paper", 1.0),
            ("kinematic", 0.0),
            ("paper", 0.0),
        ):
            label = rule if weight == 1.0 else f"{rule}, segment 0 excluded from f_ay"
            entry: dict[str, Any] = {
                "ay_first_segment_share": ay_first_segment_share(demo, rule)
                if weight == 1.0
                else 0.0
            }
            for name in ("base", "reactive"):
                if rule == "kinematic" and weight == 1.0:
                    entry[name] = payload["learning"][name]
                    continue
                fc = FeatureConfig(feature_set=name, t_rct=t_rct, ay_first_segment_weight=weight)
                p = fit_style(demo, fc, IRLConfig(), control_point_rule=rule).to_json()
                entry[name] = _summary(p)
            payload["control_point_rule"][label] = entry
        tick()
    return {
        "payload": payload,
        "demo": demo,
        "demo_summary": summary,
        "results": results,
        "styles": styles,
    }


def write_paper_study(study: dict[str, Any], out: str | Path, argv: list[str]) -> None:
    """Write a :func:`paper_study`'s artefacts into ``out``: demo/, base/, reactive/, figures.

    The results themselves are written by :func:`write_paper_results`.
    """
    out = Path(out)
    demo, payload = study["demo"], study["payload"]
    save_demonstration(demo, out / "demo" / "demo.npz")
    write_json(out / "demo" / "demo.json", study["demo_summary"], argv)
    plot_demonstration(
        demo,
        out / "demo" / "demo.png",
        title=f"SMPC demonstration, p = {payload['demo']['risk']:g} (Fig. 2)",
    )
    for name, style in study["styles"].items():
        write_json(out / name / "style.json", style, argv)
    C = demo_control_points(demo)
    plot_reproductions(
        demo, study["results"], C, out / "fig3_reproductions.png", payload["reaction_window_x_m"]
    )
    plot_lateral(
        demo,
        study["results"]["reactive"],
        C,
        out / "fig4_lateral.png",
        title="lateral motion with the reactive features (Fig. 4)",
    )


def write_paper_results(payload: dict[str, Any], out: str | Path, argv: list[str]) -> None:
    """``out/results.json`` and ``out/results.md`` of a :func:`paper_study`."""
    out = Path(out)
    write_json(out / "results.json", payload, argv)
    write_text(out / "results.md", study_markdown(payload | {"command": command_line(argv)}))


def study_markdown(res: dict[str, Any]) -> str:
    """``results.md``: the study beside the paper's numbers.

    Args:
        res: the payload of :func:`paper_study` (as written to JSON, with ``command``).
    """
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
            f"| {name} | {s['iterations']} ({PAPER_REPORTED['iterations'][name]}) | "
            f"{s['converged']} | "
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
    return "\n".join(lines)


def baseline_study(
    style_path: str | Path,
    demo: Demonstration,
    smpc_solve_s: float,
    out: str | Path,
    algo: str = "ppo",
    timesteps: int = 60_000,
    seed: int = 0,
    argv: list[str] | None = None,
) -> dict[str, Any]:
    """Train the SB3 baseline on a style, compare it with the spline and the SMPC, render videos.

    Needs the ``rl`` and ``video`` extras. Writes ``out/baseline/``, ``out/compare/`` and
    ``out/videos/``.

    Returns:
        ``train`` (training summary), ``compare`` (per-method measures), ``videos`` (paths).
    """
    from drivestyle.agents.sb3_baseline import TrainConfig, train_baseline
    from drivestyle.agents.studies.compare import (
        compare_methods,
        comparison_markdown,
        plot_comparison,
        policy_frames,
    )
    from drivestyle.envs.video import write_video
    from drivestyle.irl.style import load_style

    out = Path(out)
    style = load_style(style_path)
    train = train_baseline(
        style, out / "baseline", TrainConfig(algo=algo, timesteps=timesteps, seed=seed)
    )
    res = compare_methods(style, demo, smpc_solve_s, out / "baseline")
    plot_comparison(
        demo,
        res["trajectories"],
        out / "compare" / "compare.png",
        "driving the learned reactive style",
    )
    write_json(out / "compare" / "compare.json", {"methods": res["methods"]}, argv)
    write_text(
        out / "compare" / "compare.md", comparison_markdown(res["methods"], command_line(argv))
    )
    risk = demo.meta.get("risk", 0.7)
    videos = {}
    for kind in ("expert", "spline", "sb3"):
        frames = policy_frames(kind, demo.scenario, risk, style, demo, out / "baseline", seed)
        videos[kind] = str(write_video(frames, out / "videos" / f"{kind}.mp4"))
    videos["expert_gif"] = str(
        write_video(policy_frames("expert", demo.scenario, risk), out / "videos" / "expert.gif")
    )
    return {"train": train, "compare": res["methods"], "videos": videos}
