"""A prior over stochastic drivers and the scenes they drive in (DESIGN §21).

:class:`StochasticPrior` holds a range for every parameter of a
:class:`~drivestyle.irl.driver.stochastic.StochasticStyle` — p, the desired speed (as a
ratio to the EV's start speed, so a driver in stop-and-go traffic does not want 30 m/s),
T, s_0, the lateral factor (log-uniform), t_on, σ_a, σ_δ, τ — and for scenes: the EV's
start speed from stop-and-go to free flow (2–35 m/s), the TV in the target lane beside or
behind it, and with some probability a slower leader in the EV's lane and a leader in the
target lane, all at constant velocity, on lanes 3.2–5.25 m wide, under heading and
steering bounds that narrow with speed from the driver model's on recorded traffic to the
paper's, and a speed limit above the driver's desired speed; and the measurement noise on
positions (0–0.2 m). Every parameter is drawn uniformly from its range (the lateral factor and τ
log-uniformly). :meth:`StochasticPrior.draw` gives n :class:`EpisodeParams`, deterministic
given the seed; :meth:`StochasticPrior.simulate` (:func:`simulate_params`) drives one
(:func:`~drivestyle.irl.driver.stochastic.simulate_episode`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.traffic import TrafficScene, VehicleSpec
from drivestyle.irl.driver.stochastic import StochasticStyle, simulate_episode
from drivestyle.recorded.real_data import RECORDED_DELTA_MAX, RECORDED_PHI_MAX

__all__ = ["EpisodeParams", "StochasticPrior", "simulate_params"]

Range = tuple[float, float]


@dataclass(frozen=True)
class EpisodeParams:
    """One draw of the prior: the driver, its scene and the measurement noise."""

    style: StochasticStyle
    """The driver (its true parameters)."""
    scene: TrafficScene
    """The scene (constant-velocity vehicles, TV first)."""
    noise: float
    """σ of the position noise [m]."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"style": self.style.to_json(), "scene": self.scene.to_dict(), "noise": self.noise}

    @classmethod
    def from_json(cls, raw: dict[str, Any]) -> EpisodeParams:
        """Inverse of :meth:`to_json`."""
        return cls(StochasticStyle.from_json(raw["style"]), TrafficScene.from_dict(raw["scene"]),
                   float(raw["noise"]))  # fmt: skip


def _check_range(name: str, r: Any, lo: float, hi: float) -> None:
    ok = (
        isinstance(r, tuple)
        and len(r) == 2
        and all(isinstance(x, (int, float)) and math.isfinite(x) for x in r)
        and lo <= r[0] <= r[1] <= hi
    )
    if not ok:
        raise ValueError(
            f"{name} must be a range (low, high) with {lo:g} <= low <= high <= {hi:g}, got {r!r}"
        )


@dataclass(frozen=True)
class StochasticPrior:
    """Ranges of the drivers' parameters and of the scenes (module docstring)."""

    risk: Range = (0.5, 0.99)
    """p."""
    speed_ratio: Range = (0.9, 1.3)
    """v_ref / the EV's start speed."""
    time_gap: Range = (0.0, 2.0)
    """T [s]."""
    min_gap: Range = (2.0, 20.0)
    """s_0 [m]."""
    lateral: Range = (0.25, 4.0)
    """Factor on w_y (log-uniform)."""
    onset: Range = (0.0, 2.0)
    """t_on [s]."""
    sigma_a: Range = (0.0, 0.5)
    """σ_a [m/s²]."""
    sigma_delta: Range = (0.0, 0.004)
    """σ_δ [rad]."""
    tau: Range = (0.2, 3.0)
    """τ [s] (log-uniform)."""
    ev_speed: Range = (2.0, 35.0)
    """The EV's start speed [m/s]: stop-and-go to free flow."""
    tv_speed_ratio: Range = (0.8, 1.25)
    """The TV's speed / the EV's."""
    tv_gap_headways: Range = (-2.0, 0.5)
    """The TV's start gap x_TV − x_EV in headways of (5 m + 1 s · v_EV)."""
    leader_probability: float = 0.5
    """Chance of a slower leader in the EV's lane, and (independently) of a leader in the
    target lane ahead of the TV."""
    leader_gap_regions: Range = (1.3, 3.0)
    """A leader's start gap in the driver's regions l_a = s_0 + T·v (it starts outside it)."""
    leader_speed_ratio: Range = (0.6, 1.0)
    """The EV-lane leader's speed / the EV's."""
    noise: Range = (0.0, 0.2)
    """σ of the position noise [m]."""
    lane_width: Range = (3.2, 5.25)
    """The lanes' width [m]: from a US freeway's (NGSIM 3.6–3.7 m; the CATS test track's
    ≈ 3.5 m) to the paper's 5.25 m. A lane change across 3.5 m is another motion than one
    across 5.25 m; a prior of one width would teach the estimator only the paper's."""
    horizon_s: float = 8.0
    """Episode length [s]."""
    lateral_speed_max: float = 2.5
    """The scenes' heading bound is φ_max = this / v [rad] at the scene's speed v =
    max(v_ref, the EV's start speed) [m/s], between the paper's 0.05 rad and the driver
    model's on recorded traffic (0.3 rad): a car at 2 m/s turns harder than one at 30 m/s
    (under the paper's 0.05 rad it moves sideways at 0.1 m/s at 2 m/s: no lane change in
    stop-and-go)."""
    lateral_accel_max: float = 8.0
    """The scenes' steering bound is δ_max = this · (l_f + l_r) / v² [rad] at the scene's
    speed, between the paper's 0.05 rad and the recorded 0.25 rad: the recorded bound at
    34 m/s lets the planner swerve at 70 m/s² of lateral acceleration."""
    speed_limit_factor: float = 1.3
    """The scenes' speed bound v_max = this × max(v_ref, the EV's start speed) (≤ 70 m/s).
    Without it a cautious driver with a long time gap beside a TV can run away: its region
    l_a = s_0 + T·v grows with its own speed, each plan holds it over the horizon, so each
    plan sees accelerating as the way out (one driver of T = 1.9 s went from 18 to 58 m/s
    in 8 s)."""

    def __post_init__(self) -> None:
        bounds = {
            "risk": (0.5, 0.99), "speed_ratio": (0.1, 3.0), "time_gap": (0.0, 4.0),
            "min_gap": (1.0, 60.0), "lateral": (0.05, 20.0), "onset": (0.0, 30.0),
            "sigma_a": (0.0, 3.0), "sigma_delta": (0.0, 0.05), "tau": (0.0, 60.0),
            "ev_speed": (0.5, 60.0), "tv_speed_ratio": (0.1, 3.0),
            "tv_gap_headways": (-20.0, 20.0), "leader_gap_regions": (1.0, 20.0),
            "leader_speed_ratio": (0.1, 2.0), "noise": (0.0, 5.0), "lane_width": (2.5, 8.0),
        }  # fmt: skip
        for name, (lo, hi) in bounds.items():
            _check_range(name, getattr(self, name), lo, hi)
        for name in ("lateral", "tau"):
            if getattr(self, name)[0] <= 0:
                raise ValueError(f"{name} is drawn log-uniformly: its low must be > 0")
        if not 0 <= self.leader_probability <= 1:
            p = self.leader_probability
            raise ValueError(f"leader_probability must lie in [0, 1], got {p!r}")
        if not (isinstance(self.speed_limit_factor, (int, float)) and self.speed_limit_factor >= 1):
            raise ValueError(f"speed_limit_factor must be >= 1, got {self.speed_limit_factor!r}")
        for name in ("lateral_speed_max", "lateral_accel_max"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0 < value <= 20):
                raise ValueError(f"{name} must lie in (0, 20], got {value!r}")
        if not (isinstance(self.horizon_s, (int, float)) and 0.4 <= self.horizon_s <= 60):
            raise ValueError(f"horizon_s must lie in [0.4, 60] s, got {self.horizon_s!r}")

    def speed_limit(self, v_ref: float, ev_speed: float) -> float:
        """A scene's v_max: :attr:`speed_limit_factor` × max(v_ref, the EV's start speed), ≤ 70 m/s.

        Args:
            v_ref: the driver's desired speed [m/s].
            ev_speed: the EV's start speed [m/s].
        """
        return float(min(self.speed_limit_factor * max(v_ref, ev_speed), 70.0))

    def _style(self, rng: np.random.Generator, ev_speed: float) -> StochasticStyle:
        u = rng.uniform
        return StochasticStyle(
            risk=float(u(*self.risk)),
            v_ref=float(min(max(ev_speed * u(*self.speed_ratio), 0.5), 69.0)),
            time_gap=float(u(*self.time_gap)),
            min_gap=float(u(*self.min_gap)),
            lateral=float(math.exp(u(*np.log(self.lateral)))),
            onset=float(u(*self.onset)),
            sigma_a=float(u(*self.sigma_a)),
            sigma_delta=float(u(*self.sigma_delta)),
            tau=float(math.exp(u(*np.log(self.tau)))),
        )

    def _scene(
        self, rng: np.random.Generator, ev_speed: float, style: StochasticStyle
    ) -> TrafficScene:
        u = rng.uniform
        v_ref = float(style.v_ref or ev_speed)
        v = max(v_ref, ev_speed)
        paper = ScenarioConfig()
        wheelbase = paper.l_f + paper.l_r
        base = dataclasses.replace(
            paper,
            lane_width=float(u(*self.lane_width)),
            v_max=self.speed_limit(v_ref, ev_speed),
            ev_speed=ev_speed,
            tv_speed=float(ev_speed * u(*self.tv_speed_ratio)),
            tv_gap=float((5.0 + ev_speed) * u(*self.tv_gap_headways)),
            v_ref=v_ref,
            horizon_s=float(self.horizon_s),
            phi_max=float(np.clip(self.lateral_speed_max / v, paper.phi_max, RECORDED_PHI_MAX)),
            delta_max=float(
                np.clip(
                    self.lateral_accel_max * wheelbase / v**2, paper.delta_max, RECORDED_DELTA_MAX
                )
            ),
        )
        region = max(style.driver_style().region(ev_speed, base), base.l_a)
        others = []
        if rng.random() < self.leader_probability:
            speed = max(ev_speed * u(*self.leader_speed_ratio), 0.5)
            others.append(VehicleSpec(base.ev_lane, region * u(*self.leader_gap_regions), speed))
        if rng.random() < self.leader_probability:
            gap = max(base.tv_gap, 0.0) + region * u(*self.leader_gap_regions)
            speed = max(base.tv_speed * u(*self.leader_speed_ratio), 0.5)
            others.append(VehicleSpec(base.target_lane, gap, speed))
        return TrafficScene(base, tuple(others))

    def draw(self, n: int, seed: int) -> list[EpisodeParams]:
        """The parameters of n episodes, deterministic given the seed.

        Raises:
            ValueError: n < 0.
        """
        if not (isinstance(n, int) and n >= 0):
            raise ValueError(f"n must be an integer >= 0, got {n!r}")
        rng = np.random.default_rng(seed)
        out = []
        for _ in range(n):
            ev_speed = float(rng.uniform(*self.ev_speed))
            style = self._style(rng, ev_speed)
            scene = self._scene(rng, ev_speed, style)
            out.append(EpisodeParams(style, scene, float(rng.uniform(*self.noise))))
        return out

    def simulate(self, params: EpisodeParams, seed: int) -> Demonstration:
        """The episode of ``params`` (:func:`simulate_params`)."""
        return simulate_params(params, seed)


def simulate_params(params: EpisodeParams, seed: int) -> Demonstration:
    """Drive one drawn episode (:func:`~drivestyle.irl.driver.stochastic.simulate_episode`)."""
    return simulate_episode(params.style, params.scene, seed, noise=params.noise)
