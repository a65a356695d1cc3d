"""An episode's scenario from its observed part only (the loaders' rule, DESIGN §10).

:func:`observed_scenario` estimates every scenario constant of a recorded episode from the
window's first ``observe_s`` seconds (nothing after them enters it, so a prediction made at
their end is not told the future); :func:`speed_constants` is the speed rule it and the
observer's view share.
"""

from __future__ import annotations

import numpy as np

from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.units import ROAD_SPEED_MAX_MPS

__all__ = [
    "observed_scenario",
    "speed_constants",
]


def speed_constants(speeds: np.ndarray) -> tuple[float, float, float]:
    """The scenario constants a vehicle's observed speeds give (DESIGN §10).

    Args:
        speeds: the EV's observed speeds, shape (k,) [m/s].

    Returns:
        (v̄, v_max, l_a): the speed level v̄ = the 90th percentile (≥ 1 m/s), the desired
        speed when none is known [m/s]; v_max = the fixed bound of every road vehicle,
        :data:`~drivestyle.envs.units.ROAD_SPEED_MAX_MPS` (70 m/s), never one the data
        raises — a speed beyond it is a unit slip, and :func:`plausibility_problems` says
        so [m/s]; the speed-scaled ellipse l_a = max(5 m, 15 m · v̄ / 27.5 m/s).
    """
    level = float(np.percentile(speeds, 90))
    return max(level, 1.0), ROAD_SPEED_MAX_MPS, max(5.0, 15.0 * level / 27.5)


def observed_scenario(
    ev_observed: np.ndarray,
    tv0: np.ndarray,
    tv_lane: int,
    lane_width: float,
    dt: float,
    n: int,
    length: float,
    width: float,
    v_ref: float | None = None,
    l_a: float | None = None,
) -> ScenarioConfig:
    """An episode's scenario from its observed part only (the loaders' rule, DESIGN §10).

    Lane width from the markings; the speed level v̄ = the 90th percentile of the observed
    EV speeds; v_ref = ``v_ref`` if known, else v̄ (≥ 1 m/s); the ellipse l_a = max(5 m,
    15 m · v̄ / 27.5 m/s), l_b = 3 m · w / 5.25 m; v_max = 70 m/s, the bound of every road
    vehicle (:func:`speed_constants`); l_f = l_r = 0.4 · length; initial states from the
    first sample (the speed clamped to [0, v_max]: a faster EV is refused by the
    plausibility check, which names the speed).

    Args:
        ev_observed: EV states of the observed part, shape (k, 4), k ≥ 1.
        tv0: the TV's first state, shape (4,).
        tv_lane: the TV's lane in the episode's frame.
        lane_width: w [m].
        dt: T_s [s].
        n: samples of the whole episode.
        length: EV length [m].
        width: EV width [m].
        v_ref: known desired speed [m/s], or None.
        l_a: known semi-major axis of the ellipse [m], or None.

    Returns:
        The scenario (start-inside-ellipse check off: recorded traffic may start closer).
    """
    v_level, v_max, l_a_rule = speed_constants(ev_observed[:, 3])
    return ScenarioConfig(
        lane_width=lane_width,
        n_lanes=3,
        vehicle_length=length,
        vehicle_width=min(width, 0.9 * lane_width),
        l_f=0.4 * length,
        l_r=0.4 * length,
        v_max=v_max,
        ev_lane=0,
        target_lane=1,
        tv_lane=tv_lane,
        ev_x=float(ev_observed[0, 0]),
        ev_speed=min(max(float(ev_observed[0, 3]), 0.0), v_max),
        tv_gap=float(tv0[0] - ev_observed[0, 0]),
        tv_speed=max(float(tv0[3]), 0.0),
        v_ref=v_ref if v_ref is not None else v_level,
        dt=dt,
        horizon_s=round((n - 1) * dt, 9),
        l_a=l_a if l_a is not None else l_a_rule,
        l_b=3.0 * lane_width / 5.25,
        check_start=False,
    )
