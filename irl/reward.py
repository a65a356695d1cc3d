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

A receding-horizon *driver style* (:mod:`drivestyle.irl.driver_style`, the default model)
gives a per-step reward instead (:func:`driver_step_cost`, :class:`DriverCostReward`): the
style's stage cost of the step,

    w_y (y − y_ref)² + w_φ φ² + w_v (v − v_ref)² + w_a a² + w_δ δ²

(the state after the step, the step's input), plus its constraints as penalties — the
chance constraint g ≥ 0 with κ(p) against each vehicle's current position and covariance
Σ_0 (or, with a look-ahead of J steps, the worst of the stages j = 0 … J with the EV and
the vehicles extrapolated at constant velocity and the prediction covariance Σ_j, as the
style's planner predicts them), the nominal ellipse and the state bounds — and
r = −cost / scale. The scale is the lane term one lane off
(w_y · lane_width²), so a step starting a lane change costs ≈ 1 whatever the style's gauge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium.utils import RecordConstructorArgs

from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.chance import chance_margin
from drivestyle.irl.driver_style import DriverStyle, load_driver_style
from drivestyle.irl.features import (
    FEATURES,
    SEGMENT_FEATURES,
    event_times,
    feature_constants,
    instant_feature,
    segment_integrals,
    tiv_reference,
    tv_control_points,
)
from drivestyle.irl.prediction import PAPER_TV_UNCERTAINTY, TVUncertainty, tv_covariance
from drivestyle.irl.spline import spline_eval, state_control_points
from drivestyle.irl.style import Style, StyleError, load_style

__all__ = [
    "COST_TERMS",
    "CRASH_FACTOR",
    "DriverCost",
    "DriverCostConfig",
    "DriverCostReward",
    "LearnedStyleReward",
    "StyleReward",
    "driver_step_cost",
]

CRASH_FACTOR = 10.0
"""Default crash penalty as a multiple of the style's cost of its demonstration."""


class StyleReward:
    """Incremental learned cost of a growing trajectory (module docstring).

    It implements the env's reward-model protocol
    (:class:`drivestyle.envs.lane_change.RewardModel`):
    ``reset(scenario, ev, tv)``, ``step(u, ev, tv, dt) -> (reward, Δf)`` and
    ``crash_penalty``.

    Args:
        style: a loaded :class:`drivestyle.irl.style.Style` or the path of a ``style.json``.
        crash_penalty: cost of a collision or leaving the road; None: CRASH_FACTOR·θᵀ f(r_D).

    Raises:
        StyleError: θ overflows the style's cost, or ``feature_values_demo`` is malformed.
        ValueError: ``crash_penalty`` is negative or not finite.
    """

    # control points settle two samples late (central differences of velocities that
    # themselves use the next input), so the last few segments are recomputed each step
    TAIL = 4

    def __init__(self, style: Style | str | Path, crash_penalty: float | None = None) -> None:
        self.style: Style = style if isinstance(style, Style) else load_style(Path(style))
        self.config = self.style.features
        self.names = self.style.names
        self.theta = np.asarray(self.style.theta, float)
        self.idx = np.array([FEATURES.index(n) for n in self.names])
        self.omega = np.asarray(self.config.omega, float)
        self.control_point_rule = self.style.control_point_rule
        source = "" if isinstance(style, Style) else f"{style}: "
        ref_cost = self._reference_cost(source)
        self.crash_penalty = (
            CRASH_FACTOR * abs(ref_cost) if crash_penalty is None else float(crash_penalty)
        )
        if not (np.isfinite(self.crash_penalty) and self.crash_penalty >= 0):
            raise ValueError(f"crash_penalty must be finite and >= 0, got {crash_penalty}")

    def _reference_cost(self, source: str) -> float:
        """The style's cost of its own demonstration, θᵀ f(r_D) (100 when not recorded).

        Raises:
            StyleError: ``feature_values_demo`` is malformed, or θ is so large that this cost
                (times CRASH_FACTOR, the default crash penalty) overflows: every reward of
                such a style would be infinite or lose all precision.
        """
        f_demo = self.style.raw.get("feature_values_demo")
        if f_demo is None:
            return 100.0
        try:
            f = np.asarray(f_demo, dtype=float)
        except (TypeError, ValueError):
            f = np.empty(0)
        if f.shape != self.theta.shape or not np.all(np.isfinite(f)):
            raise StyleError(
                f"{source}feature_values_demo must be {len(self.theta)} finite numbers "
                f"(one per feature), got {f_demo}"
            )
        with np.errstate(over="ignore", invalid="ignore"):
            cost = float(self.theta @ f)
            penalty = CRASH_FACTOR * abs(cost)
        if not np.isfinite(penalty):
            raise StyleError(
                f"{source}style θ overflows: its cost of its own demonstration θᵀ f(r_D) = "
                f"{cost:.3g} (largest θ {np.max(np.abs(self.theta)):.3g}) times the crash "
                f"factor {CRASH_FACTOR:g} is not a finite number; relearn or rescale θ"
            )
        return cost

    def reset(
        self,
        scenario: ScenarioConfig,
        ev: np.ndarray,
        tv: np.ndarray,
        others: np.ndarray | None = None,
    ) -> None:
        """Start a trajectory at the first sample.

        Args:
            scenario: the episode's scenario (lanes, v_ref, λ, ellipse, T_s).
            ev: EV state [x, y, φ, v].
            tv: TV state [x, y, φ, v].
            others: further vehicles' states, shape (m, 4) (traffic; None: the TV only).
        """
        self.sc = scenario
        self.constants = feature_constants(self.config, scenario)
        self.ratio = scenario.l_r / (scenario.l_f + scenario.l_r)
        self.t = [0.0]
        self.ev = [np.asarray(ev, float).copy()]
        self.tv = [np.asarray(tv, float).copy()]
        self.m = 0 if others is None else int(np.shape(others)[0])
        self.others = [
            np.zeros((0, 4)) if others is None else np.asarray(others, float).reshape(self.m, 4)
        ]
        self.delta: list[float] = []
        self.segments: list[dict[str, float]] = []
        self.f = np.zeros(len(self.omega))

    def features(self) -> np.ndarray:
        """Scaled features Ω f of the trajectory so far, all ten (FEATURES order)."""
        n = len(self.t)
        if n < 2:
            return np.zeros(len(FEATURES))
        t = np.asarray(self.t)
        ev, tv = np.asarray(self.ev), np.asarray(self.tv)
        others = np.asarray(self.others).reshape(n, self.m, 4) if self.m else None
        events = event_times(t, ev, tv, self.sc, self.config, others)
        delta = np.asarray([*self.delta, self.delta[-1]])
        C = state_control_points(t, ev, delta, self.control_point_rule, self.ratio)
        vehicles = tv[:, None, :] if others is None else np.concatenate([tv[:, None], others], 1)
        Ts = [tv_control_points(t, vehicles[:, i]) for i in range(vehicles.shape[1])]
        ref = tiv_reference(ev, tv, self.sc, others)
        y_trg = None
        if events.reactive_active:
            y_trg = float(spline_eval(C, t, [events.reactive_window()[0]])[0, 1])
        first_tail = max(0, n - 1 - self.TAIL)
        del self.segments[first_tail:]
        for j in range(first_tail, n - 1):
            self.segments.append(
                segment_integrals(
                    np.r_[C[j, :3], C[j + 1, :3]],
                    np.r_[C[j, 3:], C[j + 1, 3:]],
                    np.r_[Ts[ref[j]][j, :3], Ts[ref[j]][j + 1, :3]],
                    t[j],
                    t[j + 1],
                    self.config,
                    self.constants,
                    events,
                    y_trg,
                    j == 0,
                )
            )
        f = dict.fromkeys(FEATURES, 0.0)
        for name in SEGMENT_FEATURES:
            f[name] = sum(seg[name] for seg in self.segments)
        # f_el is f_l's integrand over the last segment (DESIGN §5)
        f["el"] = self.segments[-1]["l"]
        if events.reactive_active:
            window = list(events.reactive_window())  # [t_trg, t_rct_end]
            at = spline_eval(C, t, window)[:, 1]
            at_tv = spline_eval(Ts[events.critical], t, window)[:, 1]
            f["sd"] = float(instant_feature(at[0], at_tv[0], np.exp, np.abs))
            f["ed"] = float(instant_feature(at[1], at_tv[1], np.exp, np.abs))
        return self.omega * np.array([f[k] for k in FEATURES])

    def step(
        self,
        u: np.ndarray,
        ev: np.ndarray,
        tv: np.ndarray,
        dt: float,
        others: np.ndarray | None = None,
    ) -> tuple[float, np.ndarray]:
        """Add the next sample and return the step's reward.

        Args:
            u: the applied input [a, δ] over the step.
            ev: EV state after the step.
            tv: TV state after the step.
            dt: step length [s].
            others: further vehicles after the step, shape (m, 4) (as at reset).

        Returns:
            (reward −θᵀΔf, Δf of the active features).
        """
        self.delta.append(float(u[1]))
        self.t.append(self.t[-1] + dt)
        self.ev.append(np.asarray(ev, float).copy())
        self.tv.append(np.asarray(tv, float).copy())
        self.others.append(
            np.zeros((0, 4)) if not self.m else np.asarray(others, float).reshape(self.m, 4).copy()
        )
        f = self.features()
        df = (f - self.f)[self.idx]
        self.f = f
        return -float(self.theta @ df), df


class LearnedStyleReward(gym.Wrapper, RecordConstructorArgs):
    """Replace a drivestyle env's reward with a learned style's negative cost.

    The original reward is kept in ``info["original_env_rew"]`` (the imitation library's
    convention) and the step's feature increment in ``info["style_feature_increment"]``.

    Args:
        env: a drivestyle env (possibly wrapped).
        style: a :class:`drivestyle.irl.style.Style` or the path of a ``style.json`` (or its
            folder).
        crash_penalty: see :class:`StyleReward`.
    """

    def __init__(
        self, env: gym.Env, style: Style | str | Path, crash_penalty: float | None = None
    ) -> None:
        RecordConstructorArgs.__init__(self, style=style, crash_penalty=crash_penalty)
        gym.Wrapper.__init__(self, env)
        self.style_reward = StyleReward(style, crash_penalty)

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the env and the style's trajectory."""
        obs, info = self.env.reset(**kwargs)
        tv, others = self._vehicles(obs, info)
        self.style_reward.reset(self._scenario(), obs[:4], tv, others)
        return obs, info

    def _scenario(self) -> ScenarioConfig:
        """The drivestyle env's current scenario (a gym.Env in general has none)."""
        base = self.env.unwrapped
        scenario = getattr(base, "scenario", None)
        if not isinstance(scenario, ScenarioConfig):
            raise TypeError(
                f"the style reward needs a drivestyle env with a scenario, got {base!r}"
            )
        return scenario

    @staticmethod
    def _vehicles(obs: np.ndarray, info: dict) -> tuple[np.ndarray, np.ndarray | None]:
        """TV and further vehicles: from ``info["vehicles"]`` in traffic, else the obs."""
        if "vehicles" in info:
            return info["vehicles"][0], info["vehicles"][1:]
        return obs[4:8], None

    def step(self, action: np.ndarray) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict]:
        """Step the env; the reward becomes −θᵀΔf (minus the crash penalty on a crash)."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        tv, others = self._vehicles(obs, info)
        r, df = self.style_reward.step(info["action"], obs[:4], tv, self._scenario().dt, others)
        if info.get("collision") or info.get("off_road"):
            r -= self.style_reward.crash_penalty
        info = {**info, "original_env_rew": reward, "style_feature_increment": df}
        return obs, r, terminated, truncated, info


# ---------------------------------------------------------------------- driver-style cost
COST_TERMS = ("lane", "heading", "speed", "accel", "steer", "chance", "ellipse", "bounds")
"""Terms of :func:`driver_step_cost`: the five stage-cost terms (the style's weights
included) and the three constraint violations (unweighted)."""


def driver_step_cost(
    ev: np.ndarray,
    u: np.ndarray,
    vehicles: np.ndarray,
    weights: np.ndarray,
    y_ref: float,
    v_ref: float,
    kappa: float,
    sigma: np.ndarray,
    scenario: ScenarioConfig,
) -> np.ndarray:
    """The terms of a driver style's cost of one step (module docstring).

    Args:
        ev: EV state after the step [x, y, φ, v].
        u: the step's input [a, δ].
        vehicles: the surrounding vehicles' states at the same time, shape (m, 4).
        weights: [w_y, w_φ, w_v, w_a, w_δ].
        y_ref: target lane centre [m].
        v_ref: desired speed [m/s].
        kappa: Φ⁻¹(p) of the chance constraint.
        sigma: the vehicles' position covariance, shape (2, 2) [m²]; or Σ_j of a look-ahead,
            shape (J + 1, 2, 2): stage j extrapolates the EV and the vehicles j T_s ahead at
            constant velocity and the chance violation is the worst stage's.
        scenario: ellipse axes l_a, l_b, T_s, bounds (y, φ_max, v_max) and lane width.

    Returns:
        :data:`COST_TERMS`, shape (8,): w_y (y − y_ref)², w_φ φ², w_v (v − v_ref)², w_a a²,
        w_δ δ²; then the violations max(0, −g) of the chance constraint (worst stage)
        summed over the vehicles, max(0, 1 − ‖z̄‖) of the nominal ellipse summed over the
        vehicles, and the bounds' (y beyond the road by lane widths, |φ| beyond φ_max and
        v beyond v_max as fractions of the bound).
    """
    sc = scenario
    x, y, phi, v = (float(c) for c in np.asarray(ev, float)[:4])
    a, delta = (float(c) for c in np.asarray(u, float)[:2])
    w = np.asarray(weights, float)
    stage = w * np.array([(y - y_ref) ** 2, phi**2, (v - v_ref) ** 2, a**2, delta**2])
    veh = np.asarray(vehicles, float).reshape(-1, 4)
    dx, dy = x - veh[:, 0], y - veh[:, 1]
    nominal = np.hypot(dx / sc.l_a, dy / sc.l_b) - 1.0
    sig = np.asarray(sigma, float).reshape(-1, 2, 2)
    t = np.arange(len(sig))[:, None] * sc.dt  # stage times, (J + 1, 1)
    # relative motion at constant velocity: EV along its heading, each vehicle along its own
    dvx = v * np.cos(phi) - veh[:, 3] * np.cos(veh[:, 2])
    dvy = v * np.sin(phi) - veh[:, 3] * np.sin(veh[:, 2])
    g = chance_margin(
        dx + dvx * t, dy + dvy * t, sig[:, 0, 0, None], sig[:, 0, 1, None], sig[:, 1, 1, None],
        sc.l_a, sc.l_b, kappa,
    ).min(axis=0)  # fmt: skip
    y_lo, y_hi = sc.y_bounds
    bounds = (
        (max(0.0, y_lo - y) + max(0.0, y - y_hi)) / sc.lane_width
        + max(0.0, abs(phi) / sc.phi_max - 1.0)
        + max(0.0, v / sc.v_max - 1.0)
    )
    violations = [float(np.sum(np.maximum(0.0, -g))), float(np.sum(np.maximum(0.0, -nominal)))]
    return np.concatenate([stage, violations, [bounds]])


@dataclass(frozen=True)
class DriverCostConfig:
    """How a driver style's cost becomes a reward (:class:`DriverCost`)."""

    chance_weight: float = 10.0
    """Penalty per unit of chance-margin violation max(0, −g) [reward units]."""
    ellipse_weight: float = 100.0
    """Penalty per unit of nominal-ellipse violation [reward units]."""
    bounds_weight: float = 10.0
    """Penalty per unit of bound violation [reward units]."""
    crash_penalty: float = 100.0
    """Cost of a collision or leaving the road (ends the episode) [reward units]: more than
    the ≈ 30 steps of stage cost an early end would save."""
    look_ahead: int = 0
    """J: the chance penalty is the worst of the stages j = 0 … J, each with the EV and
    the vehicles extrapolated j T_s at constant velocity and covariance Σ_j (0: the current
    positions and the TV's current covariance)."""
    scale: float | None = None
    """Stage cost per reward unit; None: w_y · lane_width² (one lane off costs 1)."""

    def __post_init__(self) -> None:
        for name in ("chance_weight", "ellipse_weight", "bounds_weight", "crash_penalty"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if not (isinstance(self.look_ahead, int) and 0 <= self.look_ahead <= 50):
            raise ValueError(f"look_ahead must be an integer in [0, 50], got {self.look_ahead!r}")
        if self.scale is not None and not (np.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"scale must be a finite positive number, got {self.scale!r}")


class DriverCost:
    """A driver style's per-step cost as the env's reward model (module docstring).

    Implements the env's reward-model protocol
    (:class:`drivestyle.envs.lane_change.RewardModel`); ``step`` returns the terms of
    :func:`driver_step_cost` as the increment.

    Args:
        style: a :class:`drivestyle.irl.driver_style.DriverStyle` or a driver-style file.
        config: penalties, crash penalty, covariance and scale.
        uncertainty: the vehicles' prediction error model (the style model's default).
    """

    def __init__(
        self,
        style: DriverStyle | str | Path,
        config: DriverCostConfig | None = None,
        uncertainty: TVUncertainty = PAPER_TV_UNCERTAINTY,
    ) -> None:
        self.style = style if isinstance(style, DriverStyle) else load_driver_style(style)
        self.config = config or DriverCostConfig()
        self.uncertainty = uncertainty
        self.weights = np.asarray(self.style.weights, float)
        self.penalties = np.array(
            [self.config.chance_weight, self.config.ellipse_weight, self.config.bounds_weight]
        )
        self.crash_penalty = float(self.config.crash_penalty)

    def reset(
        self,
        scenario: ScenarioConfig,
        ev: np.ndarray,
        tv: np.ndarray,
        others: np.ndarray | None = None,
    ) -> None:
        """Start an episode in ``scenario`` (the states are not needed)."""
        self.sc = scenario
        self.sigma = tv_covariance(self.uncertainty, scenario.dt, self.config.look_ahead)
        self.v_ref = scenario.v_ref if self.style.v_ref is None else self.style.v_ref
        self.scale = (
            self.config.scale
            if self.config.scale is not None
            else self.weights[0] * scenario.lane_width**2
        )
        self.kappa = self.style.kappa  # Φ⁻¹(p): computed once, not per step
        self._floats = _DriverCostFloats(self, scenario)

    def step(
        self,
        u: np.ndarray,
        ev: np.ndarray,
        tv: np.ndarray,
        dt: float,
        others: np.ndarray | None = None,
    ) -> tuple[float, np.ndarray]:
        """The step's reward −(stage cost / scale + weighted violations) and its terms."""
        rows = [np.asarray(tv, float).reshape(4).tolist()]
        if others is not None and np.size(others):
            rows += np.asarray(others, float).reshape(-1, 4).tolist()
        c = self._floats
        if len(rows) * len(c.stages) <= _FLOAT_PATH_MAX_PAIRS:
            terms = c.terms(
                np.asarray(ev, float).reshape(-1)[:4].tolist(),
                np.asarray(u, float).reshape(-1)[:2].tolist(),
                rows,
            )
            p = c.penalties
            cost = sum(terms[:5]) / self.scale + (
                p[0] * terms[5] + p[1] * terms[6] + p[2] * terms[7]
            )
            return -float(cost), np.array(terms)
        terms_array = driver_step_cost(
            ev, u, np.array(rows), self.weights, self.sc.y_ref, self.v_ref, self.kappa,
            self.sigma, self.sc,
        )  # fmt: skip
        cost = terms_array[:5].sum() / self.scale + self.penalties @ terms_array[5:]
        return -float(cost), terms_array


_FLOAT_PATH_MAX_PAIRS = 16
"""Vehicles × look-ahead stages up to which :class:`DriverCost` evaluates its terms on
Python floats (faster than numpy on a few numbers; numpy beyond)."""


class _DriverCostFloats:
    """:func:`driver_step_cost` on Python floats for one episode's constants.

    The same operations in the same order (numpy's hypot, whose rounding can differ from
    the math module's; sums over vehicles in np.sum's order below 8 terms), so the terms
    equal the array function's (tests/irl/test_reward.py).
    """

    def __init__(self, cost: DriverCost, sc: ScenarioConfig) -> None:
        self.weights = [float(w) for w in cost.weights]
        self.penalties = [float(p) for p in cost.penalties]
        self.y_ref, self.v_ref, self.kappa = float(sc.y_ref), float(cost.v_ref), cost.kappa
        self.l_a, self.l_b = l_a, l_b = float(sc.l_a), float(sc.l_b)
        sig = np.asarray(cost.sigma, float).reshape(-1, 2, 2)
        # stage j: time j T_s and the covariance entries over the axes' squares
        self.stages = [
            (j * sc.dt, sxx / l_a**2, sxy / (l_a * l_b), syy / l_b**2)
            for j, ((sxx, sxy), (_, syy)) in enumerate(sig.tolist())
        ]
        self.y_lo, self.y_hi = sc.y_bounds
        self.lane_width, self.phi_max, self.v_max = sc.lane_width, sc.phi_max, sc.v_max

    def terms(self, ev: list[float], u: list[float], vehicles: list[list[float]]) -> list[float]:
        """:data:`COST_TERMS` of one step (``vehicles``: rows [x, y, φ, v])."""
        x, y, phi, v = ev
        a, delta = u
        w = self.weights
        stage = [
            w[0] * (y - self.y_ref) ** 2,
            w[1] * phi**2,
            w[2] * (v - self.v_ref) ** 2,
            w[3] * a**2,
            w[4] * delta**2,
        ]
        l_a, l_b, kappa = self.l_a, self.l_b, self.kappa
        vx, vy = v * math.cos(phi), v * math.sin(phi)
        chance, nominal = [], []
        sqrt = math.sqrt
        for r in vehicles:
            dx, dy = x - r[0], y - r[1]
            nominal.append(max(0.0, -(float(np.hypot(dx / l_a, dy / l_b)) - 1.0)))
            dvx = vx - r[3] * math.cos(r[2])
            dvy = vy - r[3] * math.sin(r[2])
            g_min = math.inf
            for t, sxx, sxy, syy in self.stages:
                # chance_margin, operation by operation
                z1 = (dx + dvx * t) / l_a
                z2 = (dy + dvy * t) / l_b
                norm = sqrt(z1 * z1 + z2 * z2)
                zsz = z1 * z1 * sxx + 2 * z1 * z2 * sxy + z2 * z2 * syy
                g_min = min(g_min, norm - 1 - kappa * sqrt(zsz) / norm)
            chance.append(max(0.0, -g_min))
        bounds = (
            (max(0.0, self.y_lo - y) + max(0.0, y - self.y_hi)) / self.lane_width
            + max(0.0, abs(phi) / self.phi_max - 1.0)
            + max(0.0, v / self.v_max - 1.0)
        )
        # np.sum's order for fewer than 8 terms: sequential from zero
        return [*stage, sum(chance), sum(nominal), bounds]


class DriverCostReward(LearnedStyleReward):
    """Replace a drivestyle env's reward with a driver style's per-step cost.

    As :class:`LearnedStyleReward` (``info["original_env_rew"]``; the step's
    :data:`COST_TERMS` in ``info["style_feature_increment"]``), with :class:`DriverCost`.

    Args:
        env: a drivestyle env (possibly wrapped).
        style: a :class:`drivestyle.irl.driver_style.DriverStyle` or a driver-style file.
        config: see :class:`DriverCostConfig`.
    """

    def __init__(
        self,
        env: gym.Env,
        style: DriverStyle | str | Path,
        config: DriverCostConfig | None = None,
    ) -> None:
        RecordConstructorArgs.__init__(self, style=style, config=config)
        gym.Wrapper.__init__(self, env)
        self.style_reward = DriverCost(style, config)  # type: ignore[assignment]
