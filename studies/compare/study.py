"""Compare ways of driving a learned style.

The three: the SMPC demonstration it came from, the spline-optimised reproduction r*_θ,
and an RL policy trained on the learned reward. On held-out scenarios
(:func:`heldout_comparison`) also the default style model's closed-loop reproduction
(:func:`drivestyle.irl.driver.driver_style.reproduce`, method ``style``).

All trajectories are scored the same way: control points at the demonstration's sample
times (by the style's control-point rule for sampled states, the spline's own for r*_θ)
and the features evaluated with the demonstration's event times and TV, so θᵀf, the
feature error and the trajectory errors are directly comparable. Without a paper-model
style (only a driver style) every method is scored by :func:`state_metrics` (positions at
the samples; no θᵀf).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.lane_change import LaneChangeEnv
from drivestyle.envs.rollout import Policy, run_episode
from drivestyle.envs.safety import ellipse_constraint, rectangles_overlap, vehicle_corners
from drivestyle.envs.traffic import TrafficEnv, TrafficScene
from drivestyle.irl.driver.driver_style import DriverStyle, reproduce
from drivestyle.irl.metrics import trajectory_errors
from drivestyle.irl.paper.features import feature_basis, feature_values
from drivestyle.irl.paper.inner import InnerProblem
from drivestyle.irl.paper.spline import demo_control_points, spline_eval
from drivestyle.irl.paper.style import Style

__all__ = [
    "LABELS",
    "Comparison",
    "HeldoutComparison",
    "HeldoutSummary",
    "compare_methods",
    "heldout_comparison",
    "policy_frames",
    "rollout_policy",
    "state_metrics",
    "trajectory_metrics",
]

LABELS = {
    "smpc": "SMPC demonstration",
    "style": "driver style (receding horizon)",
    "spline": "spline reproduction r*_θ",
    "sb3": "SB3 policy",
}
"""Display name per compared method."""


@dataclass(frozen=True)
class Comparison:
    """The methods driving one learned style in its demonstration's scenario.

    Attributes:
        methods: method name ('smpc', 'spline', 'sb3') → JSON-ready metrics of
            :func:`trajectory_metrics` plus ``compute`` and ``compute_time_s``.
        trajectories: method name → control points at the demonstration's samples.
    """

    methods: dict[str, dict[str, Any]]
    trajectories: dict[str, np.ndarray]

    def to_json(self) -> dict[str, Any]:
        """``compare.json``'s study keys: ``methods``."""
        return {"methods": self.methods}


@dataclass(frozen=True)
class HeldoutSummary:
    """One method over the held-out scenarios (``heldout.json``'s ``summary`` entry)."""

    median_rmse_y_m: float | None
    collisions: int
    median_cost: float | None
    decision_ms: float | None
    min_d_k: float
    n: int
    median_rmse_xy_m: float | None = None
    """Median rmse_xy against SMPC(p) [m]."""
    enters_ellipse: int = 0
    """Scenarios where the method enters the nominal ellipse (min d_k < 0) and the SMPC
    demonstration does not."""

    def to_json(self) -> dict[str, Any]:
        """The entry's keys."""
        return asdict(self)


@dataclass(frozen=True)
class HeldoutComparison:
    """SMPC(p), the driver style, the spline reproduction and SB3 policies on held-out scenarios.

    Attributes:
        per_scenario: per scenario, ``scenario`` (its parameters) and ``methods``
            (method name → metrics with ``decision_ms``).
        summary: method name → its summary; the first is the SMPC (the reference).
    """

    per_scenario: list[dict[str, Any]]
    summary: dict[str, HeldoutSummary]

    def to_json(self) -> dict[str, Any]:
        """``heldout.json``'s study keys: ``per_scenario`` and ``summary``."""
        return {
            "per_scenario": self.per_scenario,
            "summary": {name: s.to_json() for name, s in self.summary.items()},
        }


def policy_frames(
    kind: str,
    scenario: Any,
    risk: float = 0.7,
    style: Style | None = None,
    demo: Demonstration | None = None,
    model: str | Path | None = None,
    seed: int = 0,
) -> list[np.ndarray]:
    """Rendered frames of one episode driven by the expert, the spline or an SB3 policy.

    The spline reproduction is replayed state by state.

    Args:
        kind: 'expert', 'spline' or 'sb3'.
        scenario: scenario of the episode, or a :class:`drivestyle.envs.traffic.TrafficScene`
            (expert and sb3 only).
        risk: SMPC risk (expert).
        style: learned style (spline).
        demo: the style's demonstration (spline).
        model: train_baseline output folder (sb3).
        seed: reset seed.

    Returns:
        RGB frames (reset frame first).
    """
    from drivestyle.envs.video import record_policy, record_states

    traffic = isinstance(scenario, TrafficScene)
    if traffic and kind == "spline":
        raise ValueError("the spline replay is single-TV only; use --policy expert in traffic")
    env: LaneChangeEnv  # a TrafficEnv in traffic
    if traffic:
        env = TrafficEnv(scenario, render_mode="rgb_array")
    else:
        env = LaneChangeEnv(scenario=scenario, render_mode="rgb_array")
    try:
        if kind == "expert":
            from drivestyle.agents.demo_generation import TRAFFIC_VEHICLES
            from drivestyle.agents.smpc import SMPCConfig, SMPCExpert

            vehicles = TRAFFIC_VEHICLES if traffic else 1
            expert = SMPCExpert(SMPCConfig(risk=risk, max_vehicles=vehicles), env.scenario)
            return record_policy(env, lambda e, o: expert.act(o), seed)[0]
        if kind == "sb3":
            if model is None:
                raise ValueError("the sb3 policy needs a model folder")
            from drivestyle.agents.sb3_baseline import SB3Policy

            return record_policy(env, SB3Policy(model).act, seed)[0]
        if kind == "spline":
            if style is None or demo is None:
                raise ValueError("the spline reproduction needs a style and its demonstration")
            C = (
                InnerProblem(demo, style.features, style.control_point_rule)
                .solve(style.theta)
                .control_points
            )
            vel = spline_eval(C, demo.t, demo.t, 1)
            ev = np.column_stack(
                [C[:, 0], C[:, 3], np.arctan2(vel[:, 1], vel[:, 0]), np.hypot(vel[:, 0], vel[:, 1])]
            )
            return record_states(env, ev, demo.tv)
        raise ValueError(f"unknown policy kind {kind!r}; choose expert, spline or sb3")
    finally:
        env.close()


def rollout_policy(policy: Policy, demo: Demonstration) -> tuple[Demonstration, float]:
    """Roll a policy out in the demonstration's scenario.

    The loop is :func:`drivestyle.envs.rollout.run_episode`.

    Args:
        policy: (env, raw observation) → [a, δ].
        demo: the reference demonstration (its scenario and horizon).

    Returns:
        The rollout as a demonstration (possibly shorter on a crash) and its wall time [s].
    """
    env = LaneChangeEnv(scenario=demo.scenario)
    t0 = time.perf_counter()
    episode = run_episode(env, policy, seed=0)
    wall = time.perf_counter() - t0
    obs, inputs = episode.observations, episode.inputs
    if len(obs) < 3:  # crashed at once: pad so the (flagged) rollout stays representable
        pad = 3 - len(obs)
        obs = np.vstack([obs, np.repeat(obs[-1:], pad, axis=0)])
        inputs = np.vstack([inputs, np.repeat(inputs[-1:], pad, axis=0)])
    out = Demonstration(
        t=np.arange(len(obs)) * demo.scenario.dt,
        ev=obs[:, :4],
        tv=obs[:, 4:8],
        u=inputs,
        meta=dict(demo.meta),
    )
    return out, wall


def trajectory_metrics(
    C: np.ndarray, demo: Demonstration, style: Style, C_demo: np.ndarray
) -> dict[str, Any]:
    """Learned cost, feature error, trajectory errors and safety of one trajectory.

    Args:
        C: control points at the demonstration's samples, shape (n, 6) (n may be shorter
            after a crash; costs are then not comparable and reported as None).
        demo: the reference demonstration.
        style: the learned style.
        C_demo: the demonstration's control points.

    Returns:
        JSON-ready metrics.
    """
    sc = demo.scenario
    n = C.shape[0]
    complete = n == demo.n
    out: dict[str, Any] = {"complete": complete, "n_samples": n}
    if complete:
        basis = feature_basis(demo, style.features)
        f = feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), basis, names=style.names)
        f_d = feature_values(C_demo[:, :3].ravel(), C_demo[:, 3:].ravel(), basis, names=style.names)
        out |= {
            "learned_cost": float(style.theta @ f),
            "feature_error": float(np.linalg.norm(f - f_d)),
            "features": f.tolist(),
        }
        events = basis.events
        out |= trajectory_errors(C[:, [0, 3]], demo, events.t_trg, events.t_rct_end)
    else:
        out |= {
            "learned_cost": None,
            "feature_error": None,
            "rmse_y_m": None,
            "rmse_xy_m": None,
            "rmse_y_reaction_m": None,
            "fde_m": None,
        }
    tv = demo.tv[:n]
    d_k = ellipse_constraint(C[:, 0] - tv[:, 0], C[:, 3] - tv[:, 1], sc.l_a, sc.l_b)
    heading = np.arctan2(C[:, 4], C[:, 1])
    crash = any(
        rectangles_overlap(
            vehicle_corners([C[i, 0], C[i, 3], heading[i]], sc.vehicle_length, sc.vehicle_width),
            vehicle_corners(tv[i], sc.vehicle_length, sc.vehicle_width),
        )
        for i in range(n)
    )
    off_road = bool(np.any((C[:, 3] < 0) | (C[:, 3] > sc.road_width)))
    out |= {"min_d_k": float(d_k.min()), "collision": bool(crash), "off_road": off_road}
    return out


def state_metrics(ev: np.ndarray, demo: Demonstration) -> dict[str, Any]:
    """Trajectory errors and safety of sampled EV states (no paper-model style needed).

    Args:
        ev: EV states [x, y, φ, v] at the demonstration's samples, shape (n, 4) (n may
            be shorter after a crash; the errors are then None).
        demo: the reference demonstration (its vehicles and scenario).

    Returns:
        JSON-ready metrics with :func:`trajectory_metrics`'s keys (``learned_cost`` and
        ``feature_error`` None); min d_k, collision and off-road against every vehicle.
    """
    sc = demo.scenario
    ev = np.asarray(ev, float)
    n = ev.shape[0]
    complete = n == demo.n
    out: dict[str, Any] = {"complete": complete, "n_samples": n}
    out |= {"learned_cost": None, "feature_error": None}
    if complete:
        out |= trajectory_errors(ev[:, :2], demo)
    else:
        out |= dict.fromkeys(("rmse_y_m", "rmse_xy_m", "rmse_y_reaction_m", "fde_m"))
    vehicles = demo.vehicles[:n]
    d_k = ellipse_constraint(
        ev[:, None, 0] - vehicles[..., 0], ev[:, None, 1] - vehicles[..., 1], sc.l_a, sc.l_b
    )
    size = (sc.vehicle_length, sc.vehicle_width)
    crash = any(
        rectangles_overlap(vehicle_corners(ev[i], *size), vehicle_corners(vehicles[i, j], *size))
        for i in range(n)
        for j in range(vehicles.shape[1])
    )
    off_road = bool(np.any((ev[:, 1] < 0) | (ev[:, 1] > sc.road_width)))
    out |= {"min_d_k": float(d_k.min()), "collision": bool(crash), "off_road": off_road}
    return out


def compare_methods(
    style: Style,
    demo: Demonstration,
    smpc_solve_s: float | None = None,
    sb3_folder: str | Path | None = None,
) -> Comparison:
    """Score the SMPC demonstration, the spline reproduction and (optionally) an SB3 policy.

    Args:
        style: the learned style.
        demo: its demonstration (the SMPC's closed loop).
        smpc_solve_s: total SMPC solve time of that closed loop [s], if known.
        sb3_folder: a :func:`drivestyle.agents.sb3_baseline.train_baseline` output folder.

    Returns:
        The comparison (metrics and control points per method).
    """
    C_demo = demo_control_points(demo, style.control_point_rule)
    methods: dict[str, Any] = {}
    trajectories: dict[str, np.ndarray] = {"smpc": C_demo}
    methods["smpc"] = trajectory_metrics(C_demo, demo, style, C_demo) | {
        "compute": "SMPC closed loop (solver time)",
        "compute_time_s": smpc_solve_s,
    }

    t0 = time.perf_counter()
    inner = InnerProblem(demo, style.features, style.control_point_rule)
    build_s = time.perf_counter() - t0
    sol = inner.solve(style.theta)
    trajectories["spline"] = sol.control_points
    methods["spline"] = trajectory_metrics(sol.control_points, demo, style, C_demo) | {
        "compute": "inner problem (build + solve)",
        "compute_time_s": build_s + sol.solve_ms / 1e3,
        "solve_ms": sol.solve_ms,
    }

    if sb3_folder is not None:
        from drivestyle.agents.sb3_baseline import SB3Policy

        policy = SB3Policy(sb3_folder)
        rollout, wall = rollout_policy(policy.act, demo)
        C = demo_control_points(replace(rollout, meta=dict(demo.meta)), style.control_point_rule)
        trajectories["sb3"] = C
        methods["sb3"] = trajectory_metrics(C, demo, style, C_demo) | {
            "compute": f"{policy.summary['algo'].upper()} training "
            f"({policy.summary['timesteps']} steps)",
            "compute_time_s": policy.summary["train_time_s"],
            "rollout_s": wall,
            "algo": policy.summary["algo"],
            "timesteps": policy.summary["timesteps"],
        }
    return Comparison(methods, trajectories)


def heldout_comparison(
    style: Style | None,
    models: dict[str, str | Path],
    k: int,
    seed: int,
    risk: float,
    progress: Callable[[int], Any] | None = None,
    driver: DriverStyle | None = None,
) -> HeldoutComparison:
    """SMPC(p), the driver style, the spline reproduction and SB3 policies on K scenarios.

    In each scenario drawn from :class:`drivestyle.envs.scenario.ScenarioRanges` with ``seed``, the
    SMPC(p) demonstration is the reference; the driver style (``style``) re-plans in closed
    loop against the recorded TV (:func:`drivestyle.irl.driver.driver_style.reproduce`); the spline
    reproduction r*_θ is planned in that scenario (open loop); each SB3 policy drives it in
    closed loop. Per method: the learned cost θᵀf (paper style only), rmse_y and rmse_xy
    against SMPC(p), min d_k, collisions, entries into the ellipse the SMPC did not enter and
    the compute per decision (SMPC: solver time per step; style: one re-plan; spline: one
    plan; SB3: one forward pass).

    Args:
        style: the paper-model style (its θ, features and control-point rule), or None.
        models: method name → :func:`drivestyle.agents.sb3_baseline.train_baseline` output folder.
        k: held-out scenarios (≥ 1).
        seed: their seed (disjoint from training).
        risk: the demonstrator's risk p.
        progress: called with 1 after each scenario.
        driver: the default model's driver style (method ``style``), or None.

    Returns:
        The per-scenario metrics and a summary per method.

    Raises:
        ValueError: k < 1, or neither a paper style nor a driver style.
    """
    from drivestyle.agents.demo_generation import generate_demonstration
    from drivestyle.agents.sb3_baseline import SB3Policy
    from drivestyle.envs.scenario import ScenarioRanges

    if k < 1:
        raise ValueError(f"need at least one held-out scenario, got {k}")
    if style is None and driver is None:
        raise ValueError("the held-out comparison needs a driver style or a paper-model style")
    policies = {name: SB3Policy(folder) for name, folder in models.items()}
    rng = np.random.default_rng(seed)
    per_scenario: list[dict[str, Any]] = []
    for _ in range(k):
        scenario = ScenarioRanges().sample(rng)
        demo, summary = generate_demonstration(risk, scenario)
        C_demo = None if style is None else demo_control_points(demo, style.control_point_rule)

        def sampled(ev: np.ndarray, inputs: np.ndarray, demo=demo, C_demo=C_demo) -> dict[str, Any]:
            """Metrics of sampled states: through the paper style's features if any."""
            if style is None or C_demo is None:
                return state_metrics(ev, demo)
            n = ev.shape[0]
            run = Demonstration(
                t=demo.t[:n], ev=ev, tv=demo.tv[:n], u=inputs[: n - 1], meta=dict(demo.meta)
            )
            C = demo_control_points(run, style.control_point_rule)
            return trajectory_metrics(C, demo, style, C_demo)

        rows = {"smpc": sampled(demo.ev, demo.u) | {"decision_ms": summary["solve_ms_median"]}}
        if driver is not None:
            t0 = time.perf_counter()
            rep = reproduce(driver, demo)
            ms = (time.perf_counter() - t0) * 1e3 / max(demo.n - 1, 1)
            rows["style"] = sampled(rep.states, rep.inputs) | {
                "decision_ms": ms,
                "solve_failures": rep.failures,
            }
        if style is not None and C_demo is not None:
            inner = InnerProblem(demo, style.features, style.control_point_rule)
            sol = inner.solve(style.theta)
            rows["spline"] = trajectory_metrics(sol.control_points, demo, style, C_demo) | {
                "decision_ms": sol.solve_ms
            }
        for name, policy in policies.items():
            times: list[float] = []

            def timed(env: Any, obs: np.ndarray, act=policy.act, times=times) -> np.ndarray:
                t0 = time.perf_counter()
                u = act(env, obs)
                times.append((time.perf_counter() - t0) * 1e3)
                return u

            rollout, _ = rollout_policy(timed, demo)
            rows[name] = sampled(rollout.ev, rollout.u) | {
                "decision_ms": float(np.median(times)) if times else None
            }
        per_scenario.append({"scenario": scenario.to_dict(), "methods": rows})
        if progress is not None:
            progress(1)

    def median(values: list) -> float | None:
        values = [v for v in values if v is not None]
        return float(np.median(values)) if values else None

    names = list(per_scenario[0]["methods"])
    summary = {
        name: HeldoutSummary(
            median_rmse_y_m=median([s["methods"][name]["rmse_y_m"] for s in per_scenario]),
            collisions=sum(s["methods"][name]["collision"] for s in per_scenario),
            median_cost=median([s["methods"][name]["learned_cost"] for s in per_scenario]),
            decision_ms=median([s["methods"][name]["decision_ms"] for s in per_scenario]),
            min_d_k=min(s["methods"][name]["min_d_k"] for s in per_scenario),
            n=len(per_scenario),
            median_rmse_xy_m=median([s["methods"][name]["rmse_xy_m"] for s in per_scenario]),
            enters_ellipse=sum(
                s["methods"][name]["min_d_k"] < 0 <= s["methods"]["smpc"]["min_d_k"]
                for s in per_scenario
            ),
        )
        for name in names
    }
    return HeldoutComparison(per_scenario, summary)
