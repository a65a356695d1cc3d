"""The style as a stochastic driver: the planner and a correlated input deviation (DESIGN §21).

A :class:`StochasticStyle` holds the parameters people differ in — the risk p, the desired
speed v_ref, the region's time gap T and standstill gap s_0 (l_a = s_0 + T·v, DESIGN §18),
how fast it changes lane (a factor on the lane weight w_y) and how early (an onset delay
t_on: before it the driver keeps its own lane as the target) — and a temporally
correlated deviation e_k on the inputs it applies: a stationary AR(1) process
(:func:`ar1_deviation`), the exact sampling at T_s of an Ornstein–Uhlenbeck (Matérn-1/2)
process with per-input scale σ = (σ_a, σ_δ) and correlation time τ. The closed loop
(:func:`closed_loop_stochastic`) is :func:`~drivestyle.irl.driver.driver_style.closed_loop`
with the applied input clip(u_k + e_k) and re-planning from the deviated state: the
planner predicts the other vehicles from their current states, as in every plan.

The SMPC expert is the member with zero deviation and zero onset
(:meth:`StochasticStyle.expert`): its closed loop is the expert's (tested to the bit).
:func:`simulate_episode` drives a style past given (non-reacting) vehicles and returns the
episode as a :class:`~drivestyle.envs.demonstration.Demonstration`, deterministic given
its seed. The prior over styles and scenes is :mod:`drivestyle.irl.driver.stochastic_prior`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.tracking import observe
from drivestyle.envs.traffic import TrafficScene
from drivestyle.irl.driver.driver_style import (
    MIN_GAP_RANGE,
    RISK_RANGE,
    TIME_GAP_RANGE,
    DriverStyle,
    closed_loop,
    expert_style,
)
from drivestyle.irl.driver.style_planner import StylePlanner, planner_for
from drivestyle.planning.description import PrimalDual, SMPCConfig

__all__ = [
    "EXPERT_WEIGHTS",
    "LATERAL_RANGE",
    "ONSET_RANGE",
    "PLANNER_SLOTS",
    "SIGMA_A_MAX",
    "SIGMA_DELTA_MAX",
    "TAU_MAX",
    "StochasticStyle",
    "StochasticStyleError",
    "ar1_deviation",
    "closed_loop_stochastic",
    "constant_velocity",
    "lane_targets",
    "load_planners",
    "planner_slots",
    "simulate_episode",
]

EXPERT_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
"""The SMPC expert's cost [w_y, w_φ, w_v, w_a, w_δ] (:func:`expert_style` of the default
:class:`SMPCConfig`): the stochastic styles' base weights."""
LATERAL_RANGE = (0.05, 20.0)
"""Factors on w_y a style admits (how fast it changes lane; 1: the expert's)."""
ONSET_RANGE = (0.0, 30.0)
"""Onset delays t_on a style admits [s]."""
SIGMA_A_MAX = 3.0
"""The largest deviation scale σ_a a style admits [m/s²] (a third of full braking)."""
SIGMA_DELTA_MAX = 0.05
"""The largest deviation scale σ_δ a style admits [rad] (the steering bound δ_max)."""
TAU_MAX = 60.0
"""The longest correlation time τ a style admits [s]."""


class StochasticStyleError(ValueError):
    """A stochastic style's parameter is invalid; the message names it and its range."""


def ar1_deviation(
    n: int, dt: float, sigma: tuple[float, float] | np.ndarray, tau: float, rng: np.random.Generator
) -> np.ndarray:
    """A stationary AR(1) deviation of the two inputs: an Ornstein–Uhlenbeck process sampled at T_s.

    e_{k+1} = ρ e_k + σ √(1 − ρ²) ε_k,  ρ = exp(−T_s/τ),  e_0 ~ N(0, σ²),  ε_k ~ N(0, I),

    the exact discretisation of de = −e/τ dt + σ √(2/τ) dW (the Matérn-1/2 kernel
    σ² exp(−|t − t'|/τ)): every e_k has variance σ², neighbouring samples correlation ρ.
    τ = 0 gives white noise (ρ = 0); σ = 0 gives zeros. The two inputs are independent.

    Args:
        n: samples (≥ 0).
        dt: T_s, the sampling time [s] (> 0).
        sigma: (σ_a, σ_δ), each ≥ 0 [m/s², rad].
        tau: τ, the correlation time [s] (≥ 0).
        rng: the generator (n + … normal draws: e_0, then ε_0 … ε_{n−2}, two per sample).

    Returns:
        e, shape (n, 2) [m/s², rad].

    Raises:
        ValueError: a negative or non-finite argument.
    """
    s = np.asarray(sigma, dtype=float)
    if s.shape != (2,) or not np.all(np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"sigma must be two finite numbers >= 0 (σ_a, σ_δ), got {sigma!r}")
    if not (isinstance(n, (int, np.integer)) and n >= 0):
        raise ValueError(f"n must be an integer >= 0, got {n!r}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be > 0 s, got {dt!r}")
    if not (math.isfinite(tau) and tau >= 0):
        raise ValueError(f"tau must be >= 0 s, got {tau!r}")
    rho = math.exp(-dt / tau) if tau > 0 else 0.0
    eps = rng.standard_normal((n, 2))
    e = np.empty((n, 2))
    if n == 0:
        return e
    scale = s * math.sqrt(1.0 - rho * rho)
    e[0] = s * eps[0]
    for k in range(1, n):
        e[k] = rho * e[k - 1] + scale * eps[k]
    return e


def _in_range(name: str, value: Any, lo: float, hi: float, unit: str) -> None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and lo <= value <= hi
    if not ok:
        raise StochasticStyleError(f"{name} must lie in [{lo:g}, {hi:g}]{unit}, got {value!r}")


@dataclass(frozen=True)
class StochasticStyle:
    """One stochastic driver: the planner's parameters people differ in, and its deviation.

    Defaults: the SMPC expert's cost at p = 0.7, the scenario's v_ref and fixed ellipse, no
    delay and no deviation.
    """

    risk: float = 0.7
    """p of the chance constraint, in :data:`RISK_RANGE`."""
    v_ref: float | None = None
    """Desired speed [m/s]; None: the scenario's v_ref."""
    time_gap: float = 0.0
    """T: the region's growth with speed, l_a = s_0 + T·v [s] (:data:`TIME_GAP_RANGE`)."""
    min_gap: float | None = None
    """s_0: the region at standstill [m] (:data:`MIN_GAP_RANGE`); None: the scenario's l_a."""
    lateral: float = 1.0
    """Factor on the lane weight w_y: how fast it changes lane (:data:`LATERAL_RANGE`)."""
    onset: float = 0.0
    """t_on: before it the driver's target is its own lane, after it the scenario's
    target lane [s] (:data:`ONSET_RANGE`)."""
    sigma_a: float = 0.0
    """σ_a: the acceleration deviation's scale [m/s²] (≤ :data:`SIGMA_A_MAX`)."""
    sigma_delta: float = 0.0
    """σ_δ: the steering deviation's scale [rad] (≤ :data:`SIGMA_DELTA_MAX`)."""
    tau: float = 1.0
    """τ: the deviation's correlation time [s] (≤ :data:`TAU_MAX`; 0: white)."""
    weights: tuple[float, ...] = EXPERT_WEIGHTS
    """The base cost [w_y, w_φ, w_v, w_a, w_δ] that ``lateral`` scales."""
    horizon: int = 10
    """N: the planning horizon [steps of T_s]."""

    def __post_init__(self) -> None:
        _in_range("risk", self.risk, *RISK_RANGE, "")
        if self.v_ref is not None:
            _in_range("v_ref", self.v_ref, 0.1, 69.9, " m/s")
        _in_range("time_gap", self.time_gap, *TIME_GAP_RANGE, " s")
        if self.min_gap is not None:
            _in_range("min_gap", self.min_gap, *MIN_GAP_RANGE, " m")
        _in_range("lateral", self.lateral, *LATERAL_RANGE, "")
        _in_range("onset", self.onset, *ONSET_RANGE, " s")
        _in_range("sigma_a", self.sigma_a, 0.0, SIGMA_A_MAX, " m/s²")
        _in_range("sigma_delta", self.sigma_delta, 0.0, SIGMA_DELTA_MAX, " rad")
        _in_range("tau", self.tau, 0.0, TAU_MAX, " s")
        try:
            self.driver_style()
        except ValueError as exc:
            raise StochasticStyleError(str(exc)) from None
        object.__setattr__(self, "weights", tuple(float(w) for w in self.weights))

    @classmethod
    def expert(cls, config: SMPCConfig | None = None) -> StochasticStyle:
        """The SMPC expert as the member with zero deviation and zero onset."""
        base = expert_style(config or SMPCConfig())
        return cls(risk=base.risk, weights=base.weights, horizon=base.horizon, sigma_a=0.0,
                   sigma_delta=0.0, onset=0.0)  # fmt: skip

    @property
    def sigma(self) -> tuple[float, float]:
        """(σ_a, σ_δ) [m/s², rad]."""
        return (float(self.sigma_a), float(self.sigma_delta))

    @property
    def deterministic(self) -> bool:
        """No deviation: the planner's own closed loop."""
        return self.sigma_a == 0 and self.sigma_delta == 0

    def driver_style(self) -> DriverStyle:
        """The planner's style: the weights with w_y × ``lateral``, p, v_ref, T, s_0, N."""
        w = (self.weights[0] * self.lateral, *self.weights[1:]) if self.weights else ()
        return DriverStyle(w, risk=self.risk, v_ref=self.v_ref, horizon=self.horizon,
                           time_gap=self.time_gap, min_gap=self.min_gap)  # fmt: skip

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (a simulated episode's ``meta["stochastic_style"]``)."""
        return {
            "risk": self.risk, "v_ref": self.v_ref, "time_gap": self.time_gap,
            "min_gap": self.min_gap, "lateral": self.lateral, "onset": self.onset,
            "sigma_a": self.sigma_a, "sigma_delta": self.sigma_delta, "tau": self.tau,
            "weights": list(self.weights), "horizon": self.horizon,
        }  # fmt: skip

    @classmethod
    def from_json(cls, raw: Any) -> StochasticStyle:
        """Inverse of :meth:`to_json`.

        Raises:
            StochasticStyleError: not an object, a key unknown, or a value invalid.
        """
        if not isinstance(raw, dict):
            raise StochasticStyleError(f"a stochastic style must be an object, got {raw!r}")
        known = set(cls().to_json())
        unknown = sorted(set(raw) - known)
        if unknown:
            raise StochasticStyleError(f"unknown stochastic style key(s) {unknown}")
        fields = dict(raw)
        if "weights" in fields:
            fields["weights"] = tuple(fields["weights"])
        return cls(**fields)


def lane_targets(n: int, onset: float, xi0: np.ndarray, scenario: ScenarioConfig) -> np.ndarray:
    """Each step's y_ref: the start lane's centre while t_k < t_on, then the target lane's.

    Args:
        n: steps.
        onset: t_on [s].
        xi0: the start state (its lane: the lane centre nearest its y).
        scenario: lanes, T_s and the target lane.

    Returns:
        y_ref per step, shape (n,) [m].
    """
    centres = scenario.lane_centres
    own = float(centres[int(np.argmin(np.abs(centres - xi0[1])))])
    t = np.arange(n) * scenario.dt
    return np.where(t < onset - 1e-9, own, scenario.y_ref)


def closed_loop_stochastic(
    style: StochasticStyle,
    xi0: np.ndarray,
    vehicles: np.ndarray,
    scenario: ScenarioConfig,
    planner: StylePlanner,
    rng: np.random.Generator,
    previous: PrimalDual | None = None,
) -> tuple[np.ndarray, list[PrimalDual | None], np.ndarray, int]:
    """Drive a stochastic style from ξ0 past the vehicles' given states, re-planning every T_s.

    u_k^applied = clip(u_k^plan + e_k) to the input bounds, e = :func:`ar1_deviation`, with
    a ≥ −v_k/T_s (braking stops the car, never reverses it); the next plan starts from the
    state the applied input leads to, warm-started from the previous plan. Where that state
    would leave the planner's road or heading bounds (from where no plan exists) the
    plan's input is applied instead (DESIGN §21). Before t_on the plans aim at the start
    lane (:func:`lane_targets`). With σ = 0 and t_on = 0 this is
    :func:`~drivestyle.irl.driver.driver_style.closed_loop` exactly (no deviation is
    drawn, no clip is applied).

    Args:
        style: the stochastic style.
        xi0: the start state [x, y, φ, v].
        vehicles: the surrounding vehicles' states at each sample, shape (n, m, 4).
        scenario: target lane, reference speed and bounds.
        planner: the NLP.
        rng: the deviation's generator (untouched when σ = 0).
        previous: the first solve's warm start (None: cold).

    Returns:
        (states (n, 4), each step's plan or None, applied inputs (n−1, 2), failed solves).
    """
    n = vehicles.shape[0]
    deviation = None
    if not style.deterministic:
        deviation = ar1_deviation(n - 1, scenario.dt, style.sigma, style.tau, rng)
    y_refs = lane_targets(n - 1, style.onset, xi0, scenario) if style.onset > 0 else None
    return closed_loop(style.driver_style(), xi0, vehicles, scenario, planner, previous,
                       deviation=deviation, y_refs=y_refs)  # fmt: skip


def constant_velocity(states: np.ndarray, n: int, dt: float) -> np.ndarray:
    """Vehicles that keep their velocity: x += v cos φ t, y += v sin φ t, shape (n, m, 4)."""
    s = np.asarray(states, dtype=float).reshape(-1, 4)
    t = (np.arange(n) * dt)[:, None]
    out = np.repeat(s[None], n, axis=0)
    out[:, :, 0] += t * s[:, 3] * np.cos(s[:, 2])
    out[:, :, 1] += t * s[:, 3] * np.sin(s[:, 2])
    return out


PLANNER_SLOTS = (1, 4)
"""The vehicle slots of the planners :func:`simulate_episode` uses (:func:`planner_slots`)."""


def planner_slots(m: int) -> int:
    """The planner's vehicle slots for m surrounding vehicles: the TV alone, else four.

    One NLP serves every scene of up to four vehicles (:data:`PLANNER_SLOTS`), so a worker
    builds two planners, not one per count.
    """
    return 1 if m == 1 else PLANNER_SLOTS[-1]


def load_planners(horizon: int = 10) -> None:
    """Build the planners :func:`simulate_episode` uses, once in this process.

    A worker's initializer (:func:`~drivestyle.common.parallel.parallel_map`): the NLPs are
    built before the first episode rather than inside its timing. The planners are keyed by
    geometry only (:func:`~drivestyle.irl.driver.style_planner.planner_for`), so the
    default scenario's serve every scene.
    """
    for slots in PLANNER_SLOTS:
        planner_for(ScenarioConfig(), horizon, slots)


def simulate_episode(
    style: StochasticStyle,
    scene: ScenarioConfig | TrafficScene,
    seed: int,
    vehicles: np.ndarray | None = None,
    noise: float = 0.0,
    planner: StylePlanner | None = None,
    start: np.ndarray | None = None,
) -> Demonstration:
    """One episode of a stochastic driver as a demonstration, deterministic given the seed.

    The EV starts at the scenario's initial state (or ``start``); the surrounding vehicles
    move as given (``vehicles``) or, by default, keep their velocity from the scene's start
    (the TV first): they do not react to the EV, as in :func:`reproduce`. The deviation is
    drawn first from ``numpy.random.default_rng(seed)``, then the measurement noise: with
    ``noise`` > 0 the episode is the one a tracker records
    (:func:`~drivestyle.envs.tracking.observe`: N(0, noise²) on the EV's and the TV's x
    and y, RTS-smoothed, the inputs recovered from the tracked states; the further
    vehicles stay exact).

    Args:
        style: the driver.
        scene: a single-TV scenario or a traffic scene (constant-velocity vehicles only).
        seed: the episode's seed.
        vehicles: the surrounding vehicles' states, shape (n, m, 4), TV first; None: the
            scene's, at constant velocity over the scenario's horizon.
        noise: σ of the position noise [m] (≥ 0).
        planner: the NLP (default: the cached one of the geometry: M = 1 with the TV
            alone, else 4).
        start: the EV's start state [x, y, φ, v], shape (4,); None: the scenario's ξ0.

    Returns:
        The demonstration (origin ``"simulated"``; ``meta``: the scenario, the true
        parameters under ``stochastic_style``, ``risk``, the seed, the noise, the scene,
        the failed solves, and with noise the tracker's ``observation``).

    Raises:
        ValueError: a traffic scene with IDM vehicles (they would react to the EV), bad
            vehicle shapes, a start state not of shape (4,) or a negative noise.
    """
    if isinstance(scene, TrafficScene):
        if any(b != "constant" for b in scene.behaviours):
            raise ValueError(
                "simulate_episode moves the vehicles at constant velocity; this scene has "
                f"behaviours {scene.behaviours} (pass their states as vehicles=)"
            )
        sc, starts = scene.base, scene.initial_states()
    else:
        sc, starts = scene, scene.tv_initial_state[None]
    if not (math.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be >= 0 m, got {noise!r}")
    n = sc.n_steps + 1
    if vehicles is None:
        vehicles = constant_velocity(starts, n, sc.dt)
    vehicles = np.asarray(vehicles, dtype=float)
    if vehicles.ndim != 3 or vehicles.shape[1] < 1 or vehicles.shape[2] != 4:
        raise ValueError(f"vehicles must have shape (n, m >= 1, 4), got {vehicles.shape}")
    n = vehicles.shape[0]
    m = vehicles.shape[1]
    planner = planner or planner_for(sc, style.horizon, planner_slots(m))
    xi0 = sc.ev_initial_state if start is None else np.asarray(start, dtype=float)
    if xi0.shape != (4,) or not np.all(np.isfinite(xi0)):
        raise ValueError(f"start must be a finite state [x, y, φ, v], got {start!r}")
    rng = np.random.default_rng(seed)
    xs, _, us, failures = closed_loop_stochastic(style, xi0, vehicles, sc, planner, rng)
    meta: dict[str, Any] = {
        "scenario": sc.to_dict(),
        "risk": float(style.risk),
        "stochastic_style": style.to_json(),
        "seed": int(seed),
        "measurement_noise_m": float(noise),
        "failures": int(failures),
        "generator": "stochastic-driver",
    }
    if isinstance(scene, TrafficScene):
        meta["scene"] = scene.to_dict()
    demo = Demonstration(np.arange(n) * sc.dt, xs, vehicles[:, 0], us, meta,
                         others=vehicles[:, 1:], origin="simulated")  # fmt: skip
    return observe(demo, noise, rng) if noise > 0 else demo
