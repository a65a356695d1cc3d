"""The prediction study's report: ``report.md`` of ``drivestyle evaluate-prediction``.

:func:`prediction_markdown` writes the study's tables (per set, t_obs and method; the
recorded benchmark's with bootstrap intervals; the goals; online identification; the
prediction regions' coverage), and the recorded episodes by kind (:func:`kind_sections`):
per kind one table of the methods' FDE median with its interval per t_obs, one table of the
FDE relative to CV's, and the regions calibrated per kind. Shares, intervals and times are
formatted as every study's report formats them (:mod:`drivestyle.studies.formatting`).
"""

from __future__ import annotations

from drivestyle.common.io import fmt
from drivestyle.prediction.errors import ERROR_METRICS
from drivestyle.prediction.methods import METHODS
from drivestyle.prediction.regions import KIND_MIN_CALIBRATION
from drivestyle.recorded.kinds import ALL_KINDS, EPISODE_KINDS, STOP_AND_GO
from drivestyle.studies.formatting import percent, seconds, value_interval
from drivestyle.studies.prediction.study import TEST_SEED, VALIDATION_SEED, PredictionStudy
from drivestyle.studies.prediction.summaries import (
    BOOTSTRAP_SAMPLES,
    RATIO_GOALS,
    RATIO_REFERENCE,
    RatioStat,
    report_set,
    shown_kinds,
)
from drivestyle.studies.prediction.tracking import NARROW_WIDTH, TrackingSummary

__all__ = ["kind_sections", "prediction_markdown"]


def _benchmark_tables(study: PredictionStudy) -> list[str]:
    """The recorded benchmark's tables: per set, medians and means with bootstrap intervals."""
    sets = [s for s in dict.fromkeys(x.set for x in study.summaries) if s != "simulated"]
    if not sets:
        return []
    lines = [
        f"## Recorded benchmark: split {study.split or '(used episodes)'}",
        "",
        "Every error [m] as value [bootstrap 95 % interval] over vehicles "
        f"({BOOTSTRAP_SAMPLES} replicates); lat = |Δy|, lon = |Δx| in the road frame. "
        "Physics parameters: "
        + ", ".join(f"{k} {v:.3g}" for k, v in (study.physics_json()).items())
        + ". Joint physics parameters: "
        + ", ".join(f"{k} {v:.3g}" for k, v in (study.joint_physics_json()).items())
        + ".",
        "",
    ]
    for set_name in sets:
        rows = [s for s in study.summaries if s.set == set_name and s.stats]
        for kind in ("median", "mean"):
            lines += [
                f"### {set_name}: {kind}s",
                "",
                "| t_obs | method | n (vehicles) | " + " | ".join(ERROR_METRICS) + " |",
                "|---|---|---|" + "---|" * len(ERROR_METRICS),
            ]
            for s in rows:
                cells = " | ".join(value_interval(s.stats[m], kind) for m in ERROR_METRICS)
                lines.append(f"| {seconds(s.t_obs)} | {s.method} | {s.n} ({s.n_units}) | {cells} |")
            lines.append("")
    return lines


def prediction_markdown(study: PredictionStudy, command: str) -> str:
    """``report.md`` of the prediction comparison (docs/RESULTS.md quotes it).

    Args:
        study: the study's result.
        command: the command that produced it.
    """
    n_sim = len(study.vehicles)
    n_rand = sum(v.scenario is not None for v in study.vehicles)
    seed_kind = {TEST_SEED: "the test seed", VALIDATION_SEED: "the validation seed"}.get(
        study.seed, f"neither the validation seed {VALIDATION_SEED} nor the test seed {TEST_SEED}"
    )
    lines = [
        "# Style-aware prediction against constant velocity",
        "",
        f"Command: `{command}`",
        "",
        f"Seed {study.seed} ({seed_kind}); {n_sim} simulated vehicles "
        f"({n_rand} random family, {n_sim - n_rand} traffic), risks U[0.5, 0.95]; recorded: "
        f"{', '.join(study.recorded_sets) or 'none'}"
        + (
            " (solver geometries: "
            + ", ".join(f"{k} {v}" for k, v in study.n_geometries.items())
            + ")"
            if study.n_geometries
            else ""
        )
        + f". Predictions: {len(study.records)}; skipped: {len(study.skipped)}.",
        "",
        "Wall time: " + ", ".join(f"{k} {seconds(v)}" for k, v in study.seconds.items()) + ".",
        "",
    ]
    sets = list(dict.fromkeys(s.set for s in study.summaries))
    for set_name in sets:
        rows = [s for s in study.summaries if s.set == set_name]
        oracle = any(s.fde_ratio_to_oracle is not None for s in rows)
        lines += [
            f"## {set_name}",
            "",
            "| t_obs | method | n | ADE mean (median) [m] | FDE mean (median) [m] | "
            "lateral FDE mean [m] | FDE reduction vs CV |"
            + (" FDE / oracle | FDE − oracle [m] | share of oracle's gain |" if oracle else ""),
            "|---|---|---|---|---|---|---|" + ("---|---|---|" if oracle else ""),
        ]
        for s in rows:
            line = (
                f"| {seconds(s.t_obs)} | {s.method} | {s.n} | {fmt(s.ade_mean_m, 2)} "
                f"({fmt(s.ade_median_m, 2)}) | {fmt(s.fde_mean_m, 2)} ({fmt(s.fde_median_m, 2)}) "
                f"| {fmt(s.fde_lat_mean_m, 2)} | {percent(s.fde_reduction_vs_cv)} |"
            )
            if oracle:
                ratio = s.fde_ratio_to_oracle
                line += (
                    f" {'—' if ratio is None else (f'{ratio:.2f}' if ratio < 1e3 else '≫ 1')} | "
                    f"{fmt(s.fde_gap_to_oracle_m, 2)} | {percent(s.oracle_gain_share)} |"
                )
            lines.append(line)
        lines.append("")
    lines += _benchmark_tables(study)
    lines += kind_sections(study)
    lines += [
        "## Goals",
        "",
        "FDE ≥ 30 % below CV on simulated vehicles and ≥ 15 % on recorded ones; within 25 % "
        "of the oracle (FDE ≤ 1.25 × FDE_oracle) on simulated ones.",
        "",
        "| goal | set | t_obs | method | threshold | value | |",
        "|---|---|---|---|---|---|---|",
    ]
    for g in study.goals:
        value = g.value
        shown = "—" if value is None else (f"{value:.3f}" if abs(value) < 1e3 else "≫ 1")
        lines.append(
            f"| {g.goal} | {g.set} | {seconds(g.t_obs)} | {g.method} | {g.threshold:g} | "
            f"{shown} | {'met' if g.met else 'MISSED'} |"
        )
    tr = study.tracking
    lines.append("")
    if tr.n:  # no simulated vehicle (--episodes, --no-simulated): no section of nothing
        lines += _tracking_section(tr)
    if study.regions:
        lines += [
            "## 90 % prediction regions (split-conformal, calibrated on another split)",
            "",
            "A disc around the predicted final position, radius = rate × horizon (the "
            "calibration split's ⌈(n+1)·0.9⌉-th FDE per second); coverage on this split.",
            "",
            "| set | t_obs | method | rate [m/s] (n cal.) | median radius [m] | coverage (n) |",
            "|---|---|---|---|---|---|",
        ]
        lines += [
            f"| {g.set} | {seconds(g.t_obs, 0)} | {g.method} | {fmt(g.rate_m_per_s, 2)} "
            f"({g.n_calibration}) | {fmt(g.median_radius_m, 1)} | {percent(g.coverage)} ({g.n}) |"
            for g in study.regions
        ] + [""]
    if study.skipped:
        lines += ["## Skipped", ""]
        reasons: dict[str, int] = {}
        for skip in study.skipped:
            key = f"{skip.set}: {skip.reason}"
            reasons[key] = reasons.get(key, 0) + 1
        lines += [f"- {n} × {r}" for r, n in sorted(reasons.items())] + [""]
    return "\n".join(lines)


def _tracking_section(tr: TrackingSummary) -> list[str]:
    """The online identification's section (simulated vehicles only)."""
    return [
        "## Online identification (simulated vehicles, inputs unseen)",
        "",
        f"{tr.n} vehicles; the 90 % interval gets narrower than {NARROW_WIDTH:g} for "
        f"{tr.n_narrow} ({percent(tr.fraction_narrow)}), first after a median "
        f"{seconds(tr.t_narrow_median_s)} (10–25–75–90 %: {seconds(tr.t_narrow_q10_s)}, "
        f"{seconds(tr.t_narrow_q25_s)}, {seconds(tr.t_narrow_q75_s)}, "
        f"{seconds(tr.t_narrow_q90_s)}); it stays narrow to the end for {tr.n_narrow_stays} "
        f"(from a median {seconds(tr.t_narrow_stays_median_s)}). Final interval covers the "
        f"true risk for {percent(tr.final_coverage)}; final |mean − p| {fmt(tr.final_mae)}. "
        f"Update: median {fmt(tr.update_ms_median, 1)} ms, p95 {fmt(tr.update_ms_p95, 1)} ms "
        "(parallel workers on a shared machine).",
        "",
    ]


def _label(kind: str) -> str:
    return {ALL_KINDS: "every kind", STOP_AND_GO: "stop-and-go windows (any kind)"}.get(
        kind, kind.replace("_", " ")
    )


def kind_sections(study: PredictionStudy) -> list[str]:
    """The recorded episodes by kind: FDE medians per kind, the ratios to CV, the regions.

    For the set :func:`~drivestyle.studies.prediction.summaries.report_set` picks (every
    recorded episode); nothing where the run has none.
    """
    set_name = report_set([s.set for s in study.kind_summaries])
    groups = shown_kinds(study.kind_summaries)
    if set_name is None or not groups:
        return []
    times = sorted({s.t_obs for s in study.kind_summaries if s.set == set_name})
    head = " | ".join(seconds(t) for t in times)
    counts = []
    recs = [r for r in study.records if r.set != "simulated"]
    recs = recs if set_name == "recorded" else [r for r in recs if r.set == set_name]
    for kind in EPISODE_KINDS:
        of_kind = [r for r in recs if r.kind == kind]
        if of_kind:
            counts.append(f"{_label(kind)} {len({r.vehicle_id for r in of_kind})} episodes of "
                          f"{len({r.unit or r.vehicle_id for r in of_kind})} vehicles")  # fmt: skip
    n_sg = len({r.vehicle_id for r in recs if r.stop_and_go})
    lines = [
        f"## By kind of episode: {set_name}",
        "",
        "; ".join(counts) + f"; {n_sg} of the episodes in stop-and-go windows. "
        + ("Every episode is of one kind: its numbers are the pooled ones. "
           if len([g for g in groups if g in EPISODE_KINDS]) == 1 else "")
        + "FDE median [bootstrap 95 % interval, vehicles resampled] [m].",
        "",
    ]  # fmt: skip
    for kind in groups:
        lines += [f"### {_label(kind)}", "", f"| method | {head} |", "|---|" + "---|" * len(times)]
        ns = [study.summary(set_name, t, RATIO_REFERENCE, kind) for t in times]
        lines.append("| n (vehicles) | " + " | ".join(
            "—" if s is None else f"{s.n} ({s.n_units})" for s in ns) + " |")  # fmt: skip
        for method in METHODS:
            cells = [study.summary(set_name, t, method, kind) for t in times]
            if all(c is None for c in cells):
                continue
            lines.append(f"| {method} | " + " | ".join(
                "—" if c is None else value_interval(c.stats["fde"], "median") for c in cells
            ) + " |")  # fmt: skip
        lines.append("")
    lines += _ratio_table(study, set_name, groups, times)
    lines += _kind_region_table(study, set_name, groups, times)
    return lines


def _ratio_cell(r: RatioStat | None) -> str:
    if r is None or r.n == 0:
        return "—"
    mark = " ✓" if r.below_goal else ""
    return f"{r.median:.2f} [{r.lo:.2f}, {r.hi:.2f}]{mark}"


def _ratio_table(
    study: PredictionStudy, set_name: str, groups: list[str], times: list[float]
) -> list[str]:
    """One table: per kind and method, FDE / CV's FDE per t_obs (and lateral, lane changes)."""
    mine = {(r.kind, r.method, r.metric, r.t_obs): r for r in study.ratios if r.set == set_name}
    if not mine:
        return []
    lateral = any(k[2] == "fde_lat" for k in mine)
    head = " | ".join(f"FDE {seconds(t)}" for t in times)
    if lateral:
        head += " | " + " | ".join(f"lateral {seconds(t)}" for t in times)
    n_cols = len(times) * (2 if lateral else 1)
    lines = [
        f"### FDE relative to {RATIO_REFERENCE.upper()}",
        "",
        f"Median over predictions of FDE_method / FDE_{RATIO_REFERENCE} (each prediction's own "
        "ratio) [bootstrap 95 % interval, vehicles resampled]; below 1: better than "
        f"{RATIO_REFERENCE.upper()}. Goals: ≤ {RATIO_GOALS['fde']:.2f} pooled and for lane "
        f"changes, lateral ≤ {RATIO_GOALS['fde_lat']:.2f} for lane changes; ✓: the whole "
        "interval below the goal.",
        "",
        f"| kind | method | {head} |",
        "|---|---|" + "---|" * n_cols,
    ]
    for kind in groups:
        for method in METHODS:
            cells = [mine.get((kind, method, "fde", t)) for t in times]
            if lateral:
                cells += [mine.get((kind, method, "fde_lat", t)) for t in times]
            if all(c is None for c in cells):
                continue
            lines.append(f"| {_label(kind)} | {method} | "
                         + " | ".join(_ratio_cell(c) for c in cells) + " |")  # fmt: skip
    return [*lines, ""]


def _kind_region_table(
    study: PredictionStudy, set_name: str, groups: list[str], times: list[float]
) -> list[str]:
    """Coverage of the regions calibrated per kind: per kind and method, per t_obs."""
    mine = {(g.kind, g.method, g.t_obs): g for g in study.kind_regions if g.set == set_name}
    if not mine:
        return []
    lines = [
        "### 90 % prediction regions calibrated per kind",
        "",
        "Each kind's rate from its own records of the calibration run where it has at least "
        f"{KIND_MIN_CALIBRATION} (at that t_obs), else the pooled rate (†, with the kind's "
        "own count); every record judged by its kind's region. Coverage (n) on this split.",
        "",
        "| kind | method | " + " | ".join(seconds(t) for t in times) + " |",
        "|---|---|" + "---|" * len(times),
    ]
    for kind in groups:
        for method in METHODS:
            cells = [mine.get((kind, method, t)) for t in times]
            if all(c is None for c in cells):
                continue
            shown = [
                "—" if c is None
                else f"{percent(c.coverage)} ({c.n})"
                + (f" † ({c.n_kind_calibration} cal.)" if c.calibrated_on == "pooled" else "")
                for c in cells
            ]  # fmt: skip
            lines.append(f"| {_label(kind)} | {method} | " + " | ".join(shown) + " |")
    return [*lines, ""]
