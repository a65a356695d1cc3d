"""The comparison study's report: ``compare.md``."""

from __future__ import annotations

from typing import TYPE_CHECKING

from drivestyle.common.io import fmt
from drivestyle.studies.compare.study import LABELS

if TYPE_CHECKING:
    from drivestyle.studies.compare.study import Comparison

__all__ = ["comparison_markdown"]


def comparison_markdown(comparison: Comparison, command: str) -> str:
    """``compare.md``: one row per method of a :class:`~.compare.Comparison`.

    Args:
        comparison: the comparison.
        command: the command that produced it.
    """
    lines = [
        "# SMPC vs spline reproduction vs SB3 on the learned reward",
        "",
        f"Command: `{command}`",
        "",
        "| method | learned cost θᵀf | feature error | rmse_y [m] | rmse_xy [m] | "
        "rmse_y reaction [m] | min d_k | collision | compute | time [s] |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, m in comparison.methods.items():
        lines.append(
            f"| {LABELS.get(name, name)} | {fmt(m['learned_cost'])} | "
            f"{fmt(m['feature_error'])} | {fmt(m['rmse_y_m'])} | {fmt(m['rmse_xy_m'])} | "
            f"{fmt(m['rmse_y_reaction_m'])} | {m['min_d_k']:.3f} | {m['collision']} | "
            f"{m['compute']} | {fmt(m['compute_time_s'], 2)} |"
        )
    lines += ["", "Figure: `compare.png`.", ""]
    return "\n".join(lines)
