"""What an observer has seen of a recorded episode: its observed states, its no-leak view.

DESIGN §15 (the observed mask), §17 (the view after t_obs).

:func:`observed_view` (tested by perturbing the future). After t_obs a recorded episode is
seen as: the scenario's v_ref and v_max from the observed speeds, the ellipse l_a from the
observed 90th-percentile speed (the episode's rule, rounded up to 1 m so that few solvers are
compiled); the frame shifted laterally by whole lanes so that the vehicle's current lane is
the middle one of three (the episode's frame puts its origin lane at the road's edge, on the
side away from the recorded change: the road edge would tell the direction); the target lane
the neighbouring one in the direction of the observed lateral velocity
(:func:`~drivestyle.envs.lanes.lane_change_target`), not the recorded destination; the
vehicle it reacts to first (the TV slot) the nearest observed vehicle in that lane, not the
episode's target (chosen at the recorded crossing); a vehicle not yet recorded at t_obs (the
loader continues it backwards at constant velocity from its first recorded state, i.e. from
the future; :func:`observed_mask` says which) is replaced by a phantom
:data:`PHANTOM_BEHIND_M` behind. Residual leaks, in the
loader (``recorded/real_data.py``): the resampling splines are global (a state at t ≤ t_obs
moves by a decaying amount with the later recorded positions); NGSIM's lane grid is placed at
the recorded crossing; the episode's window is centred on the recorded crossing (the lane
change is known to happen).

:func:`observer_view` is the view every prediction is made in: this one of a recorded
episode, a simulated demonstration as it is.

*Observed states* (:func:`observed_mask`).
The extraction resamples each interacting vehicle from its recorded samples where the
window overlaps its track and continues it at constant velocity before its first and
after its last recorded sample (:mod:`drivestyle.recorded.resampling`); it says which is
which in :attr:`~drivestyle.envs.demonstration.Demonstration.observed` (True: a recorded
sample). :func:`observed_mask` is what every consumer calls: that mask where the
demonstration carries one, all True for a simulated demonstration, and for a recorded one
written before the mask was carried the mask :func:`mask_from_repeats` derives — the
fallback rule, in this one function.

The fallback rule: the continuation holds the heading φ and the speed v of the edge state
exactly (bitwise), while recorded states never repeat both bitwise from one sample to the
next; so the leading samples that repeat the first state's (φ, v) are continued up to the
last of them (the first recorded sample, whose state the continuation copies), and the
trailing samples that repeat the last state's are continued after the first of them. On
every shipped episode it gives the extraction's mask exactly (tested); it would take a
vehicle standing still with a recorded heading and speed that repeat bitwise for a
continuation.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.lanes import lane_change_target, lane_index
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.recorded.episodes import speed_constants
from drivestyle.recorded.real_data import is_recorded, recorded_view

__all__ = [
    "PHANTOM_BEHIND_M",
    "mask_from_repeats",
    "observed_mask",
    "observed_view",
    "observer_view",
]

PHANTOM_BEHIND_M = 1000.0
"""A vehicle not yet observed at t_obs is replaced by one this far behind the vehicle [m]."""


def _observed_index(demo: Demonstration, t_obs: float) -> int:
    dt = float(demo.t[1] - demo.t[0])
    return min(max(round(t_obs / dt), 0), demo.n - 2)


def mask_from_repeats(vehicles: np.ndarray) -> np.ndarray:
    """The fallback rule: a vehicle's states are observed unless they repeat an edge's (φ, v).

    For each vehicle, the leading samples whose (φ, v) equal the first sample's bitwise
    are the continuation before its first recorded sample (the last of them is that
    sample); the trailing samples whose (φ, v) equal the last sample's are the
    continuation after its last recorded sample (the first of them is that sample). A
    vehicle whose (φ, v) never change is a continuation throughout (the extraction's
    vehicle recorded at most once in the window).

    Args:
        vehicles: the surrounding vehicles' states [x, y, φ, v], shape (n, m, 4)
            (:attr:`~drivestyle.envs.demonstration.Demonstration.vehicles`).

    Returns:
        True where a state is a recorded sample, shape (m, n) bool.
    """
    vehicles = np.asarray(vehicles, float)
    n, m = vehicles.shape[:2]
    mask = np.ones((m, n), bool)
    for j in range(m):
        heading_speed = vehicles[:, j, 2:4]
        as_first = np.all(heading_speed == heading_speed[0], axis=1)
        if as_first.all():
            mask[j] = False
            continue
        lead = int(np.argmin(as_first))  # samples repeating the first state
        trail = int(np.argmin(np.all(heading_speed == heading_speed[-1], axis=1)[::-1]))
        mask[j, : lead - 1] = False
        mask[j, n - trail + 1 :] = False
    return mask


def observed_mask(demo: Demonstration) -> np.ndarray:
    """Which surrounding vehicle's states are recorded samples, per sample.

    Args:
        demo: a demonstration (recorded or simulated).

    Returns:
        Shape (1 + m, n) bool, rows in ``demo.vehicles`` order (TV first): the
        demonstration's own mask where it carries one; all True for a simulated one; the
        fallback rule (:func:`mask_from_repeats`) for a recorded one without a mask (a
        file written before the mask was carried).
    """
    if demo.observed is not None:
        return demo.observed
    if demo.origin == "recorded":
        return mask_from_repeats(demo.vehicles)
    return np.ones((demo.vehicles.shape[1], demo.n), bool)


def observed_view(demo: Demonstration, t_obs: float) -> tuple[Demonstration, ScenarioConfig]:
    """A recorded episode as an observer knows it after ``t_obs`` s (module docstring).

    The episode is first seen as the driver model sees the samples 0 … k_obs
    (:func:`~drivestyle.recorded.real_data.recorded_view`: the recorded bounds where the
    observed heading needs them). The returned demonstration has the same samples (the
    truth after t_obs is still there, to score against; no method reads it), its vehicles
    reordered (the observed TV first), unobserved ones replaced by phantoms, and every
    position shifted by whole lanes laterally; the scenario is built from samples 0 …
    k_obs only.

    Args:
        demo: a recorded episode (as extracted).
        t_obs: observed time [s].

    Returns:
        (the demonstration, its scenario; ``meta["scenario"]`` is that scenario and
        ``meta["observed_shift_m"]`` the lateral shift).
    """
    k = _observed_index(demo, t_obs)
    demo = recorded_view(demo, k)
    sc = demo.scenario
    w, dt = sc.lane_width, float(demo.t[1] - demo.t[0])
    ev = demo.ev.copy()
    vehicles = demo.vehicles.copy()  # (n, 1 + m, 4), the episode's TV first
    mask = observed_mask(demo).copy()  # (1 + m, n), rows as vehicles'
    for j in range(vehicles.shape[1]):
        if not mask[j, :k].any():  # first recorded at k or later: continued from the future
            mask[j] = False  # a phantom, recorded nowhere
            vehicles[:, j, 0] = ev[0, 0] - PHANTOM_BEHIND_M + ev[0, 3] * demo.t
            vehicles[:, j, 1] = ev[0, 1]
            vehicles[:, j, 2] = 0.0
            vehicles[:, j, 3] = ev[0, 3]
    shift = w * (1.0 - math.floor(ev[k, 1] / w))
    ev[:, 1] += shift
    vehicles[..., 1] += shift
    target, _ = lane_change_target(ev[: k + 1, 1], dt, w)  # the one rule (envs.lanes)
    lane0 = min(max(math.floor(ev[0, 1] / w), 0), 2)
    ev_lane = lane0 if lane0 != target else 1
    lanes_k = lane_index(vehicles[k, :, 1], w)
    in_target = np.flatnonzero(lanes_k == target)
    pool = in_target if in_target.size else np.arange(vehicles.shape[1])
    first = int(pool[np.argmin(np.abs(vehicles[k, pool, 0] - ev[k, 0]))])
    order = [first] + [j for j in range(vehicles.shape[1]) if j != first]
    vehicles = vehicles[:, order]
    tv = vehicles[:, 0]
    v_ref, v_max, l_a = speed_constants(ev[: k + 1, 3])
    observed = replace(
        sc,
        ev_lane=ev_lane,
        target_lane=target,
        tv_lane=int(min(max(lanes_k[first], 0), 2)),
        ev_x=float(ev[0, 0]),
        ev_speed=float(ev[0, 3]),
        tv_gap=float(tv[0, 0] - ev[0, 0]),
        tv_speed=float(tv[0, 3]),
        v_ref=v_ref,
        v_max=v_max,
        l_a=float(math.ceil(l_a)),
    )
    out = Demonstration(
        t=demo.t,
        ev=ev,
        tv=tv,
        u=demo.u,
        meta={**demo.meta, "scenario": observed.to_dict(), "observed_shift_m": shift},
        others=vehicles[:, 1:] if vehicles.shape[1] > 1 else None,
        origin=demo.origin,
        observed=mask[order],
    )
    return out, observed


def observer_view(demo: Demonstration, t_obs: float) -> tuple[Demonstration, ScenarioConfig | None]:
    """The demonstration and scenario every prediction after ``t_obs`` is made in.

    Returns:
        :func:`observed_view` of a recorded episode; a simulated demonstration and None
        (its own scenario).
    """
    return observed_view(demo, t_obs) if is_recorded(demo) else (demo, None)
