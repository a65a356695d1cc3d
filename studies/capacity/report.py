"""The capacity study's report: ``capacity.md``."""

from __future__ import annotations

from typing import TYPE_CHECKING

from drivestyle.common.io import fmt
from drivestyle.studies.formatting import seconds

if TYPE_CHECKING:
    from drivestyle.studies.capacity.study import CapacityStudy

__all__ = ["capacity_markdown"]


def capacity_markdown(study: CapacityStudy, command: str) -> str:
    """``capacity.md``: per driver and reproduction class, median rmse_y and rmse_xy.

    Args:
        study: the capacity study.
        command: the command that produced it.
    """
    n_train, n_test = len(study.train_scenarios), len(study.test_scenarios)
    lines = [
        "# Capacity of the reproduction classes",
        "",
        f"Command: `{command}`",
        "",
        f"One driver SMPC(p) per row group; {n_train} training scenarios (seed "
        f"{study.train_seed}), {n_test} held-out (seed {study.test_seed}); medians over "
        f"demonstrations [m]; Nelder–Mead budget {study.budget} evaluations. Objective: mean "
        "of sqrt(rmse_y² + (rmse_x/2)²) over the training demonstrations.",
        "",
        "| p | reproduction class | train rmse_y | train rmse_xy | test rmse_y | "
        "test rmse_xy | objective | test min d_k | evals | fit time |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in study.rows:
        for c in row.classes:
            m = c.medians()
            min_d = min(c.test_min_d) if c.test_min_d else None
            lines.append(
                f"| {row.risk:g} | {c.label} | {fmt(m['train_rmse_y_m'], 2)} | "
                f"{fmt(m['train_rmse_xy_m'], 2)} | {fmt(m['test_rmse_y_m'], 2)} | "
                f"{fmt(m['test_rmse_xy_m'], 2)} | {fmt(c.objective, 2)} | {fmt(min_d, 2)} | "
                f"{c.evaluations or '—'} | {seconds(c.seconds)} |"
            )
    lines += ["", "| p | driver's own min d_k (held out) | wall time |", "|---|---|---|"]
    for row in study.rows:
        lines.append(
            f"| {row.risk:g} | {fmt(min(row.driver_min_d_test), 2)} | {seconds(row.seconds)} |"
        )
    lines += ["", f"Total wall time {seconds(study.seconds)}.", ""]
    return "\n".join(lines)
