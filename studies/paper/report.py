"""The paper study's report: ``results.md`` and the lines ``reproduce-paper`` prints."""

from __future__ import annotations

from typing import TYPE_CHECKING

from drivestyle.common.io import fmt
from drivestyle.studies.formatting import seconds

if TYPE_CHECKING:
    from drivestyle.studies.paper.study import PaperStudy

__all__ = ["paper_console", "paper_markdown"]


def paper_markdown(study: PaperStudy, command: str) -> str:
    """``results.md``: the paper study beside the paper's numbers.

    Args:
        study: the study's result.
        command: the command that produced it (shown in the report).
    """
    res = study.to_json()
    paper = res["paper"]
    demo = res["demo"]
    lm, paper_rule = res["learning"], res.get("paper_rule", {})
    lines = [
        "# Reproduction of the paper's simulation study",
        "",
        f"Command: `{command}`",
        "",
        f"## Demonstration (p = {demo['risk']:g})",
        "",
        f"t_trg = {seconds(demo['t_trg_s'])} (paper: {seconds(paper['t_trg_s'])}); "
        f"min s_e = {demo['min_s_e']:.2f} at x = {demo['x_at_min_s_e']:.0f} m; min d_k = "
        f"{demo['min_d_k']:.2f}; collision: {demo['collision']}.",
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
            f"| {name} | {s['iterations']} ({paper['iterations'][name]}) | "
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
        lines += [
            "",
            "## Control-point rule (DESIGN §4)",
            "",
            "| rule | share of f_ay in segment 0 | base rmse_y [m] | reactive rmse_y [m] "
            "| reactive rmse_y reaction [m] |",
            "|---|---|---|---|---|",
        ]
        for rule, s in res["control_point_rule"].items():
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


def paper_console(study: PaperStudy) -> str:
    """The lines ``reproduce_paper.py`` prints after the study (t_trg and each style)."""
    res = study.to_json()
    demo, paper = res["demo"], res["paper"]
    lines = [f"  t_trg = {seconds(demo['t_trg_s'])} (paper {seconds(paper['t_trg_s'])})"]
    for name in ("base", "reactive"):
        s = res["learning"][name]
        lines.append(
            f"  {name:8s}: {s['iterations']:3d} iterations, rmse_y {s['rmse_y_m']:.3f} m, "
            f"reaction window {fmt(s['rmse_y_reaction_m'])} m, {s['wall_time_s']:.2f} s"
        )
    return "\n".join(lines)
