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
    from drivestyle.studies.identification.amortized_results import (
        BesideExact,
        EstimatorScores,
    )
    from drivestyle.studies.identification.references import References
    from drivestyle.studies.identification.study import Evaluation

__all__ = [
    "amortized_markdown",
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


def _error(scores: EstimatorScores, kind: str) -> str:
    e = scores.risk_error
    if e is None:
        return "—"
    v, lo, hi = (getattr(e, f"{kind}{s}") for s in ("", "_lo", "_hi"))
    return f"{v:.3f} [{lo:.3f}, {hi:.3f}]"


def amortized_markdown(beside: BesideExact) -> str:
    """``evaluation.md``'s part of ``--posterior``: the amortized posterior beside the exact.

    Per noise level both posteriors' risk error, coverage, accuracy and time on the same
    demonstrations, their agreement; the noise's cost; the amortized posterior's other
    parameters on SMPC drivers against the expert's values.
    """
    lines = [
        "",
        "## Amortized posterior beside the exact (the same demonstrations as observed)",
        "",
        f"Estimator: `{beside.posterior}`, {beside.samples} draws per demonstration on one "
        "torch thread. Compared on the demonstrations the exact identified. Grid risk of a "
        "posterior: the library risk whose cell holds most of its mass (the exact's rule; the "
        "amortized posterior's mass is its draws'); identifiable as above. Risk error: "
        "|posterior mean − p|, mean and median with 95 % bootstrap intervals over the "
        "held-out scenarios. Time: the exact's scoring of one demonstration, the amortized "
        "posterior's series and draws.",
        "",
        "| σ [m] | posterior | risk MAE [95 %] | median [95 %] | 90 % coverage | interval "
        "width | grid acc. | identifiable acc. | continuous MAE | ms per episode (median) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for sm in beside.summaries:
        for name, sc in (("exact", sm.exact), ("amortized", sm.amortized)):
            lines.append(
                f"| {sm.noise_sigma_m:g} | {name} | {_error(sc, 'mean')} | "
                f"{_error(sc, 'median')} | {fmt(sc.coverage, 2)} | {fmt(sc.interval_width, 2)} "
                f"| {fmt(sc.grid_accuracy, 2)} | {fmt(sc.identifiable_accuracy, 2)} "
                f"({sm.n_identifiable}) | {fmt(sc.continuous_mae)} | "
                f"{fmt(sc.identify_ms_median, 1)} |"
            )
    lines += [
        "",
        "| σ [m] | compared | refused by the exact | mean difference of the means (abs.) | "
        "median | max | correlation |",
        "|---|---|---|---|---|---|---|",
    ]
    for sm in beside.summaries:
        a = sm.agreement
        lines.append(
            f"| {sm.noise_sigma_m:g} | {a.n} | {sm.n_exact_refused} | {fmt(a.mae)} | "
            f"{fmt(a.median)} | {fmt(a.max)} | {fmt(a.correlation, 2)} |"
        )
    if beside.noise_cost:
        lines += [
            "",
            "What noise costs (against the first level; accuracy in points, negative a "
            "loss; MAE change, positive a loss):",
            "",
            "| σ [m] | exact identifiable | amortized identifiable | exact grid | amortized "
            "grid | exact MAE change | amortized MAE change |",
            "|---|---|---|---|---|---|---|",
        ]
        for c in beside.noise_cost:
            lines.append(
                f"| {c.noise_sigma_m:g} vs {c.baseline_sigma_m:g} | "
                f"{fmt(c.exact_identifiable_points, 1)} | "
                f"{fmt(c.amortized_identifiable_points, 1)} | {fmt(c.exact_grid_points, 1)} | "
                f"{fmt(c.amortized_grid_points, 1)} | {fmt(c.exact_mae_change)} | "
                f"{fmt(c.amortized_mae_change)} |"
            )
    if beside.summaries and beside.summaries[0].parameters:
        head = beside.summaries[0]
        lines += [
            "",
            f"The other parameters on these SMPC drivers (σ = {head.noise_sigma_m:g} m): the "
            "expert is the stochastic driver with T = 0, s_0 = l_a, λ_y = 1, t_on = 0, "
            "σ_a = σ_δ = 0 and the scenario's v_ref (τ: none). Position: the posterior "
            "means' mean in the prior's box (0 its low end); the box centre's error is what "
            "a posterior that learnt nothing would roughly err by.",
            "",
            "| parameter | box | expert's (mean) | posterior mean: mean / median | position "
            "in box | MAE (of the box) | box centre's | 90 % coverage |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for q in head.parameters:
            lines.append(
                f"| {q.name} | [{q.low:g}, {q.high:g}] | {fmt(q.expert_mean, 4)} | "
                f"{q.mean:.4f} / {q.median:.4f} | {q.box_position:.2f} | "
                f"{fmt(q.mae, 4)} ({fmt(q.mae_relative, 2)}) | {fmt(q.centre_mae_relative, 2)} "
                f"| {fmt(q.coverage, 2)} |"
            )
    return "\n".join([*lines, ""])
