"""A learned driving style as the environment's reward.

The per-step reward is the negative learned cost of the step,

    r_t = −θᵀ Δf_t,    Δf_t = Ω f(r_{0:t+1}) − Ω f(r_{0:t}),

where f(r_{0:k}) are the style's features of the EV's own trajectory up to sample k,
represented exactly as a demonstration would be (quintic spline over the samples, the
style's control-point rule, same quadrature). The increments telescope, so an episode's
summed reward is −θᵀ f of the whole episode: replaying a demonstration's inputs returns
−θᵀ f(r_D) up to round-off (tested to 1e-8 relative).

Event times are computed online from the env's trajectory with the demonstration's own
definitions — t_turn where the EV crosses its initial lane's boundary, t_trg at the first
sample with s_e < λ, the reaction window [t_trg, t_trg + T_rct] — which depend on past
samples only, so "online" and "offline" agree. Before t_turn is reached the prefix's f_il
runs to its end, exactly as for a demonstration that never turns.

Collisions and leaving the road end the episode early; since the remaining cost would
then be saved, a crash costs ``crash_penalty`` (default: ten times the style's cost of its
own demonstration, θᵀ f(r_D) — large enough that rushing into the target lane and being
hit there never pays; with 2× an RL policy learned exactly that).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from envs.safety import elliptical_index
from envs.scenario import ScenarioConfig

__all__ = ["CRASH_FACTOR", "LearnedStyleReward", "StyleReward"]

CRASH_FACTOR = 10.0
"""Default crash penalty as a multiple of the style's cost of its demonstration."""


class StyleReward:
    """Incremental learned cost of a growing trajectory (module docstring).

    Args:
        style: a loaded :class:`irl.style.Style` or the path of a ``style.json``.
        crash_penalty: cost of a collision or leaving the road; None: CRASH_FACTOR·θᵀ f(r_D).
    """

    # control points settle two samples late (central differences of velocities that
    # themselves use the next input), so the last few segments are recomputed each step
    TAIL = 4

    def __init__(self, style: Any, crash_penalty: float | None = None) -> None:
        from irl.features import FEATURES
        from irl.style import Style, load_style

        self.style: Style = style if isinstance(style, Style) else load_style(Path(style))
        cfg = self.style.features
        self.config = cfg
        self.names = self.style.names
        self.theta = np.asarray(self.style.theta, float)
        self.idx = np.array([FEATURES.index(n) for n in self.names])
        self.omega = np.asarray(cfg.omega, float)
        self.rule = self.style.control_point_rule
        f_demo = self.style.raw.get("feature_values_demo")
        ref_cost = float(self.theta @ np.asarray(f_demo)) if f_demo is not None else 100.0
        self.crash_penalty = (
            CRASH_FACTOR * abs(ref_cost) if crash_penalty is None else float(crash_penalty)
        )
        if not (np.isfinite(self.crash_penalty) and self.crash_penalty >= 0):
            raise ValueError(f"crash_penalty must be finite and >= 0, got {crash_penalty}")

    def reset(self, scenario: ScenarioConfig, ev: np.ndarray, tv: np.ndarray) -> None:
        """Start a trajectory at the first sample.

        Args:
            scenario: the episode's scenario (lanes, v_ref, λ, ellipse, T_s).
            ev: EV state [x, y, φ, v].
            tv: TV state [x, y, φ, v].
        """
        cfg, sc = self.config, scenario
        self.sc = sc
        self.consts = {
            "config": cfg,
            "v_des": cfg.v_des if cfg.v_des is not None else sc.v_ref,
            "v_lane": cfg.v_lane if cfg.v_lane is not None else sc.v_ref,
            "l_des": cfg.l_des if cfg.l_des is not None else sc.y_ref,
            "l_initial": (
                cfg.l_initial if cfg.l_initial is not None else float(sc.lane_centres[sc.ev_lane])
            ),
        }
        self.lam = cfg.trigger_lambda if cfg.trigger_lambda is not None else sc.trigger_lambda
        self.ratio = sc.l_r / (sc.l_f + sc.l_r)
        self.upward = sc.target_lane > sc.ev_lane
        self.boundary = sc.lane_width * (sc.ev_lane + 1 if self.upward else sc.ev_lane)
        self.t = [0.0]
        self.ev = [np.asarray(ev, float).copy()]
        self.tv = [np.asarray(tv, float).copy()]
        self.delta: list[float] = []
        self.segments: list[dict[str, float]] = []
        self.t_turn: float | None = None
        self.t_trg: float | None = None
        self._check_trigger()
        self.f = np.zeros(len(self.omega))

    def _check_trigger(self) -> None:
        if self.t_trg is None:
            ev, tv = self.ev[-1], self.tv[-1]
            s_e = float(elliptical_index(ev[0] - tv[0], ev[1] - tv[1], self.sc.l_a, self.sc.l_b))
            if s_e < self.lam:
                self.t_trg = self.t[-1]

    def _check_turn(self) -> None:
        if self.t_turn is not None or len(self.t) < 2:
            return
        s = [(e[1] - self.boundary) * (1 if self.upward else -1) for e in self.ev[-2:]]
        if s[1] > 0:
            frac = 0.0 if s[0] > 0 else -s[0] / (s[1] - s[0])
            self.t_turn = self.t[-2] + frac * (self.t[-1] - self.t[-2])

    def features(self) -> np.ndarray:
        """Scaled features Ω f of the trajectory so far, all ten (FEATURES order)."""
        from irl.features import FEATURES, segment_integrals
        from irl.spline import spline_eval, state_control_points

        n = len(self.t)
        if n < 2:
            return np.zeros(len(FEATURES))
        t = np.asarray(self.t)
        ev, tv = np.asarray(self.ev), np.asarray(self.tv)
        delta = np.asarray([*self.delta, self.delta[-1]])
        C = state_control_points(t, ev, delta, self.rule, self.ratio)
        T = state_control_points(t, tv, np.zeros(n), "kinematic", 0.5)  # as tv_control_points
        t_rct = self.config.t_rct
        window = None
        if self.t_trg is not None:
            i_trg = int(np.argmin(np.abs(t - self.t_trg)))
            window = (self.t_trg, self.t_trg + t_rct, float(ev[i_trg, 1]))
        t_turn = self.t_turn if self.t_turn is not None else np.inf
        first_tail = max(0, n - 1 - self.TAIL)
        del self.segments[first_tail:]
        for j in range(first_tail, n - 1):
            self.segments.append(
                segment_integrals(
                    np.r_[C[j, :3], C[j + 1, :3]],
                    np.r_[C[j, 3:], C[j + 1, 3:]],
                    np.r_[T[j, :3], T[j + 1, :3]],
                    t[j],
                    t[j + 1],
                    self.consts,
                    t_turn,
                    window,
                    j == 0,
                )
            )
        f = dict.fromkeys(FEATURES, 0.0)
        for seg in self.segments:
            for k, v in seg.items():
                f[k] += v
        f["el"] = self.segments[-1]["l"]  # f_el: ∫ |l_des − y| over the last segment
        if window is not None:
            i_trg = int(np.argmin(np.abs(t - self.t_trg)))
            f["sd"] = float(np.exp(-abs(ev[i_trg, 1] - tv[i_trg, 1])))
            t_e = min(self.t_trg + t_rct, t[-1])
            y_ev = spline_eval(C, t, [t_e])[0, 1]
            y_tv = spline_eval(T, t, [t_e])[0, 1]
            f["ed"] = float(np.exp(-abs(y_ev - y_tv)))
        return self.omega * np.array([f[k] for k in FEATURES])

    def step(
        self, u: np.ndarray, ev: np.ndarray, tv: np.ndarray, dt: float
    ) -> tuple[float, np.ndarray]:
        """Add the next sample and return the step's reward.

        Args:
            u: the applied input [a, δ] over the step.
            ev: EV state after the step.
            tv: TV state after the step.
            dt: step length [s].

        Returns:
            (reward −θᵀΔf, Δf of the active features).
        """
        self.delta.append(float(u[1]))
        self.t.append(self.t[-1] + dt)
        self.ev.append(np.asarray(ev, float).copy())
        self.tv.append(np.asarray(tv, float).copy())
        self._check_turn()
        self._check_trigger()
        f = self.features()
        df = (f - self.f)[self.idx]
        self.f = f
        return -float(self.theta @ df), df


class LearnedStyleReward(gym.Wrapper):
    """Replace a drivestyle env's reward with a learned style's negative cost.

    The original reward is kept in ``info["original_env_rew"]`` (the imitation library's
    convention) and the step's feature increment in ``info["style_feature_increment"]``.

    Args:
        env: a drivestyle env (possibly wrapped).
        style: a :class:`irl.style.Style` or the path of a ``style.json`` (or its folder).
        crash_penalty: see :class:`StyleReward`.
    """

    def __init__(self, env: gym.Env, style: Any, crash_penalty: float | None = None) -> None:
        super().__init__(env)
        self.style_reward = StyleReward(style, crash_penalty)

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the env and the style's trajectory."""
        obs, info = self.env.reset(**kwargs)
        self.style_reward.reset(self.env.unwrapped.scenario, obs[:4], obs[4:])
        return obs, info

    def step(self, action: np.ndarray) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict]:
        """Step the env; the reward becomes −θᵀΔf (minus the crash penalty on a crash)."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        r, df = self.style_reward.step(
            info["action"], obs[:4], obs[4:], self.env.unwrapped.scenario.dt
        )
        if info.get("collision") or info.get("off_road"):
            r -= self.style_reward.crash_penalty
        info = {**info, "original_env_rew": reward, "style_feature_increment": df}
        return obs, r, terminated, truncated, info
