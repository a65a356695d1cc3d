"""The Markdown reports the studies write, and how they print times.

The prediction study writes its own (:mod:`drivestyle.studies.prediction.report`).

Each function takes a study's typed result and returns the Markdown text (or, for the
parts of ``evaluation.md``, its lines); the scripts write it beside the JSON.
Numbers are rounded here once, so a time reads ``2.4 s`` and never ``2.4000000000000004 s``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from drivestyle.common.io import fmt
from drivestyle.irl.identification.posterior import DEFAULT_SCORER, INTERVAL_MASS, VERDICT_LABELS
from drivestyle.studies.compare import LABELS

if TYPE_CHECKING:
    from drivestyle.studies.av_vs_human import AVHumanComparison
    from drivestyle.studies.capacity import CapacityStudy
    from drivestyle.studies.ceiling import References
    from drivestyle.studies.compare import Comparison
    from drivestyle.studies.cut_in_study import PlanningStudy
    from drivestyle.studies.identification_study import Evaluation
    from drivestyle.studies.out_of_class import OutOfClassStudy
    from drivestyle.studies.paper import PaperStudy
    from drivestyle.studies.real_traffic import DriverTrafficStudy, RealTrafficStudy

__all__ = [
    "av_human_markdown",
    "capacity_markdown",
    "comparison_markdown",
    "driver_evaluation_markdown",
    "driver_traffic_markdown",
    "evaluation_markdown",
    "noise_markdown",
    "out_of_class_markdown",
    "paper_console",
    "paper_markdown",
    "planning_markdown",
    "real_traffic_markdown",
    "references_markdown",
    "seconds",
]


def seconds(t: float | None, digits: int = 1) -> str:
    """A time for people to read: ``2.4 s`` (rounded to ``digits`` decimals), ``never`` for None.

    Sample times are multiples of the step (k·0.2 s) and carry floating-point residue;
    every print, caption and report shows them through this function.
    """
    return "never" if t is None else f"{t:.{digits}f} s"


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


def _av_hv_markdown(d: dict[str, Any]) -> str:
    c = d["classifier_base_features"]
    rows = [
        "| set | n | median rmse_y (personal reactive) | median peak lateral accel | "
        "median 10–90 % duration |",
        "|---|---|---|---|---|",
    ]
    for s in ("AV", "HV"):
        if s in d:
            rows.append(
                f"| {s} | {d['n'][s]} | {d[s]['rmse_y_personal_reactive_median_m']:.3f} m "
                f"| {d[s]['peak_lateral_accel_mps2']:.2f} m/s² | "
                f"{seconds(d[s]['duration_10_90_s'])} |"
            )
    rows += [
        "",
        f"Leave-one-out nearest-centroid classifier on the base-feature styles: "
        f"{c['accuracy']:.0%} of {c['n']} (majority rate {c['majority_rate']:.0%}, "
        f"one-sided binomial p = {c['p_value_vs_majority']:.2f}).",
    ]
    return "\n".join(rows)


def real_traffic_markdown(study: RealTrafficStudy) -> str:
    """``real_traffic.md``: medians per method, AV vs human (CATS), rmse_y per episode."""
    medians = study.medians
    methods = list(medians)  # REPRODUCTIONS, in its order
    lines = [
        f"# Real traffic: {study.dataset}",
        "",
        f"{study.n_used} of {study.n_episodes} episodes used (selection in recorded/real_data.py).",
        "",
        "| method | median rmse_y [m] | median rmse_xy [m] | median fde [m] |",
        "|---|---|---|---|",
    ]
    for m in methods:
        lines.append(
            f"| {m} | {fmt(medians[m]['rmse_y_m'])} | {fmt(medians[m]['rmse_xy_m'])} "
            f"| {fmt(medians[m]['fde_m'])} |"
        )
    if study.av_vs_hv is not None:
        lines += ["", "## AV vs human", "", _av_hv_markdown(study.av_vs_hv)]
    lines += [
        "",
        "| episode | " + " | ".join(f"{m} rmse_y" for m in methods) + " |",
        "|---|" + "---|" * len(methods),
    ]
    for r in study.episodes:
        if "methods" in r:
            lines.append(
                f"| {r['episode_id']} | "
                + " | ".join(fmt(r["methods"].get(m, {}).get("rmse_y_m")) for m in methods)
                + " |"
            )
    return "\n".join(lines) + "\n"


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


def driver_traffic_markdown(
    study: DriverTrafficStudy, paper: RealTrafficStudy | None = None
) -> str:
    """``real_traffic.md``'s driver-model part.

    Medians beside the paper model's, the per-vehicle leave-one-out test and the episodes.
    """
    m = study.medians
    settings = study.settings
    lines = [
        "",
        "## Receding-horizon driver model (irl/driver/driver_style.py)",
        "",
        "Per episode `learn_driver([episode], fit_speed=True)` (weights, risk p and desired "
        f"speed free; {settings.screen} screened starts, {settings.restarts} LM run(s)), "
        "reproduced in closed loop against the recorded vehicles.",
        "",
        "| model | reproduction | median rmse_y [m] | median rmse_xy [m] | median fde [m] |",
        "|---|---|---|---|---|",
    ]
    for name in ("personal", "own_loo", "general_loo"):
        v = m[name]
        if v["rmse_y_m"] is not None:
            lines.append(
                f"| driver | {name} | {fmt(v['rmse_y_m'])} | {fmt(v['rmse_xy_m'])} "
                f"| {fmt(v['fde_m'])} |"
            )
    if paper is not None:
        for name in ("personal_reactive", "general"):
            v = paper.medians[name]
            lines.append(
                f"| paper | {name} | {fmt(v['rmse_y_m'])} | {fmt(v['rmse_xy_m'])} "
                f"| {fmt(v['fde_m'])} |"
            )
    if study.vehicles:
        lines += [
            "",
            "### A vehicle's style from its other episodes (leave-one-out)",
            "",
            "| vehicle | held out | own rmse_y | general rmse_y | own rmse_xy | general rmse_xy |",
            "|---|---|---|---|---|---|",
        ]
        for vehicle, entry in study.vehicles.items():
            for sp in entry["splits"]:
                g = sp.get("general_loo", {})
                lines.append(
                    f"| {vehicle} | {sp['held_out']} | {fmt(sp['own_loo']['rmse_y_m'])} "
                    f"| {fmt(g.get('rmse_y_m'))} | {fmt(sp['own_loo']['rmse_xy_m'])} "
                    f"| {fmt(g.get('rmse_xy_m'))} |"
                )
            own, gen = entry["median_own_loo"], entry["median_general_loo"]
            lines.append(
                f"| {vehicle} | **median** | {fmt(own['rmse_y_m'])} | {fmt(gen['rmse_y_m'])} "
                f"| {fmt(own['rmse_xy_m'])} | {fmt(gen['rmse_xy_m'])} |"
            )
    lines += [
        "",
        "| episode | driver personal rmse_y | rmse_xy | risk p | v_ref [m/s] | failures | min d |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in study.episodes:
        p = r["personal"]
        style = p["fit"]["style"]
        lines.append(
            f"| {r['episode_id']} | {fmt(p['rmse_y_m'])} | {fmt(p['rmse_xy_m'])} "
            f"| {fmt(style['risk'], 2)} | {fmt(style['v_ref'], 1)} | {p['failures']} "
            f"| {fmt(p['min_d'], 2)} |"
        )
    return "\n".join(lines) + "\n"


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
            f"Re-simulating ceiling (ceiling.py): grid accuracy {fmt(c2.grid_accuracy, 2)} "
            f"({fmt(c2.tied_fraction, 2)} tied within 1 cm; untied "
            f"{fmt(c2.grid_accuracy_untied, 2)})."
        )
    return "\n".join([*lines, ""])


def planning_markdown(study: PlanningStudy) -> str:
    """The cut-in study's table (``planning.md``; docs/RESULTS.md quotes it)."""
    from drivestyle.studies.cut_in_study import HARD_BRAKING

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


def av_human_markdown(comparison: AVHumanComparison, command: str) -> str:
    """``av_vs_human.md``: per quantity the groups' medians and the AV's differences."""
    from drivestyle.studies.av_vs_human import GROUPS, QUANTITIES

    def cell(median: float | None, lo: float | None, hi: float | None, n: int | None = None):
        if median is None:
            return "—"
        text = f"{fmt(median, 3)} [{fmt(lo, 3)}, {fmt(hi, 3)}]"
        return text if n is None else f"{text} (n {n})"

    lines = [
        "# The automated car against human drivers (CATS)",
        "",
        f"`{command}`",
        "",
        "Medians with percentile-bootstrap 95 % intervals over each group's lane changes; "
        "a difference is the AV's median minus the group's (its interval excludes 0: "
        "**bold**).",
        "",
        "| quantity | " + " | ".join(GROUPS) + " | AV − same car, human | AV − other humans |",
        "|---|" + "---|" * (len(GROUPS) + 2),
    ]
    for q, meaning in QUANTITIES.items():
        stats = {s.group: s for s in comparison.stats if s.quantity == q}
        row = [cell(stats[g].median, stats[g].lo, stats[g].hi, stats[g].n) for g in GROUPS]
        for d in (d for d in comparison.differences if d.quantity == q):
            text = cell(d.median, d.lo, d.hi)
            row.append(f"**{text}**" if d.excludes_zero else text)
        lines.append(f"| {meaning} | " + " | ".join(row) + " |")
    lines += ["", "Identification verdicts (lane changes):", ""]
    for g in GROUPS:
        counts = comparison.verdicts.get(g, {})
        lines.append(f"- {g}: " + ", ".join(f"{v} {n}" for v, n in sorted(counts.items())))
    return "\n".join(lines) + "\n"


def out_of_class_markdown(study: OutOfClassStudy, command: str) -> str:
    """``out_of_class.md``: identification and prediction of drivers outside the style class.

    Args:
        study: the study's result.
        command: the command that produced it (shown in the report).
    """
    from drivestyle.studies.out_of_class import FDE_GOAL, SPEARMAN_GOAL
    from drivestyle.studies.prediction.report import percent, value_interval

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
    return "\n".join(lines) + "\n"
