"""Closed-loop rollouts of the SMPC expert in the env: demonstrations and their summary."""

from __future__ import annotations

import platform
from dataclasses import asdict
from typing import Any

import gymnasium as gym
import numpy as np
from tqdm import tqdm

from agents.smpc import SMPCConfig, SMPCExpert
from envs.demonstration import Demonstration
from envs.lane_change import LaneChangeEnv
from envs.safety import ellipse_constraint, elliptical_index, trigger_time
from envs.scenario import ScenarioConfig, get_scenario

__all__ = ["demo_summary", "generate_demonstration", "rollout_expert"]


def rollout_expert(
    env: gym.Env,
    expert: SMPCExpert,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    progress: bool = False,
) -> tuple[Demonstration, list[dict[str, Any]]]:
    """Run the expert in closed loop on ``env`` for one episode.

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
    obs, info = env.reset(seed=seed, options=options)
    scenario: ScenarioConfig = info["scenario"]
    expert.reset(scenario)
    states, inputs, steps = [obs.copy()], [], []
    for _ in tqdm(
        range(scenario.n_steps), desc="SMPC closed loop", disable=not progress, leave=False
    ):
        action, solve = expert.act(obs, return_info=True)
        obs, _, terminated, truncated, info = env.step(action)
        states.append(obs.copy())
        inputs.append(action)
        steps.append(
            {**solve, "collision": bool(info["collision"]), "off_road": bool(info["off_road"])}
        )
        if terminated or truncated:
            break
    states = np.array(states)
    n = len(states)
    demo = Demonstration(
        t=np.arange(n) * scenario.dt,
        ev=states[:, :4],
        tv=states[:, 4:],
        u=np.array(inputs).reshape(n - 1, 2),
        meta={
            "scenario": scenario.to_dict(),
            "risk": expert.config.risk,
            "smpc": _config_dict(expert.config),
        },
    )
    return demo, steps


def _config_dict(cfg: SMPCConfig) -> dict[str, Any]:
    d = asdict(cfg)
    d["kappa"] = cfg.kappa
    return d


def demo_summary(demo: Demonstration, steps: list[dict[str, Any]]) -> dict[str, Any]:
    """Summary numbers of a demonstration (the ``demo.json`` fields of SPEC §7).

    Args:
        demo: the demonstration (with ``meta["scenario"]``).
        steps: per-step records from :func:`rollout_expert`.

    Returns:
        JSON-ready dict: risk, t_trg_s (None if the trigger never fires), min_s_e and where,
        min_d_k (nominal ellipse), collision, off_road, solver statistics, lane-change
        timing and the final state.
    """
    sc = demo.scenario
    dx, dy = demo.ev[:, 0] - demo.tv[:, 0], demo.ev[:, 1] - demo.tv[:, 1]
    s_e = elliptical_index(dx, dy, sc.l_a, sc.l_b)
    d_k = ellipse_constraint(dx, dy, sc.l_a, sc.l_b)
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
    from dataclasses import replace

    sc = get_scenario(scenario)
    cfg = replace(smpc or SMPCConfig(), risk=risk)
    env = LaneChangeEnv(scenario=sc)
    try:
        demo, steps = rollout_expert(env, SMPCExpert(cfg, sc), seed=seed, progress=progress)
    finally:
        env.close()
    return demo, demo_summary(demo, steps)
