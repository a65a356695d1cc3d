"""The cut-in study's report: ``planning.md`` (docs/RESULTS.md quotes it)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from drivestyle.common.io import fmt
from drivestyle.studies.cut_in.study import HARD_BRAKING

if TYPE_CHECKING:
    from drivestyle.studies.cut_in.study import PlanningStudy

__all__ = ["planning_markdown"]


def planning_markdown(study: PlanningStudy) -> str:
    """The cut-in study's table (``planning.md``; docs/RESULTS.md quotes it)."""
    lines = [
        f"Cut-in scenes: {len(study.seeds)} (seeds {study.seeds[0]}–{study.seeds[-1]}); "
        "the ego's prediction of the lane changer:",
        "",
        "| predictor | collisions | least distance [m] mean (min) | least margin s_e−1 mean | "
        f"time in ellipse [s] | hardest braking [m/s²] mean (p90) | scenes > {HARD_BRAKING:g} "
        "m/s² | braking > 3 m/s² [s] | max jerk [m/s³] | progress [m] | step [ms] |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for s in study.summaries:
        lines.append(
            f"| {s.method} | {s.collisions} | {fmt(s.min_distance_m_mean, 1)} "
            f"({fmt(s.min_distance_m_min, 1)}) | {fmt(s.min_d_mean, 2)} | "
            f"{fmt(s.time_in_ellipse_s_mean, 2)} | {fmt(s.hardest_braking_mean, 2)} "
            f"({fmt(s.hardest_braking_p90, 1)}) | {s.scenes_with_hard_braking} | "
            f"{fmt(s.hard_braking_s_mean, 2)} | {fmt(s.max_jerk_mean, 1)} | "
            f"{fmt(s.progress_m_mean, 1)} | {fmt(s.plan_ms_median, 1)} |"
        )
    lines += ["", "Goals (style-aware ego): " + ", ".join(
        f"{k} {'met' if v else 'MISSED'}" for k, v in study.goals.items()), ""]  # fmt: skip
    return "\n".join(lines)
