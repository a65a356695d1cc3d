"""The identification study's report: ``evaluation.md`` and its parts.

Each function takes the study's typed results and returns the Markdown text or its lines.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from drivestyle.common.io import fmt
from drivestyle.irl.identification.paper_scorers import DEFAULT_SCORER
from drivestyle.irl.identification.result import INTERVAL_MASS

if TYPE_CHECKING:
    from drivestyle.studies.identification.references import References
    from drivestyle.studies.identification.study import Evaluation

__all__ = [
    "driver_evaluation_markdown",
    "evaluation_markdown",
    "noise_markdown",
    "references_markdown",
]


def evaluation_markdown(results: Mapping[str, Evaluation], extra: Sequence[str] = ()) -> str:
    """``evaluation.md``: per feature set and scorer, accuracy, MAE, intervals, pooling, timing.

    Args:
        results: feature-set name → its evaluation.
        extra: further Markdown lines (references, noise curve).
    """
    lines = [
        "# Style identification on held-out scenarios",
        "",
        f"Default scorer: {DEFAULT_SCORER}; interval: {INTERVAL_MASS:.0%} posterior mass.",
        "",
        "Demonstrations refused (not identifiable, e.g. no lane change): "
        + ", ".join(f"{n} {r.summary.n_failed} of {r.summary.n}" for n, r in results.items()),
        "",
        "| features | scorer | grid acc. (informative) | grid acc. (all) | grid MAE "
        "(informative) | between MAE (posterior mean) | interval coverage | interval width |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, r in results.items():
        sm = r.summary
        for s, m in sm.by_scorer.items():
            lines.append(
                f"| {name} | {s} | {fmt(m.grid_accuracy_informative, 2)} "
                f"({sm.n_grid_informative}) | {fmt(m.grid_accuracy, 2)} ({sm.n_grid}) | "
                f"{fmt(m.grid_mae_informative)} | {fmt(m.between_mae_interpolated)} | "
                f"{fmt(m.interval_coverage, 2)} | {fmt(m.interval_width, 2)} |"
            )
    lines += [
        "",
        "| features | pooled 3 demos: accuracy single → pooled | interval width single → "
        "pooled | transfer | identify s (median) |",
        "|---|---|---|---|---|",
    ]
    for name, r in results.items():
        sm, pl = r.summary, r.summary.pooled
        lines.append(
            f"| {name} | {fmt(pl.single_accuracy, 2)} → {fmt(pl.pooled_accuracy, 2)} "
            f"({pl.n_pools} pools) | {fmt(pl.single_interval_width, 2)} → "
            f"{fmt(pl.pooled_interval_width, 2)} | {fmt(sm.transfer_own_risk_best, 2)} "
            f"(own style's median rmse_y {fmt(sm.own_style_rmse_y_median_m, 2)} m) | "
            f"{fmt(sm.identify_s_median, 2)} |"
        )
    return "\n".join([*lines, "", *extra, ""])


def noise_markdown(curves: Mapping[str, Sequence[Evaluation]]) -> list[str]:
    """Markdown lines: the default scorer's accuracy and coverage per noise level."""
    lines = [
        "## Measurement noise (default scorer)",
        "",
        "| features | σ [m] | grid acc. (informative) | coverage |",
        "|---|---|---|---|",
    ]
    for name, evaluations in curves.items():
        for e in evaluations:
            m = e.summary.by_scorer[DEFAULT_SCORER]
            lines.append(
                f"| {name} | {e.summary.noise_sigma_m:g} | "
                f"{fmt(m.grid_accuracy_informative, 2)} | {fmt(m.interval_coverage, 2)} |"
            )
    return [*lines, ""]


def references_markdown(refs: References, results: Mapping[str, Evaluation]) -> list[str]:
    """Markdown lines comparing IRL identification with the two references."""
    lines = [
        "## References on the same grid demonstrations",
        "",
        "| method | grid accuracy |",
        "|---|---|",
    ]
    for name, r in results.items():
        lines.append(
            f"| IRL library ({name}, {DEFAULT_SCORER}) | "
            f"{fmt(r.summary.by_scorer[DEFAULT_SCORER].grid_accuracy, 2)} |"
        )
    for name, k in refs.knn.items():
        lines.append(
            f"| k-NN on features + scenario ({name}), no IRL | {fmt(k.grid_accuracy, 2)} |"
        )
    c = refs.ceiling
    lines.append(
        f"| ceiling: simulate SMPC(p) in the demo's scenario | {fmt(c.grid_accuracy, 2)} "
        f"({fmt(c.tied_fraction, 2)} of demos tied with a neighbour; untied "
        f"{fmt(c.grid_accuracy_untied, 2)}) |"
    )
    return [*lines, ""]


def driver_evaluation_markdown(curve: Sequence[Evaluation], refs: References | None = None) -> str:
    """``evaluation.md``'s driver-library part: identification beside the path ceiling.

    Per noise level: the whole grid and the identifiable subset, continuous risks, interval
    coverage, pooling and timing.

    Args:
        curve: the driver library's evaluations, one per noise level (the first: headline).
        refs: the re-simulating ceiling of ``--references`` (None: not run).
    """
    lines = [
        "",
        "## Driver library (receding-horizon style, scorer likelihood)",
        "",
        "Identifiable: a grid demonstration whose neighbouring grid risks' closed-loop SMPC "
        "paths lie ≥ 5 cm RMS from the true risk's in its scenario (path ceiling). Ceiling: "
        "the grid risk whose SMPC path in the scenario is closest to the demonstration as "
        "observed.",
        "",
        "| σ [m] | grid acc. (all) | ceiling (all) | identifiable acc. | ceiling "
        "(identifiable) | grid coverage | continuous MAE (mean) | continuous coverage | "
        "coverage (all) | interval width | pooled 3: single → pooled | identify s (median) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for e in curve:
        sm = e.summary
        m = sm.by_scorer[e.scorer]
        c = sm.ceiling
        pl = sm.pooled
        lines.append(
            f"| {sm.noise_sigma_m:g} | {fmt(m.grid_accuracy, 2)} ({sm.n_grid}) | "
            f"{fmt(c.grid_accuracy if c else None, 2)} | "
            f"{fmt(m.grid_accuracy_identifiable, 2)} ({c.n_identifiable if c else '—'}) | "
            f"{fmt(c.identifiable_accuracy if c else None, 2)} | {fmt(m.grid_coverage, 2)} | "
            f"{fmt(m.continuous_mae_interpolated)} ({sm.n_continuous}) | "
            f"{fmt(m.continuous_coverage, 2)} | {fmt(m.interval_coverage, 2)} | "
            f"{fmt(m.interval_width, 2)} | {fmt(pl.single_accuracy, 2)} → "
            f"{fmt(pl.pooled_accuracy, 2)} ({pl.n_pools}) | {fmt(sm.identify_s_median, 2)} |"
        )
    head = curve[0].summary
    m0 = head.by_scorer[curve[0].scorer]
    lines += [
        "",
        f"Between-grid risks (midpoints, {head.n_between - head.n_continuous} demos): MAE of "
        f"the posterior mean {fmt(m0.between_mae_interpolated)}; refused demonstrations "
        f"{head.n_failed} of {head.n}.",
    ]
    if refs is not None:
        c2 = refs.ceiling
        lines.append(
            f"Re-simulating ceiling (references.py): grid accuracy {fmt(c2.grid_accuracy, 2)} "
            f"({fmt(c2.tied_fraction, 2)} tied within 1 cm; untied "
            f"{fmt(c2.grid_accuracy_untied, 2)})."
        )
    return "\n".join([*lines, ""])
