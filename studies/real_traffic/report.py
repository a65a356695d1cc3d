"""The recorded-traffic study's report: ``real_traffic.md`` (paper model, then driver model)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from drivestyle.common.io import fmt
from drivestyle.studies.formatting import seconds

if TYPE_CHECKING:
    from drivestyle.studies.real_traffic.driver_study import DriverTrafficStudy
    from drivestyle.studies.real_traffic.study import RealTrafficStudy

__all__ = ["driver_traffic_markdown", "real_traffic_markdown"]


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
