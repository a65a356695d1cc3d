"""A recorded episode as an observer knows it after t_obs: the no-leak view (DESIGN §17).

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
the future) is replaced by a phantom :data:`PHANTOM_BEHIND_M` behind. Residual leaks, in the
loader (``recorded/real_data.py``): the resampling splines are global (a state at t ≤ t_obs
moves by a decaying amount with the later recorded positions); NGSIM's lane grid is placed at
the recorded crossing; the episode's window is centred on the recorded crossing (the lane
change is known to happen).

:func:`observer_view` is the view every prediction is made in: this one of a recorded
episode, a simulated demonstration as it is.
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
    "observed_view",
    "observer_view",
]

PHANTOM_BEHIND_M = 1000.0
"""A vehicle not yet observed at t_obs is replaced by one this far behind the vehicle [m]."""


def _observed_index(demo: Demonstration, t_obs: float) -> int:
    dt = float(demo.t[1] - demo.t[0])
    return min(max(round(t_obs / dt), 0), demo.n - 2)


def _not_yet_observed(states: np.ndarray, k: int) -> bool:
    """Whether a vehicle's states 0 … k are the loader's backward continuation.

    The loader holds φ and v exactly before a vehicle's first recorded sample; recorded
    states never repeat bitwise over k + 1 samples (a vehicle first recorded at sample k
    counts as not yet observed).
    """
    head = states[: k + 1]
    return bool(np.all(head[:, 2] == head[0, 2]) and np.all(head[:, 3] == head[0, 3]))


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
    for j in range(vehicles.shape[1]):
        if _not_yet_observed(vehicles[:, j], k):
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
    )
    return out, observed


def observer_view(demo: Demonstration, t_obs: float) -> tuple[Demonstration, ScenarioConfig | None]:
    """The demonstration and scenario every prediction after ``t_obs`` is made in.

    Returns:
        :func:`observed_view` of a recorded episode; a simulated demonstration and None
        (its own scenario).
    """
    return observed_view(demo, t_obs) if is_recorded(demo) else (demo, None)
