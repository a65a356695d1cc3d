"""The prediction study's report: ``report.md`` of ``drivestyle evaluate-prediction``.

:func:`prediction_markdown` writes the study's tables (per set, t_obs and method; the
recorded benchmark's with bootstrap intervals; the goals; online identification; the
prediction regions' coverage). Shares, intervals and times are formatted as every study's
report formats them (:mod:`drivestyle.studies.formatting`).
"""

from __future__ import annotations

from drivestyle.common.io import fmt
from drivestyle.prediction.errors import ERROR_METRICS
from drivestyle.studies.formatting import percent, seconds, value_interval
from drivestyle.studies.prediction.study import TEST_SEED, VALIDATION_SEED, PredictionStudy
from drivestyle.studies.prediction.summaries import BOOTSTRAP_SAMPLES
from drivestyle.studies.prediction.tracking import NARROW_WIDTH, TrackingSummary

__all__ = ["prediction_markdown"]


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
