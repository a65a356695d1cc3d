"""The replay study's report: ``replay.md``."""

from __future__ import annotations

from typing import TYPE_CHECKING

from drivestyle.common.io import fmt
from drivestyle.studies.formatting import percent, seconds

if TYPE_CHECKING:
    from drivestyle.studies.replay.study import Collision, EpisodeReplay, ReplayStudy

__all__ = ["replay_markdown"]

ATTENDED = {
    "ahead": "the vehicles ahead and, changing lane, the target lane's",
    "lanes": "the vehicles ahead in its lane and those of the lane it heads for",
    "all": "every other vehicle",
}
"""Whom the style drivers plan around, said (``attend``)."""


def _pairs(found: tuple[Collision, ...]) -> str:
    """``0–1 @ 1.2 s (3)`` per pair: vehicles, first time since the start, samples."""
    return ", ".join(f"{c.a}–{c.b} @ {seconds(c.first_s)} ({c.samples})" for c in found) or "—"


def _speeds(replay: EpisodeReplay) -> str:
    """``within/with a recorded range``, and the vehicles outside it with both ranges."""
    judged = [s for s in replay.speeds if s.within is not None]
    out = [
        f"{s.vehicle}: {fmt(s.replayed_min, 1)}–{fmt(s.replayed_max, 1)} vs "
        f"{fmt(s.recorded_min, 1)}–{fmt(s.recorded_max, 1)}"
        for s in judged
        if not s.within
    ]
    head = f"{sum(bool(s.within) for s in judged)}/{len(judged)}"
    return head + (f" (outside: {'; '.join(out)})" if out else "")


def replay_markdown(study: ReplayStudy, command: str) -> str:
    """The summary and one row per episode (``replay.md``)."""
    s = study.summary()
    idm = study.idm
    if study.others == "style":
        drivers = (
            "Every vehicle, the EV included, drives its own style identified from the samples "
            f"up to the start by the amortized posterior {study.posterior} (the joint "
            "prediction's point driver, re-planning at every step against the current states of "
            f"{ATTENDED.get(study.attend or '', 'the others')}; "
            f"DESIGN §24): {s['plans']} plans, {s['failed_plans']} failed."
        )
    else:
        drivers = (
            "Every surrounding vehicle drives the IDM along its log's lateral path, the EV the "
            f"same IDM through the bicycle (DESIGN §24); IDM {study.idm_choice}: a_max = "
            f"{fmt(idm.a_max, 2)} m/s², b = {fmt(idm.b, 2)} m/s², s0 = {fmt(idm.s0, 2)} m, "
            f"T = {fmt(idm.time_gap, 2)} s, v0 = {fmt(study.v0_factor, 3)} × v90 of the speeds "
            "up to the start."
        )
    lines = [
        "# Recorded scenes replayed with every vehicle reactive",
        "",
        f"Command: `{command}`",
        "",
        f"Episodes: {study.source}. {drivers} Collision: the scenario's rectangles overlap "
        "(the env's rule), in the log from the start to its end; speeds within the recorded range "
        f"± {fmt(study.tolerance, 2)} m/s.",
        "",
        "| episodes | vehicles | ended early | log collision pairs | replay collision pairs "
        "| new pairs (episodes) | speeds within range | largest excess [m/s] "
        "| EV's largest lateral deviation [m] |",
        "|---|---|---|---|---|---|---|---|---|",
        f"| {s['episodes']} | {s['vehicles']} | {s['ended_early']} | "
        f"{s['log_collision_pairs']} | {s['replay_collision_pairs']} | "
        f"{s['new_collision_pairs']} ({s['episodes_with_new_collisions']}) | "
        f"{s['speeds_within']}/{s['vehicles_with_recorded_speeds']} "
        f"({percent(s['speeds_within_share'])}) | {fmt(s['speed_excess_max_mps'], 2)} | "
        f"{fmt(s['ev_lateral_max_m'], 2)} |",
        "",
        "Per episode (pairs: vehicles a–b, 0 the EV, @ first overlap since the start, "
        "(samples); speeds: replayed min–max vs recorded min–max [m/s] of those outside):",
        "",
        "| set | episode | start | steps | ended | vehicles | log collisions | replay collisions "
        "| new | speeds within | EV lateral [m] |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in study.replays:
        lines.append(
            f"| {r.dataset} | {r.episode_id} | {r.start} | {r.steps}/{r.log_steps} | {r.ended} "
            f"| {r.vehicles} | {_pairs(r.log_collisions)} | {_pairs(r.replay_collisions)} | "
            f"{_pairs(r.new_collisions)} | {_speeds(r)} | {fmt(r.ev_lateral_m, 2)} |"
        )
    lines += ["", f"Wall time {seconds(study.seconds)}.", ""]
    return "\n".join(lines)
