"""A receding-horizon driver style's cost as the environment's reward.

A receding-horizon *driver style* (:mod:`drivestyle.irl.driver.driver_style`, the default
model) gives a per-step reward (:func:`driver_step_cost`, :class:`DriverCostReward`), unlike
the paper model's −θᵀΔf (:mod:`drivestyle.irl.paper.style_reward`): the style's stage cost
of the step,

    w_y (y − y_ref)² + w_φ φ² + w_v (v − v_ref)² + w_a a² + w_δ δ²

(the state after the step, the step's input), plus its constraints as penalties — the
chance constraint g ≥ 0 with κ(p) against each vehicle's current position and covariance
Σ_0 (or, with a look-ahead of J steps, the worst of the stages j = 0 … J with the EV and
the vehicles extrapolated at constant velocity and the prediction covariance Σ_j, as the
style's planner predicts them), the nominal ellipse and the state bounds — and
r = −cost / scale. The scale is the lane term one lane off
(w_y · lane_width²), so a step starting a lane change costs ≈ 1 whatever the style's gauge.

:class:`DriverCostReward` is the paper model's env wrapper
(:class:`~drivestyle.irl.paper.style_reward.LearnedStyleReward`) with this cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.utils import RecordConstructorArgs

from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.driver_style import DriverStyle, load_driver_style
from drivestyle.irl.paper.style_reward import LearnedStyleReward
from drivestyle.planning.chance import chance_margin
from drivestyle.planning.tv_gaussian import PAPER_TV_UNCERTAINTY, TVUncertainty, tv_covariance

__all__ = [
    "COST_TERMS",
    "DriverCost",
    "DriverCostConfig",
    "DriverCostReward",
    "driver_step_cost",
]

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
    (:class:`drivestyle.envs.reward_model.RewardModel`); ``step`` returns the terms of
    :func:`driver_step_cost` as the increment.

    Args:
        style: a :class:`drivestyle.irl.driver.driver_style.DriverStyle` or a driver-style file.
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
    equal the array function's (tests/irl/driver/test_driver_cost.py).
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
        style: a :class:`drivestyle.irl.driver.driver_style.DriverStyle` or a driver-style file.
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
