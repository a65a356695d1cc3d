"""Closed-loop rollouts of the SMPC expert in the env: demonstrations and their summary.

Also the scenario draws and the (parallel) demonstration batches that style libraries
are learned from: a scenario of the ``LaneChangeRandom`` family is *interactive* when the
SMPC at the probe risk (default: the lowest p) enters the λ-ellipse, i.e. the trigger
fires. The same interactive scenarios serve every risk level, so styles differ only by p.
"""

from __future__ import annotations

import platform
from collections.abc import Callable, Sequence
from dataclasses import asdict, replace
from typing import Any

import gymnasium as gym
import numpy as np

from drivestyle.agents.smpc import SMPCConfig, SMPCExpert
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.lane_change import LaneChangeEnv
from drivestyle.envs.rollout import run_episode
from drivestyle.envs.safety import ellipse_constraint, elliptical_index, trigger_time
from drivestyle.envs.scenario import ScenarioConfig, ScenarioRanges, get_scenario
from drivestyle.envs.traffic import TrafficEnv, TrafficRanges, TrafficScene

__all__ = [
    "demo_summary",
    "draw_interactive_scenarios",
    "generate_demonstration",
    "generate_demonstrations",
    "generate_traffic_demonstration",
    "rollout_expert",
    "smpc_robustness",
]


def rollout_expert(
    env: gym.Env,
    expert: SMPCExpert,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    progress: bool = False,
) -> tuple[Demonstration, list[dict[str, Any]]]:
    """Run the expert in closed loop on ``env`` for one episode.

    The loop is :func:`drivestyle.envs.rollout.run_episode`.

    Args:
        env: a drivestyle env (possibly wrapped).
        expert: the SMPC expert; it is reset to the episode's scenario.
        seed: reset seed.
        options: reset options (e.g. ``{"scenario": cfg}``).
        progress: show a progress bar.

    Returns:
        The demonstration (states from the observations, inputs as applied) and one
        record per step with the solver report and the env's info.
    """
    solves: list[dict[str, Any]] = []

    def policy(_env: gym.Env, obs: np.ndarray) -> np.ndarray:
        decision = expert.plan(obs)
        solves.append(decision.report.info())
        return decision.action

    episode = run_episode(
        env,
        policy,
        seed,
        options,
        on_reset=lambda info: expert.reset(info["scenario"]),
        progress="SMPC closed loop" if progress else None,
    )
    steps = [
        {**solve, "collision": bool(info["collision"]), "off_road": bool(info["off_road"])}
        for solve, info in zip(solves, episode.infos, strict=True)
    ]
    demo = episode.to_demonstration(
        {"risk": expert.config.risk, "smpc": _config_dict(expert.config)}
    )
    return demo, steps


def _config_dict(cfg: SMPCConfig) -> dict[str, Any]:
    d = asdict(cfg)
    d["kappa"] = cfg.kappa
    return d


def demo_summary(demo: Demonstration, steps: list[dict[str, Any]]) -> dict[str, Any]:
    """Summary numbers of a demonstration (the ``demo.json`` fields, docs/DESIGN.md §7).

    Args:
        demo: the demonstration (with ``meta["scenario"]``).
        steps: per-step records from :func:`rollout_expert`.

    Returns:
        JSON-ready dict: risk, t_trg_s (None if the trigger never fires), min_s_e and where,
        min_d_k (nominal ellipse), collision, off_road, solver statistics, lane-change
        timing and the final state.
    """
    sc = demo.scenario
    veh = demo.vehicles  # TV first; traffic: every vehicle, the least margin counts
    dx, dy = demo.ev[:, None, 0] - veh[:, :, 0], demo.ev[:, None, 1] - veh[:, :, 1]
    s_e = elliptical_index(dx, dy, sc.l_a, sc.l_b).min(axis=1)
    d_k = ellipse_constraint(dx, dy, sc.l_a, sc.l_b).min(axis=1)
    t_trg = trigger_time(demo.t, s_e, sc.trigger_lambda)
    ms = np.array([s["solve_ms"] for s in steps])
    if sc.target_lane > sc.ev_lane:  # entering the target lane across its near edge
        entered = np.flatnonzero(demo.ev[:, 1] > sc.lane_width * sc.target_lane)
    else:
        entered = np.flatnonzero(demo.ev[:, 1] < sc.lane_width * (sc.target_lane + 1))
    final_lane = int(np.clip(demo.ev[-1, 1] // sc.lane_width, 0, sc.n_lanes - 1))
    return {
        "risk": demo.meta.get("risk"),
        "t_trg_s": t_trg,
        "trigger_fired": t_trg is not None,
        "min_s_e": float(s_e.min()),
        "x_at_min_s_e": float(demo.ev[int(np.argmin(s_e)), 0]),
        "min_d_k": float(d_k.min()),
        "collision": any(s["collision"] for s in steps),
        "off_road": any(s["off_road"] for s in steps),
        "solve_ms_median": float(np.median(ms)) if ms.size else None,
        "solve_ms_p95": float(np.percentile(ms, 95)) if ms.size else None,
        "solve_ms_total": float(ms.sum()),
        "n_steps": len(steps),
        "n_solver_failures": sum(not s["success"] for s in steps),
        "n_retries": sum(bool(s.get("retried")) for s in steps),
        "n_fallbacks": sum(s["fallback"] is not None for s in steps),
        "n_chance_relaxed": sum(bool(s["slack"] > 1e-6) for s in steps if s["success"]),
        "fallbacks": [s["fallback"] for s in steps if s["fallback"]],
        "t_enter_target_lane_s": float(demo.t[entered[0]]) if entered.size else None,
        "final_lane": final_lane,
        "final_in_target_lane": final_lane == sc.target_lane,
        "final_state": demo.ev[-1].tolist(),
        "solver": demo.meta.get("smpc", {}).get("solver"),
        "python": platform.python_version(),
    }


def generate_demonstration(
    risk: float = 0.7,
    scenario: str | ScenarioConfig = "paper",
    smpc: SMPCConfig | None = None,
    seed: int | None = 0,
    progress: bool = False,
) -> tuple[Demonstration, dict[str, Any]]:
    """Generate one SMPC demonstration in a fresh env.

    Args:
        risk: p, overriding ``smpc.risk``.
        scenario: scenario name or config.
        smpc: expert configuration (defaults: the paper's).
        seed: env seed.
        progress: show a progress bar.

    Returns:
        The demonstration and its :func:`demo_summary`.
    """
    sc = get_scenario(scenario)
    cfg = replace(smpc or SMPCConfig(), risk=risk)
    env = LaneChangeEnv(scenario=sc)
    try:
        demo, steps = rollout_expert(env, SMPCExpert(cfg, sc), seed=seed, progress=progress)
    finally:
        env.close()
    return demo, demo_summary(demo, steps)


TRAFFIC_VEHICLES = 4
"""Vehicles the SMPC constrains in traffic (the default scene has four besides the EV)."""


def generate_traffic_demonstration(
    risk: float = 0.7,
    scene: TrafficScene | None = None,
    smpc: SMPCConfig | None = None,
    seed: int | None = 0,
    randomize: bool = False,
    progress: bool = False,
) -> tuple[Demonstration, dict[str, Any]]:
    """Generate one SMPC demonstration among several vehicles (``drivestyle.envs.traffic``).

    Args:
        risk: p, overriding ``smpc.risk``.
        scene: the traffic scene (default: :data:`drivestyle.envs.traffic.DEFAULT_TRAFFIC`).
        smpc: expert configuration (default: the paper's with a chance constraint for
            each of :data:`TRAFFIC_VEHICLES` vehicles).
        seed: env seed (with ``randomize``: draws the scene).
        randomize: draw the scene from :class:`drivestyle.envs.traffic.TrafficRanges` with ``seed``.
        progress: show a progress bar.

    Returns:
        The demonstration (``others`` holds the further vehicles; ``meta["scene"]`` the
        scene) and its :func:`demo_summary` (s_e and d_k against every vehicle).
    """
    cfg = replace(smpc or SMPCConfig(max_vehicles=TRAFFIC_VEHICLES), risk=risk)
    env = TrafficEnv(scene, randomize=randomize)
    try:
        demo, steps = rollout_expert(
            env, SMPCExpert(cfg, env.scene.base), seed=seed, progress=progress
        )
    finally:
        env.close()
    return demo, demo_summary(demo, steps)


def draw_interactive_scenarios(
    k: int,
    seed: int,
    probe_risk: float = 0.5,
    ranges: ScenarioRanges | None = None,
    max_draws: int = 500,
) -> list[ScenarioConfig]:
    """K scenarios of the random family in which the SMPC at ``probe_risk`` triggers.

    Args:
        k: how many (≥ 1).
        seed: seed of the draws (use disjoint seeds for training and evaluation).
        probe_risk: risk of the probing SMPC.
        ranges: the family (default ranges).
        max_draws: give up after this many draws.

    Returns:
        The scenarios.

    Raises:
        ValueError: k < 1.
        RuntimeError: fewer than k interactive scenarios in ``max_draws`` draws.
    """
    if k < 1:
        raise ValueError(f"the number of scenarios must be >= 1, got {k}")
    ranges = ranges or ScenarioRanges()
    rng = np.random.default_rng(seed)
    out: list[ScenarioConfig] = []
    for _ in range(max_draws):
        sc = ranges.sample(rng)
        _, summary = generate_demonstration(probe_risk, sc, SMPCConfig(risk=probe_risk))
        if summary["trigger_fired"] and not summary["collision"]:
            out.append(sc)
            if len(out) == k:
                return out
    raise RuntimeError(f"only {len(out)} interactive scenarios in {max_draws} draws")


def _demos_of_risk(risk: float, scenarios: list[dict[str, Any]]) -> list[Demonstration]:
    """Worker: the SMPC(risk) demonstration in each scenario (or traffic scene)."""
    demos = []
    for i, raw in enumerate(scenarios):
        if "others" in raw:
            demo, _ = generate_traffic_demonstration(risk, TrafficScene.from_dict(raw))
        else:
            demo, _ = generate_demonstration(risk, ScenarioConfig(**raw), SMPCConfig(risk=risk))
        demos.append(replace(demo, meta={**demo.meta, "scenario_index": i}))
    return demos


def generate_demonstrations(
    risks: Sequence[float],
    scenarios: Sequence[ScenarioConfig | TrafficScene],
    workers: int = 2,
    progress: Callable[[float], None] | None = None,
) -> dict[float, list[Demonstration]]:
    """SMPC demonstrations of every risk in every scenario, one process per risk at a time.

    Args:
        risks: risk levels p.
        scenarios: the scenarios or traffic scenes (shared by every risk).
        workers: processes (1: in this process).
        progress: called with each finished risk.

    Returns:
        risk → its demonstrations, in scenario order (``meta["scenario_index"]`` set).
    """
    raw = [sc.to_dict() for sc in scenarios]
    risks = [float(p) for p in risks]
    done = parallel_map(
        _demos_of_risk,
        [(p, raw) for p in risks],
        workers,
        None if progress is None else lambda i, _: progress(risks[i]),
    )
    return dict(zip(risks, done, strict=True))


ROBUSTNESS_RISKS = (0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.925, 0.95)
"""The six grid risks and the five midpoints between them."""


def _robustness_of_risk(risk: float, scenarios: list[dict[str, Any]], jit: bool) -> dict:
    """Worker: closed loops of SMPC(risk) in every scenario; per-demo counts and step times.

    Scenarios with an ``others`` entry are traffic scenes (:class:`TrafficScene` dicts).
    """
    traffic = bool(scenarios) and "others" in scenarios[0]
    env = TrafficEnv() if traffic else LaneChangeEnv()
    vehicles = TRAFFIC_VEHICLES if traffic else 1
    expert = SMPCExpert(SMPCConfig(risk=risk, jit=jit, max_vehicles=vehicles))
    demos, step_ms = [], []
    for i, raw in enumerate(scenarios):
        options = (
            {"scene": TrafficScene.from_dict(raw)}
            if traffic
            else {"scenario": ScenarioConfig(**raw)}
        )
        _, steps = rollout_expert(env, expert, seed=0, options=options)
        step_ms += [s["solve_ms"] for s in steps if not s.get("retried")]
        demos.append(
            {
                "risk": risk,
                "scenario_index": i,
                "n_steps": len(steps),
                "n_solver_failures": sum(not s["success"] for s in steps),
                "n_retries": sum(bool(s.get("retried")) for s in steps),
                "n_fallbacks": sum(s["fallback"] is not None for s in steps),
                "collision": any(s["collision"] for s in steps),
                "failure_statuses": [s["status"] for s in steps if not s["success"]],
            }
        )
    env.close()
    return {"risk": risk, "demos": demos, "step_ms": step_ms}


def smpc_robustness(
    n_scenarios: int,
    seed: int,
    risks: Sequence[float] = ROBUSTNESS_RISKS,
    workers: int = 2,
    jit: bool = False,
    progress: Callable[[float], None] | None = None,
    traffic: bool = False,
) -> dict[str, Any]:
    """Count solver failures, retries and fallbacks of the SMPC over many demonstrations.

    Every risk drives every one of ``n_scenarios`` scenarios drawn from the random family
    (:class:`drivestyle.envs.scenario.ScenarioRanges`) with ``seed``; one process per risk at
    a time, the solver built once per risk.

    Args:
        n_scenarios: scenarios (≥ 1).
        seed: seed of the scenario draws.
        risks: risk levels.
        workers: processes.
        jit: compile the NLPs (faster steps).
        progress: called with each finished risk.
        traffic: draw traffic scenes (:class:`drivestyle.envs.traffic.TrafficRanges`) and constrain
            :data:`TRAFFIC_VEHICLES` vehicles.

    Returns:
        ``n_demos``, ``n_steps``, ``n_solver_failures`` (steps whose solve and retry failed),
        ``n_demos_with_failures``, ``n_retries``, ``n_fallbacks``, ``n_collisions``, step
        times (first attempts), a per-risk breakdown and the failing demonstrations.
    """
    if n_scenarios < 1:
        raise ValueError(f"n_scenarios must be >= 1, got {n_scenarios}")
    rng = np.random.default_rng(seed)
    ranges = TrafficRanges() if traffic else ScenarioRanges()
    raw = [ranges.sample(rng).to_dict() for _ in range(n_scenarios)]
    risks = [float(p) for p in risks]
    runs = parallel_map(
        _robustness_of_risk,
        [(p, raw, jit) for p in risks],
        workers,
        None if progress is None else lambda i, _: progress(risks[i]),
    )
    demos = [d for run in runs for d in run["demos"]]
    step_ms = np.array([ms for run in runs for ms in run["step_ms"]])

    def counts(ds: list[dict]) -> dict[str, int]:
        return {
            "n_demos": len(ds),
            "n_solver_failures": sum(d["n_solver_failures"] for d in ds),
            "n_demos_with_failures": sum(d["n_solver_failures"] > 0 for d in ds),
            "n_retries": sum(d["n_retries"] for d in ds),
            "n_fallbacks": sum(d["n_fallbacks"] for d in ds),
            "n_collisions": sum(d["collision"] for d in ds),
        }

    return {
        **counts(demos),
        "n_steps": int(sum(d["n_steps"] for d in demos)),
        "n_scenarios": n_scenarios,
        "seed": seed,
        "risks": risks,
        "jit": jit,
        "traffic": traffic,
        "step_ms_median": float(np.median(step_ms)),
        "step_ms_p95": float(np.percentile(step_ms, 95)),
        "step_ms_max": float(np.max(step_ms)),
        "by_risk": {f"{run['risk']:g}": counts(run["demos"]) for run in runs},
        "failing_demos": [d for d in demos if d["n_solver_failures"] or d["n_retries"]],
    }
