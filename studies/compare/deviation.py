"""When the TV deviates from its prediction: closed-loop control against open-loop plans.

Every planner here predicts the TV at constant velocity. In the deviating episode
(:class:`drivestyle.envs.lane_change.TVDeviation`: by default the TV brakes at 4 m/s² from t = 1.5 s
for 1.5 s) four drivers of the same style are compared:

- ``smpc``: the SMPC expert, re-planning every step (the demonstrator);
- ``policy``: an SB3 policy trained on the style's reward, closed loop;
- ``spline_open_loop``: r*_θ planned once at t = 0 for the nominal (constant-velocity) TV
  and executed as planned;
- ``spline_receding``: r*_θ re-planned every ``replan_every`` steps from the EV's current
  state, with the TV's current state extrapolated at constant velocity over the rest of
  the horizon (event times and warm start from the previous plan); its next
  ``replan_every`` samples are executed. A re-plan that fails keeps the previous plan.

Measures per driver: collision with the (deviating) TV, min d_k, rmse_y against the SMPC
in the same deviating episode.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import rollout_expert
from drivestyle.agents.smpc import SMPCConfig, SMPCExpert
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.lane_change import LaneChangeEnv, TVDeviation
from drivestyle.envs.rollout import run_episode
from drivestyle.envs.safety import ellipse_constraint, rectangles_overlap, vehicle_corners
from drivestyle.envs.scenario import ScenarioConfig, get_scenario
from drivestyle.irl.paper.inner import InnerProblem, InnerSolveError
from drivestyle.irl.paper.style import Style

__all__ = ["DeviationStudy", "DriverMeasures", "deviating_tv_study", "plan_states", "write_videos"]


@dataclass(frozen=True)
class DriverMeasures:
    """One driver in the deviating episode (``deviation.json``'s ``methods`` entry).

    Attributes:
        collision: its vehicle box overlapped the deviating TV's.
        min_d_k: least ellipse-constraint value d_k over the episode.
        rmse_y_vs_smpc_m: RMS lateral distance to the SMPC's path [m].
        n_samples: samples compared.
    """

    collision: bool
    min_d_k: float
    rmse_y_vs_smpc_m: float
    n_samples: int

    def to_json(self) -> dict[str, Any]:
        """The entry's keys."""
        return asdict(self)


@dataclass(frozen=True)
class DeviationStudy:
    """The four drivers (module docstring) in one deviating episode.

    Attributes:
        deviation: the TV's deviation.
        replan_every: samples between re-plans of the receding-horizon spline.
        methods: driver name → its measures.
        ev: driver name → EV states per sample.
        tv: the deviating TV's states per sample.
    """

    deviation: TVDeviation
    replan_every: int
    methods: dict[str, DriverMeasures]
    ev: dict[str, np.ndarray]
    tv: np.ndarray

    def to_json(self) -> dict[str, Any]:
        """``deviation.json``'s study keys: ``deviation``, ``replan_every``, ``methods``."""
        return {
            "deviation": asdict(self.deviation),
            "replan_every": self.replan_every,
            "methods": {name: m.to_json() for name, m in self.methods.items()},
        }


def plan_states(C: np.ndarray) -> np.ndarray:
    """EV states [x, y, φ, v] at the knots of a spline plan (heading along the velocity)."""
    return np.column_stack(
        [C[:, 0], C[:, 3], np.arctan2(C[:, 4], C[:, 1]), np.hypot(C[:, 1], C[:, 4])]
    )


def _tv_path(sc: ScenarioConfig, deviation: TVDeviation) -> np.ndarray:
    """The deviating TV's states over the episode (independent of the EV)."""
    env = LaneChangeEnv(scenario=sc, tv_deviation=deviation)
    env.reset(seed=0)
    path = [env.tv.copy()]
    for _ in range(sc.n_steps):
        env._advance_others()
        env.k += 1
        path.append(env.tv.copy())
    return np.array(path)


def _measures(
    ev: np.ndarray, tv: np.ndarray, ref: np.ndarray, sc: ScenarioConfig
) -> DriverMeasures:
    n = min(len(ev), len(tv))
    ev, tv = ev[:n], tv[:n]
    d_k = ellipse_constraint(ev[:, 0] - tv[:, 0], ev[:, 1] - tv[:, 1], sc.l_a, sc.l_b)
    crash = any(
        rectangles_overlap(
            vehicle_corners(e, sc.vehicle_length, sc.vehicle_width),
            vehicle_corners(t, sc.vehicle_length, sc.vehicle_width),
        )
        for e, t in zip(ev, tv, strict=True)
    )
    m = min(n, len(ref))
    return DriverMeasures(
        collision=bool(crash),
        min_d_k=float(d_k.min()),
        rmse_y_vs_smpc_m=float(np.sqrt(np.mean((ev[:m, 1] - ref[:m, 1]) ** 2))),
        n_samples=n,
    )


def _replan(
    style: Style,
    t: np.ndarray,
    k: int,
    ev_now: np.ndarray,
    plan: np.ndarray,
    tv_now: np.ndarray,
    sc: ScenarioConfig,
) -> np.ndarray | None:
    """A new plan from sample k to the end (None if it cannot be made)."""
    rest = t[k:] - t[k]
    if rest.size < 3:
        return None
    tv_pred = np.column_stack(
        [
            tv_now[0] + tv_now[3] * np.cos(tv_now[2]) * rest,
            tv_now[1] + tv_now[3] * np.sin(tv_now[2]) * rest,
            np.full_like(rest, tv_now[2]),
            np.full_like(rest, tv_now[3]),
        ]
    )
    ev_guess = np.vstack([ev_now, plan[k + 1 :]])
    horizon = dict(sc.to_dict(), horizon_s=float(rest[-1]), ev_x=float(ev_now[0]))
    try:
        demo = Demonstration(
            rest, ev_guess, tv_pred, np.zeros((rest.size - 1, 2)), {"scenario": horizon}
        )
        sol = InnerProblem(demo, style.features, style.control_point_rule).solve(style.theta)
    except (ValueError, InnerSolveError):
        return None
    return plan_states(sol.control_points)


def deviating_tv_study(
    style: Style,
    nominal: Demonstration,
    deviation: TVDeviation,
    policy: Any = None,
    replan_every: int = 5,
    risk: float = 0.7,
) -> DeviationStudy:
    """Run the four drivers (module docstring) in one deviating episode.

    Args:
        style: the learned style (its θ).
        nominal: the SMPC demonstration of the nominal scenario (the open-loop plan's
            knots, event times and warm start).
        deviation: the TV's deviation.
        policy: an SB3 policy's ``act`` (env, obs) → [a, δ], or None.
        replan_every: samples between re-plans of the receding-horizon spline (≥ 1).
        risk: the SMPC's risk.

    Returns:
        The measures per driver, the EV states per driver and the TV's states.
    """
    if replan_every < 1:
        raise ValueError(f"replan_every must be >= 1, got {replan_every}")
    sc = nominal.scenario
    tv = _tv_path(sc, deviation)
    ev: dict[str, np.ndarray] = {}
    env = LaneChangeEnv(scenario=sc, tv_deviation=deviation)
    smpc_demo, _ = rollout_expert(env, SMPCExpert(SMPCConfig(risk=risk), sc), seed=0)
    ev["smpc"] = smpc_demo.ev
    if policy is not None:
        ev["policy"] = run_episode(env, policy, seed=0).observations[:, :4]
    C = InnerProblem(nominal, style.features, style.control_point_rule).solve(style.theta)
    open_loop = plan_states(C.control_points)
    ev["spline_open_loop"] = open_loop
    plan, executed = open_loop.copy(), [open_loop[0]]
    t = nominal.t
    for k in range(1, nominal.n):
        if k % replan_every == 0:
            new = _replan(style, t, k - 1, executed[-1], plan, tv[k - 1], sc)
            if new is not None:
                plan = np.vstack([plan[: k - 1], new])
        executed.append(plan[k])
    ev["spline_receding"] = np.array(executed)
    methods = {name: _measures(states, tv, smpc_demo.ev, sc) for name, states in ev.items()}
    return DeviationStudy(deviation, replan_every, methods, ev, tv)


def write_videos(result: DeviationStudy, scenario: Any, folder: str | Path) -> dict[str, str]:
    """A gif per driver of the deviating episode (EV states replayed beside the TV's)."""
    from drivestyle.envs.video import record_states, write_video

    sc = get_scenario(scenario)
    out = {}
    env = LaneChangeEnv(scenario=sc, render_mode="rgb_array")
    try:
        for name, states in result.ev.items():
            n = min(len(states), len(result.tv))
            frames = record_states(env, states[:n], result.tv[:n])
            out[name] = str(write_video(frames, Path(folder) / f"deviating_{name}.gif"))
    finally:
        env.close()
    return out
