"""The out-of-class study's report: ``out_of_class.md``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from drivestyle.common.io import fmt
from drivestyle.irl.amortized.identify import SAMPLES
from drivestyle.irl.identification.verdict import VERDICT_LABELS
from drivestyle.studies.formatting import percent, seconds, value_interval
from drivestyle.studies.out_of_class.amortized import ORDERED
from drivestyle.studies.out_of_class.caution_order import SPEARMAN_GOAL
from drivestyle.studies.out_of_class.study import FDE_GOAL

if TYPE_CHECKING:
    from drivestyle.studies.out_of_class.amortized import AmortizedOutOfClass
    from drivestyle.studies.out_of_class.study import OutOfClassStudy

__all__ = ["amortized_markdown", "out_of_class_markdown"]


def out_of_class_markdown(study: OutOfClassStudy, command: str) -> str:
    """``out_of_class.md``: identification and prediction of drivers outside the style class.

    Args:
        study: the study's result.
        command: the command that produced it (shown in the report).
    """
    cfg = study.config
    lines = [
        "# Drivers outside the style class",
        "",
        f"`{command}`",
        "",
        f"highway-env IDM + MOBIL classes (caution rank 0 = least cautious) and SMPC variants "
        f"(caution = p); seed {cfg.seed}. Verdicts: DESIGN §15. Wall time per stage: "
        + ", ".join(f"{k} {seconds(v, 0)}" for k, v in study.seconds.items())
        + ".",
        "",
    ]
    hw = study.highway_facts
    if hw:
        lines += [
            f"Traffic: {hw['runs']} runs, {hw['lane_changes']} lane changes extracted, "
            f"{hw['usable']} usable; unusable: "
            + (", ".join(f"{k} {v}" for k, v in hw["unusable_reasons"].items()) or "none")
            + ".",
            "",
        ]
    lines += [
        "## Identified risk per group",
        "",
        "| family | group | caution | n | median p | IQR | binds | median min s_e | "
        + " | ".join(VERDICT_LABELS)
        + " |",
        "|---|---|---|---|---|---|---|---|" + "---|" * len(VERDICT_LABELS),
    ]
    for grp in study.groups:
        iqr = "—" if grp.risk_q25 is None else f"{grp.risk_q25:.3f}–{grp.risk_q75:.3f}"
        counts = " | ".join(str(grp.verdicts.get(v, 0)) for v in VERDICT_LABELS)
        lines.append(f"| {grp.family} | {grp.group} | {grp.caution:g} | {grp.n} | "
                     f"{fmt(grp.risk_median)} | {iqr} | {grp.n_binds} | "
                     f"{fmt(grp.min_s_e_median, 2)} | {counts} |")  # fmt: skip
    lines += [
        "",
        f"## Caution order: Spearman ρ (goal ≥ {SPEARMAN_GOAL:g})",
        "",
        "binds: a chance constraint binds (only those episodes can move p); min s_e: the "
        "closest approach of another vehicle in ellipse units, an observed caution without a "
        "model, given as a reference (its ρ with the known caution).",
        "",
        "| scope | episodes | n | ρ (episodes) | p-value | ρ (medians) | goal | ρ of min s_e |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for o in study.orders:
        pv = "—" if o.p_value is None else f"{o.p_value:.2g}"
        lines.append(f"| {o.scope} | {o.subset} | {o.n} | {fmt(o.rho_episodes)} | {pv} | "
                     f"{fmt(o.rho_medians)} | {'met' if o.met else 'missed'} | "
                     f"{fmt(o.rho_min_s_e)} |")  # fmt: skip
    if study.summaries:
        lines += [
            "",
            "## Prediction: FDE [m], median [bootstrap 95 % interval] over episodes",
            "",
            "| set | t_obs | method | n | FDE median | FDE mean | reduction of the mean vs CV |",
            "|---|---|---|---|---|---|---|",
        ]
        for s in study.summaries:
            st = s.stats.get("fde")
            med = f"{s.fde_median_m:.2f}" if st is None else value_interval(st, "median")
            lines.append(f"| {s.set} | {seconds(s.t_obs)} | {s.method} | {s.n} | {med} | "
                         f"{s.fde_mean_m:.2f} | {percent(s.fde_reduction_vs_cv)} |")  # fmt: skip
        lines += [
            "",
            f"## FDE goal: the style ≥ {FDE_GOAL:.0%} below constant velocity",
            "",
            "| set | t_obs | method | n | FDE median | CV median | reduction (median) | "
            "reduction (mean) | goal |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for g in study.goals:
            lines.append(
                f"| {g.set} | {seconds(g.t_obs)} | {g.method} | {g.n} | {g.fde_median_m:.2f} "
                f"[{g.fde_median_ci[0]:.2f}, {g.fde_median_ci[1]:.2f}] | {g.cv_median_m:.2f} "
                f"[{g.cv_median_ci[0]:.2f}, {g.cv_median_ci[1]:.2f}] | "
                f"{percent(g.reduction_median)} | {percent(g.reduction_mean)} | "
                f"{'met' if g.met else 'missed'} |"
            )
    if study.skipped:
        lines += ["", f"Skipped: {len(study.skipped)} (reasons in the JSON)."]
    text = "\n".join(lines) + "\n"
    return text if study.amortized is None else text + amortized_markdown(study.amortized)


def amortized_markdown(amortized: AmortizedOutOfClass) -> str:
    """The report's section on the amortized posterior (appended to ``out_of_class.md``)."""
    lines = [
        "",
        f"## Caution order by the amortized posterior (goal ≥ {SPEARMAN_GOAL:g})",
        "",
        f"Every lane change identified by the amortized posterior `{amortized.estimator}` "
        f"(weights SHA-256 {amortized.estimator_sha256[:12]}…, {SAMPLES} draws; DESIGN §22); "
        "Spearman ρ between the known caution and each parameter's posterior mean, beside the "
        "exact identification's ρ of p over the same episodes.",
        "",
        "| scope | parameter | n | ρ (episodes) | p-value | ρ (medians) | goal | exact ρ of p |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for o in amortized.orders:
        pv = "—" if o.p_value is None else f"{o.p_value:.2g}"
        lines.append(f"| {o.scope} | {o.parameter} | {o.n} | {fmt(o.rho_episodes)} | {pv} | "
                     f"{fmt(o.rho_medians)} | {'met' if o.met else 'missed'} | "
                     f"{fmt(o.rho_exact)} |")  # fmt: skip
    groups = list(dict.fromkeys((e.family, e.group, e.caution) for e in amortized.episodes))
    if amortized.episodes:
        names = [n for n in ORDERED if n in amortized.episodes[0].style.names]
        lines += [
            "",
            "Median posterior means per group:",
            "",
            "| family | group | caution | n | " + " | ".join(names) + " |",
            "|---|---|---|---|" + "---|" * len(names),
        ]
        for fam, grp, c in groups:
            eps = [e for e in amortized.episodes if (e.family, e.group, e.caution) == (fam, grp, c)]
            meds = [fmt(float(np.median([e.style.mean[e.style.index(n)] for e in eps])))
                    for n in names]  # fmt: skip
            lines.append(f"| {fam} | {grp} | {c:g} | {len(eps)} | " + " | ".join(meds) + " |")
    return "\n".join(lines) + "\n"
