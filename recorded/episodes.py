"""Lane-change episodes of a :class:`~drivestyle.recorded.tracks.Recording` as demonstrations.

:func:`extract_episodes` finds, on each carriageway, every lane change of every vehicle
and turns it into a :class:`~drivestyle.envs.demonstration.Demonstration` in the
project's frame; :func:`write_episodes` writes them with an ``episodes.csv`` index. The
rules (the numbers are :class:`ExtractionConfig` fields):

- **Lane.** A sample's lane is the track's ``lane`` where the reader gives one, else the
  lane its centre y lies in between the carriageway's markings.
- **Lane change.** The lane changes from one sample to the next by one lane (to either
  side), the vehicle was in the old lane for ``min_stay_s`` before and stays in the new one
  for ``min_stay_s`` after. The crossing time t_c is where y crosses the line (linear
  between the two samples).
- **Window.** [t_c − ``before_s``, t_c + ``after_s``], cut to the track, to the
  vehicle's previous and next crossing and at a gap between samples longer than
  ``max_gap_s``; it must keep ``min_before_s`` before and ``min_after_s`` after t_c, else
  the episode is kept unusable with the reason. A crossing inside such a gap, or an
  interacting vehicle with one in the window, is unusable too: a spline across it would
  invent the motion.
- **Lateral move.** Across the window the vehicle must move towards the new lane by at
  least ``min_lateral_move`` lane widths (default half the mean width w of the two lanes;
  :func:`lateral_move`), else the episode is kept unusable with the reason: a vehicle
  drifting along a line crosses it and stays on the other side without changing lane.
- **Frame.** x as recorded; y moved so that the crossed line lies at y = w (w the mean
  width of the two lanes) and, for a change to the right, mirrored about it (y → −y, φ →
  −φ): the change goes to +y, lane 0 = [0, w) is the origin lane, lane 1 the target
  (the frame of :mod:`drivestyle.recorded.real_data`).
- **Observed part.** The window's first ``observe_s`` seconds (at most ``min_before_s``, so
  it always ends before the crossing). Every scenario constant estimated from the
  data comes from it alone (:func:`observed_scenario`): nothing of the manoeuvre after it
  enters the scenario, so a prediction or identification made at its end is not told the
  future. The interacting vehicles are chosen at its start.
- **Interacting vehicles** at the window's start, within ``interaction_range_m`` along x:
  the nearest vehicles behind (target-lane follower) and ahead (target-lane leader) in the
  target lane and ahead in the origin lane (own-lane leader). The TV is the first present
  of follower, leader, own-lane leader (the paper's TV is the target-lane follower); the
  others become the demonstration's ``others``. Where a vehicle's track ends inside the
  window it is continued at constant velocity, and the demonstration's ``observed`` mask
  says which states are recorded samples (:mod:`drivestyle.recorded.observed`). Without
  any, the TV is a phantom 1 km behind in the target lane (:data:`PHANTOM_GAP_M`, the CATS
  loader's convention; its mask row is True: it continues no track): the episode is kept
  and flagged ``no_interaction`` — its risk cannot be identified. The demonstration's
  origin is ``"recorded"``.
- **Resampling** to T_s = ``dt`` (:func:`resample_states`): cubic splines through the
  recorded positions; the recorded heading and speed where the track has them, else the
  direction and norm of the splines' velocity.
- **Inputs** [a, δ] are recovered from consecutive states
  (:func:`~drivestyle.envs.dynamics.recover_inputs`, the one function every recorded path
  uses; re-exported here).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.dynamics import recover_inputs
from drivestyle.envs.plausibility import plausibility_problems
from drivestyle.recorded.episode_files import (
    EPISODE_COLUMNS,
    FILE_NAME_HASH,
    FILE_NAME_MAX,
    FILE_NAME_UNSAFE,
    episode_file_name,
    episode_file_names,
    read_episodes,
    write_episodes,
)
from drivestyle.recorded.episode_scenario import observed_scenario, speed_constants
from drivestyle.recorded.extraction_config import (
    FINE_DT_RATIO,
    SECONDS_PER_SAMPLE,
    WINDOW_SAMPLES_MAX,
    ExtractionConfig,
    check_sampling,
    sampling_note,
)
from drivestyle.recorded.lane_changes import (
    LATERAL_MOVE_SPAN_S,
    LaneChange,
    _crossings,
    find_lane_changes,
    lateral_move,
)
from drivestyle.recorded.resampling import _states_on, resample_states, time_grid
from drivestyle.recorded.tracks import Carriageway, Recording, Track

__all__ = [
    "EPISODE_COLUMNS",
    "FILE_NAME_HASH",
    "FILE_NAME_MAX",
    "FILE_NAME_UNSAFE",
    "FINE_DT_RATIO",
    "LATERAL_MOVE_SPAN_S",
    "PHANTOM_GAP_M",
    "ROLES",
    "SECONDS_PER_SAMPLE",
    "WINDOW_SAMPLES_MAX",
    "Episode",
    "ExtractionConfig",
    "LaneChange",
    "check_sampling",
    "episode_file_name",
    "episode_file_names",
    "extract_episodes",
    "find_lane_changes",
    "interacting_vehicles",
    "lateral_move",
    "observed_scenario",
    "read_episodes",
    "recover_inputs",
    "resample_states",
    "sampling_note",
    "speed_constants",
    "time_grid",
    "write_episodes",
]

PHANTOM_GAP_M = -1000.0
"""Gap x_TV − x_EV of the phantom TV of an episode without a target vehicle [m]."""
ROLES = ("target_follower", "target_leader", "own_leader")
"""Interacting vehicles' roles, in the order the TV is chosen from."""


# --------------------------------------------------------------------------------- the types
@dataclass(frozen=True)
class Episode:
    """One extracted lane change, usable or not (then with the reasons)."""

    episode_id: str
    """``<carriageway>_<vehicle>_<t_c in ms>``: unique within a recording."""
    source: str
    """The file the track was read from."""
    carriageway: str
    vehicle_id: str
    from_lane: int
    to_lane: int
    mirrored: bool
    """A change to the right, mirrored to +y."""
    t_cross: float
    """Crossing time in the source's clock [s]."""
    first_frame: float | None
    """The source frame at (just after) the window's start (None: no window)."""
    last_frame: float | None
    """The source frame at (just before) the window's end."""
    lane_width: float
    """w of the demonstration's frame: the mean width of the two lanes [m]."""
    interacting: tuple[tuple[str, str], ...]
    """(role, vehicle id) of the interacting vehicles, TV first (:data:`ROLES`)."""
    no_interaction: bool
    """No interacting vehicle: the TV is a phantom, the risk cannot be identified."""
    usable: bool
    reasons: tuple[str, ...]
    """Why not usable (empty when usable)."""
    demo: Demonstration | None
    """The demonstration (None when it could not be built)."""
    observed_until_s: float = 0.0
    """End of the observed part in the demonstration's time [s]."""
    lateral_move: float = math.nan
    """How far the vehicle moved towards the new lane across the window [m]
    (:func:`lateral_move`)."""
    flags: dict[str, Any] = field(default_factory=dict)
    """Further facts (observed samples, …)."""
    kind: str = "lane_change"
    """What the window holds (:data:`~drivestyle.recorded.kinds.EPISODE_KINDS`): a lane
    change, or a window without one (:mod:`drivestyle.recorded.windows`), whose ``to_lane``
    is the lane its frame puts at +y."""

    def __post_init__(self) -> None:
        if self.usable and (self.reasons or self.demo is None):
            raise ValueError(f"episode {self.episode_id}: usable with reasons or no demo")
        if abs(self.to_lane - self.from_lane) != 1:
            raise ValueError(f"episode {self.episode_id}: not a change to a neighbouring lane")

    @property
    def direction(self) -> str:
        """'left' (to +y) or 'right'; empty for a window without a lane change."""
        if self.kind != "lane_change":
            return ""
        return "left" if self.to_lane > self.from_lane else "right"


# -------------------------------------------------------------------------------- the frame
@dataclass(frozen=True)
class _Frame:
    """The map from a carriageway's frame to an episode's: y' = w + s (y − line), φ' = s φ."""

    line: float
    sign: float
    w: float

    def states(self, s: np.ndarray) -> np.ndarray:
        out = s.copy()
        out[:, 1] = self.w + self.sign * (s[:, 1] - self.line)
        out[:, 2] = self.sign * s[:, 2]
        return out


def _position_at(track: Track, t: float) -> tuple[float, float] | None:
    """(x, y) of a track at time t, None when it is not recorded then."""
    if not track.t[0] <= t <= track.t[-1]:
        return None
    return float(np.interp(t, track.t, track.x)), float(np.interp(t, track.t, track.y))


def interacting_vehicles(
    ev: Track, road: Carriageway, t0: float, from_lane: int, to_lane: int, range_m: float
) -> list[tuple[str, Track]]:
    """The interacting vehicles at ``t0`` as (role, track), in :data:`ROLES` order.

    Args:
        ev: the lane changer.
        road: its carriageway.
        t0: when they are chosen (the window's start) [s].
        from_lane: the origin lane (carriageway numbering).
        to_lane: the target lane.
        range_m: farthest distance along x [m].

    Returns:
        At most one vehicle per role.
    """
    here = _position_at(ev, t0)
    assert here is not None
    x_ev = here[0]
    best: dict[str, tuple[float, Track]] = {}
    for other in road.tracks:
        if other is ev or other.vehicle_id == ev.vehicle_id:
            continue
        pos = _position_at(other, t0)
        if pos is None:
            continue
        if other.lane is not None:
            lane = round(float(np.interp(t0, other.t, other.lane)))
        else:
            lane = int(road.lane_of(pos[1]))
        dx = pos[0] - x_ev
        if abs(dx) > range_m:
            continue
        role = None
        if lane == to_lane:
            role = "target_leader" if dx > 0 else "target_follower"
        elif lane == from_lane and dx > 0:
            role = "own_leader"
        if role is not None and (role not in best or abs(dx) < best[role][0]):
            best[role] = (abs(dx), other)
    return [(role, best[role][1]) for role in ROLES if role in best]


# ----------------------------------------------------------------------------- the episodes
def _gaps(
    track: Track, start: float, stop: float, max_gap_s: float
) -> list[tuple[float, float, float]]:
    """(from, to, length) [s] of each gap longer than ``max_gap_s`` meeting [start, stop]."""
    t = track.t
    k = np.flatnonzero((np.diff(t) > max_gap_s) & (t[1:] > start) & (t[:-1] < stop))
    return [(float(t[i]), float(t[i + 1]), float(t[i + 1] - t[i])) for i in k]


def _frame_near(track: Track, t: float, side: str) -> float:
    """The source frame of the first sample at/after (side 'after') or last before t."""
    if side == "after":
        k = min(int(np.searchsorted(track.t, t - 1e-9)), track.n - 1)
    else:
        k = max(int(np.searchsorted(track.t, t + 1e-9)) - 1, 0)
    return float(track.frames[k])


def _episode(
    track: Track, road: Carriageway, change: LaneChange, crossings: np.ndarray,
    config: ExtractionConfig,
) -> Episode:  # fmt: skip
    """One lane change as an :class:`Episode` (usable, or with the reasons)."""
    a, b, t_c = change.from_lane, change.to_lane, change.t_cross
    eid = f"{road.name}_{track.vehicle_id}_{round(t_c * 1000)}"
    widths = road.lane_widths
    w = float((widths[a] + widths[b]) / 2)
    line = road.markings[max(a, b)]
    # the window ends at the vehicle's previous and next change of lane (sample midpoints)
    earlier, later = crossings[crossings < change.index], crossings[crossings > change.index]
    t_prev = (track.t[earlier[-1]] + track.t[earlier[-1] + 1]) / 2 if earlier.size else -np.inf
    t_next = (track.t[later[0]] + track.t[later[0] + 1]) / 2 if later.size else np.inf
    start = max(track.t[0], t_c - config.before_s, t_prev)
    stop = min(track.t[-1], t_c + config.after_s, t_next)
    # the window ends at a gap longer than max_gap_s: a spline would invent the motion there
    steps = np.diff(track.t)
    holes = np.flatnonzero(steps > config.max_gap_s)
    across = change.index in holes
    cut_at = []
    for g in holes:
        if track.t[g + 1] <= t_c and track.t[g + 1] > start:
            start = float(track.t[g + 1])
            cut_at.append(int(g))
        elif track.t[g] >= t_c and track.t[g] < stop:
            stop = float(track.t[g])
            cut_at.append(int(g))
    common = _episode_fields(track, road, eid, a, b, t_c, start, stop)
    move = common["lateral_move"]
    # the readers' checks (recorded.track_checks): the vehicle's motion in the window is not a
    # road vehicle's; the demonstration is still built, for the plausibility's own say
    flagged = tuple(
        f"vehicle {track.vehicle_id} {p.text}" for p in track.problems if p.meets(start, stop)
    )
    reasons = []
    gap_limit = f"more than max_gap_s (--max-gap) {config.max_gap_s:g} s"
    k = change.index
    if across:
        reasons.append(
            f"no sample for {steps[k]:.3g} s across the crossing (t = {track.t[k]:g} to "
            f"{track.t[k + 1]:g} s), {gap_limit}: the lane change itself is not recorded, and a "
            "spline would invent it"
        )
    cut = "".join(
        f"; the window is cut at a {steps[g]:.3g} s gap (t = {track.t[g]:g} to "
        f"{track.t[g + 1]:g} s, {gap_limit})"
        for g in cut_at
    )
    if not across and t_c - start < config.min_before_s - 1e-9:
        reasons.append(
            f"only {t_c - start:.2f} s of track before the crossing (min_before_s "
            f"{config.min_before_s:g} s){cut if start > track.t[0] else ''}"
        )
    if not across and stop - t_c < config.min_after_s - 1e-9:
        reasons.append(
            f"only {stop - t_c:.2f} s of track after the crossing (min_after_s "
            f"{config.min_after_s:g} s){cut if stop < track.t[-1] else ''}"
        )
    need = config.min_lateral_move * w
    if config.min_lateral_move > 0 and move < need:
        share = "half" if config.min_lateral_move == 0.5 else f"{config.min_lateral_move:g} ×"
        reasons.append(
            f"moved {move:.2f} m laterally towards the new lane across the window, below the "
            f"minimum lateral move {need:.2f} m ({share} the {w:.2f} m lane width; "
            "min_lateral_move): a drift along the line or an aborted change, not a lane change"
        )
    if reasons:
        return Episode(
            **common, first_frame=None, last_frame=None, interacting=(), no_interaction=False,
            usable=False, reasons=(*flagged, *reasons), demo=None,
        )  # fmt: skip
    meta = {"kind": "lane_change", "t_cross_rel_s": t_c}
    return _built_episode(common, track, road, start, stop, line, config, flagged, meta)


def _episode_fields(
    track: Track, road: Carriageway, eid: str, a: int, b: int, t: float, start: float,
    stop: float,
) -> dict[str, Any]:  # fmt: skip
    """An :class:`Episode`'s fields of its window [start, stop] in the frame of lanes a → b.

    The frame's lane width is the mean of the two lanes'; the lateral move is towards b.
    """
    widths = road.lane_widths
    return {
        "episode_id": eid,
        "source": track.source,
        "carriageway": road.name,
        "vehicle_id": track.vehicle_id,
        "from_lane": a,
        "to_lane": b,
        "mirrored": b < a,
        "t_cross": t,
        "lane_width": float((widths[a] + widths[b]) / 2),
        "lateral_move": (1.0 if b > a else -1.0) * lateral_move(track.t, track.y, start, stop),
    }


def _built_episode(
    common: dict[str, Any], track: Track, road: Carriageway, start: float, stop: float,
    line: float, config: ExtractionConfig, flagged: tuple[str, ...], extra: dict[str, Any],
) -> Episode:  # fmt: skip
    """The demonstration of a window [start, stop] of a track in the frame of ``common``.

    ``common`` holds the episode's fields (its ``from_lane``, ``to_lane`` and ``lane_width``
    set the frame: the line between the two lanes at y = w, the ``to_lane`` side +y);
    ``extra`` the demonstration's further metadata (``kind``; ``t_cross_rel_s`` given in the
    source's clock, made relative here).
    """
    a, b, w = common["from_lane"], common["to_lane"], common["lane_width"]
    eid = common["episode_id"]
    gap_limit = f"more than max_gap_s (--max-gap) {config.max_gap_s:g} s"

    dt = config.dt
    t_grid = np.round(start + np.arange(math.floor((stop - start) / dt + 1e-9) + 1) * dt, 9)
    frame = _Frame(line, 1.0 if b > a else -1.0, w)
    ev = frame.states(_states_on(track, t_grid)[0])  # the window lies within the EV's track
    t_rel = t_grid - t_grid[0]
    observed = t_rel <= config.observe_s + 1e-9
    chosen = interacting_vehicles(track, road, float(t_grid[0]), a, b, config.interaction_range_m)
    on_grid = [_states_on(other, t_grid) for _, other in chosen]
    vehicles = [frame.states(states) for states, _ in on_grid]
    # which states are recorded samples, not the continuation beyond a track's ends
    recorded = [samples for _, samples in on_grid]
    if vehicles:
        tv, others = vehicles[0], vehicles[1:]
        tv_lane = int(np.clip(math.floor(float(tv[0, 1]) / w), 0, 2))
    else:
        tv, others = ev.copy(), []
        tv[:, 0] += PHANTOM_GAP_M
        tv[:, 1], tv[:, 2] = 1.5 * w, 0.0
        tv_lane = 1
        recorded = [np.ones(t_grid.size, bool)]  # the phantom continues no track
    first, last = _frame_near(track, start, "after"), _frame_near(track, stop, "before")
    # the interacting vehicles' problems and holes in the window make it unusable too
    flagged += tuple(
        f"interacting vehicle {other.vehicle_id} ({role}) {p.text}"
        for role, other in chosen
        for p in other.problems
        if p.meets(start, stop)
    ) + tuple(
        f"interacting vehicle {other.vehicle_id} ({role}) has no sample for {gap:.3g} s "
        f"(t = {t0:g} to {t1:g} s) inside the window, {gap_limit}: a spline would invent its "
        "motion"
        for role, other in chosen
        for t0, t1, gap in _gaps(other, start, stop, config.max_gap_s)[:1]
    )
    try:
        sc = observed_scenario(
            ev[observed], tv[0], tv_lane, w, dt, t_grid.size, track.length, track.width,
            config.v_ref, config.l_a,
        )  # fmt: skip
        meta = {
            "scenario": sc.to_dict(),
            "episode_id": eid,
            "source": track.source,
            "vehicle_id": track.vehicle_id,
            "observed_until_s": float(t_rel[observed][-1]),
            "interacting": [[role, other.vehicle_id] for role, other in chosen],
            "no_interaction": not chosen,
            "mirrored": b < a,
            "heading": "recorded" if track.heading is not None else "course",
            # what set lane_width, ev_lane and tv_lane (the plausibility messages say it)
            "lanes_from": f"the lane lines of carriageway {road.name!r}",
        }
        meta |= {
            key: round(value - float(t_grid[0]), 9) if key == "t_cross_rel_s" else value
            for key, value in extra.items()
        }
        demo = Demonstration(
            t=t_rel, ev=ev, tv=tv, u=recover_inputs(ev, sc, t_rel), meta=meta,
            others=np.stack(others, axis=1) if others else None, origin="recorded",
            observed=np.stack(recorded),
        )  # fmt: skip
    except ValueError as exc:
        return Episode(**common, first_frame=first, last_frame=last,
                       interacting=tuple((r, o.vehicle_id) for r, o in chosen),
                       no_interaction=not chosen, usable=False,
                       reasons=(*flagged, f"unusable: {exc}"), demo=None)  # fmt: skip
    problems = flagged + tuple(f"implausible: {p}" for p in plausibility_problems(demo))
    return Episode(
        **common,
        first_frame=first,
        last_frame=last,
        interacting=tuple((role, other.vehicle_id) for role, other in chosen),
        no_interaction=not chosen,
        usable=not problems,
        reasons=problems,
        demo=demo,
        observed_until_s=float(t_rel[observed][-1]),
        flags={"observed_samples": int(observed.sum())},
    )


def extract_episodes(
    recording: Recording,
    config: ExtractionConfig | None = None,
    progress: bool = False,
    all_vehicles: bool = False,
) -> list[Episode]:
    """Every lane change of a recording as an :class:`Episode` (module docstring's rules).

    Args:
        recording: tracks in the road frame (any reader).
        config: the extraction's numbers (default :class:`ExtractionConfig`).
        progress: show a progress bar over the tracks.
        all_vehicles: also every vehicle's windows without a lane change, of the same
            length, each of its kind (:func:`drivestyle.recorded.windows.vehicle_windows`),
            after the vehicle's lane changes.

    Returns:
        The episodes in carriageway, vehicle and time order; unusable ones carry their
        reasons (too little track around the crossing, an implausible demonstration).

    A T_s much finer than the data's sampling is said in a note on stderr
    (:func:`sampling_note`).

    Raises:
        ValueError: settings the recording's sampling cannot meet (:func:`check_sampling`).
    """
    config = config or ExtractionConfig()
    check_sampling(recording, config)
    note = sampling_note(recording, config)
    if note:
        print(note, file=sys.stderr, flush=True)
    items = [(road, track) for road in recording.carriageways for track in road.tracks]
    if progress:
        from tqdm import tqdm

        items = tqdm(items, desc="lane changes", unit="vehicle")
    # the windows build on this module's episodes (a module-level import would be circular)
    from drivestyle.recorded.windows import vehicle_windows

    episodes: list[Episode] = []
    for road, track in items:
        changes = find_lane_changes(track, road, config.min_stay_s)
        if changes:
            crossings = _crossings(track, road)
            episodes.extend(_episode(track, road, c, crossings, config) for c in changes)
        if all_vehicles:
            times = [c.t_cross for c in changes]
            episodes.extend(vehicle_windows(track, road, times, config))
    return episodes
