"""Every vehicle of a recorded scene driving its own identified style (DESIGN §24).

``drivestyle/Recorded-v0``'s ``others="style"`` moves each vehicle with a
:data:`~drivestyle.envs.reactive.Driver`; :func:`style_drivers` builds one per vehicle of a
recorded :class:`~drivestyle.envs.demonstration.Demonstration`, the env's vehicle order
(:mod:`drivestyle.envs.scene_log`: 0 the EV, j ≥ 1 the j-th of ``demo.vehicles``):

- **Identification from the past only.** Every vehicle in the scene at the start is
  identified from samples 0 … start of the scene — nothing later is read — as the joint
  prediction's point prediction identifies a scene's vehicles at t_obs (DESIGN §23): the
  amortized posterior in one pass (:func:`~drivestyle.prediction.joint.identify_vehicles`:
  each vehicle's own view, the posterior's lane shift inside it; its median and
  :data:`~drivestyle.prediction.joint.JOINT_SAMPLES` draws), each candidate's region
  admitting the gap the vehicle kept ahead (:func:`~drivestyle.prediction.joint.admitted`),
  and of those the one whose plans best reproduce its last observed accelerations
  (:func:`~drivestyle.prediction.joint.best_explaining`), without deviation: deterministic
  given the seed. Its lateral target is fixed then: the next lane's centre if it was moving
  laterally, else its lateral position (:func:`~drivestyle.prediction.joint.lane_intent`).
  A vehicle that enters after the start has no past to identify: it has no driver, and the
  env moves it along its log (none does in the shipped splits).
- **Re-planning at every call.** A :class:`StyleDriver` plans with its style's planner
  (:meth:`~drivestyle.irl.driver.style_planner.StylePlanner.plan`, the stochastic driver's
  planner of :data:`~drivestyle.prediction.joint.PLANNER_SLOTS` vehicles, the nearest) against
  the other vehicles' current states — the vehicles not in the scene (NaN rows) left out,
  the agent included — warm-started from its previous plan, and returns the plan's first
  input [a, δ]. A failed plan applies the previous plan's next input while one remains, else
  brakes at a_min/2 (the closed loop's rule,
  :func:`~drivestyle.irl.driver.driver_style.closed_loop`); braking never reverses the car
  (a ≥ −v/T_s). A call that does not follow the previous one by T_s (a reset) starts cold.
- **Whom it plans around** (``attend``, :data:`ATTEND`): ``"ahead"`` (default), as the joint
  prediction's rollout, the vehicles ahead of it in any lane and, when it heads for another
  lane, that lane's vehicles behind too (:func:`~drivestyle.prediction.joint.constraining`);
  ``"lanes"``, only those ahead in its own lane and the lane it heads for (the vehicles a
  lane keeper and a lane changer answer to, as IDM and MOBIL); ``"all"``, every other
  vehicle in the scene. The style's planner predicts each vehicle it constrains with the
  paper's TV uncertainty (σ_vx = 6 m/s, σ_vy = 3.75 m/s, DESIGN §3): a neighbour beside or
  a follower behind soon covers the driver's own lane, and a cautious style planning around
  it escapes at full throttle, or finds no plan and brakes (DESIGN §24 has the numbers).

**The frame.** The env's states are the demonstration's road frame, and so are the drivers'
inputs and targets. Three things differ from the env's scenario inside the plans only:

- the heading bound is the recorded one (:data:`~drivestyle.recorded.real_data.
  RECORDED_PHI_MAX`, 0.3 rad: the scenario's 0.05 rad is a highway lane change's, and a
  recorded vehicle in stop-and-go starts beyond it, from where no plan exists); the steering
  bound stays the env's, the one its bicycle applies;
- a vehicle outside the planner's road (the scenario's lanes; recorded vehicles one lane
  beyond them: y = −3.0 m and 11.5 m on the validation split) plans in the frame moved
  laterally by whole lanes that puts it in the middle lane, and keeps that frame while it
  stays on the frame's road — the kinematic bicycle and the constraints do not depend on y,
  so its inputs are the same; its previous plan moves with the frame;
- the lateral target stays on the plans' road (at most the outer lanes' centres): a vehicle
  of the outer lane drifting outwards at the start heads for a lane the scenario does not
  have (the lane-change run-up of the CATS cars), and would otherwise press against the
  road's edge.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.scene_log import scene_log
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.irl.driver.stochastic import StochasticStyle
from drivestyle.irl.driver.style_planner import StylePlanner, planner_for
from drivestyle.prediction.joint import (
    JOINT_SAMPLES,
    PLANNER_SLOTS,
    constraining,
    lane_intent,
    scene_candidates,
)
from drivestyle.recorded.real_data import RECORDED_PHI_MAX

if TYPE_CHECKING:
    from drivestyle.planning.description import PrimalDual

__all__ = [
    "ATTEND",
    "MIN_PAST",
    "SceneStyles",
    "StyleDriver",
    "attended",
    "planning_scenario",
    "scene_styles",
    "style_drivers",
]

MIN_PAST = 3
"""Samples of the past identification needs (the start must be sample 2 or later)."""
ATTEND = ("ahead", "lanes", "all")
"""The vehicles a style driver plans around (module docstring): the joint prediction's
(ahead, and the target lane's), those of its lanes only, or every other vehicle."""


def attended(
    states: np.ndarray, i: int, y_ref: float, lane_width: float, attend: str
) -> np.ndarray:
    """The vehicles vehicle i's plan keeps clear of (``attend``, module docstring).

    Args:
        states: every vehicle's current state [x, y, φ, v], shape (V, 4), the vehicles in
            the scene only.
        i: the planning vehicle.
        y_ref: where it heads laterally [m] (lane i covers [i·w, (i + 1)·w)).
        lane_width: w [m].
        attend: one of :data:`ATTEND`.

    Returns:
        The indices j ≠ i of those vehicles.
    """
    if attend == "ahead":
        return constraining(states, i, y_ref, lane_width)
    keep = np.ones(len(states), bool)
    if attend == "lanes":
        lanes = np.floor(states[:, 1] / lane_width)
        own, target = lanes[i], math.floor(y_ref / lane_width)
        keep = (lanes == own) & (states[:, 0] > states[i, 0])
        keep |= (target != own) & (lanes == target)
    keep[i] = False
    return np.flatnonzero(keep)


def planning_scenario(scenario: ScenarioConfig) -> ScenarioConfig:
    """The scenario of a style driver's plans: the env's, with the recorded heading bound."""
    return replace(scenario, phi_max=max(scenario.phi_max, RECORDED_PHI_MAX))


class StyleDriver:
    """One vehicle's identified style as a :data:`~drivestyle.envs.reactive.Driver`.

    Stateful (its last plan warm-starts the next, module docstring): one per vehicle and
    replay. ``driver(j, t, states) → [a, δ]``.
    """

    def __init__(
        self,
        vehicle: int,
        style: StochasticStyle,
        y_ref: float,
        scenario: ScenarioConfig,
        planner: StylePlanner | None = None,
        attend: str = "ahead",
    ) -> None:
        """A driver of ``vehicle``.

        Args:
            vehicle: its index in the scene (0 the EV).
            style: its style (its planner's weights, risk, v_ref and region; a deviation,
                if it has one, is not applied: the driver is deterministic).
            y_ref: the lateral position its plans aim for, in the env's frame [m].
            scenario: the env's scenario (lanes, geometry, bounds, T_s).
            planner: its planner (default: :func:`planner_for` the style's horizon and
                :data:`~drivestyle.prediction.joint.PLANNER_SLOTS` vehicles).
            attend: the vehicles it plans around (:data:`ATTEND`; default the joint
                prediction's).

        Raises:
            ValueError: an unknown ``attend``.
        """
        if attend not in ATTEND:
            raise ValueError(f"attend must be one of {ATTEND}, got {attend!r}")
        self.attend = attend
        self.vehicle = vehicle
        self.style = style
        self.y_ref = float(y_ref)
        self.scenario = planning_scenario(scenario)
        self.planner = planner or planner_for(self.scenario, style.horizon, PLANNER_SLOTS)
        self._drive = style.driver_style()
        self.plans = 0
        """Plans made (diagnostics)."""
        self.failures = 0
        """Plans that failed (the previous plan's next input or braking applied)."""
        self._shift = 0.0
        self._previous: PrimalDual | None = None
        self._spare = np.empty((0, 2))
        self._last_t: float | None = None

    def _inside(self, y: float) -> bool:
        lo, hi = self.scenario.y_bounds
        return lo <= y <= hi

    def _frame_shift(self, y: float) -> float:
        """The plans' lateral shift [m] (module docstring).

        Kept while the vehicle is on the plans' road, else the one that moves its lane to
        the middle lane.
        """
        if self._inside(y + self._shift):
            return self._shift
        sc = self.scenario
        w = sc.lane_width
        return w * ((sc.n_lanes - 1) // 2 - math.floor(y / w))

    def _target(self, shift: float) -> float:
        """y_ref in the plans' frame, on their road: the nearest lane centre at most [m]."""
        sc = self.scenario
        w = sc.lane_width
        return min(max(self.y_ref + shift, 0.5 * w), (sc.n_lanes - 0.5) * w)

    def __call__(self, j: int, t: float, states: np.ndarray) -> np.ndarray:
        """Vehicle j's input [a, δ] at time t from every vehicle's state (module docstring).

        Raises:
            ValueError: j is another vehicle than this driver's, or its state is not finite.
        """
        if int(j) != self.vehicle:
            raise ValueError(
                f"the style driver of vehicle {self.vehicle} was asked for vehicle {j}"
            )
        states = np.asarray(states, dtype=float)
        xi0 = states[j].copy()
        if not np.all(np.isfinite(xi0)):
            raise ValueError(f"vehicle {j} is not in the scene at t = {t} s: no input to plan")
        sc = self.scenario
        if self._last_t is None or abs(t - self._last_t - sc.dt) > 0.5 * sc.dt:
            self._previous, self._spare = None, np.empty((0, 2))  # a new replay: cold
        self._last_t = float(t)
        shift = self._frame_shift(float(xi0[1]))
        if shift != self._shift:  # a new lane: the previous plan moved with the frame
            if self._previous is not None:
                w = self._previous.w.copy()
                w[self.planner.layout.ix[:, 1]] += shift - self._shift
                self._previous = replace(self._previous, w=w)
            self._shift = shift
        scene = states[np.all(np.isfinite(states), axis=1) | (np.arange(len(states)) == j)]
        me = int(np.sum(np.all(np.isfinite(states[:j]), axis=1)))  # j's row in the scene
        others = scene[attended(scene, me, self.y_ref, sc.lane_width, self.attend)]
        xi0[1] += shift
        others[:, 1] += shift
        res = self.planner.plan(
            xi0, others, self._drive, sc, self._previous, y_ref=self._target(shift)
        )
        self.plans += 1
        if res.ok and res.point is not None:
            u = res.u0.copy()
            self._previous = res.point
            self._spare = res.point.w[self.planner.layout.iu][1:]
        else:
            self.failures += 1
            self._previous = None
            if len(self._spare):
                u, self._spare = self._spare[0].copy(), self._spare[1:]
            else:
                u = np.array([sc.a_min / 2, 0.0])
        u[0] = max(float(u[0]), min(-float(xi0[3]) / sc.dt, 0.0))  # braking stops the car
        return u


def style_drivers(
    posterior: NeuralPosterior,
    demo: Demonstration,
    start: int,
    seed: int = 0,
    attend: str = "ahead",
) -> dict[int, StyleDriver]:
    """Each vehicle of a recorded scene identified from samples 0 … ``start``, as a driver.

    Args:
        posterior: the amortized posterior (build-posterior's; its parameters
            :data:`~drivestyle.irl.amortized.simulations.PARAMETERS`).
        demo: the recorded scene (a :class:`Demonstration` with a scenario).
        start: the replay's first sample: the last one read (≥ 2).
        seed: seeds the posterior draws (the median's and the candidates').
        attend: the vehicles each driver plans around (:data:`ATTEND`).

    Returns:
        {vehicle: driver} for every vehicle in the scene at ``start``, the env's order
        (module docstring); vehicles that enter later have none.

    Raises:
        ValueError: a start outside the episode or before sample 2; an estimator of other
            parameters (:class:`~drivestyle.prediction.protocol.ForecastError`); an unknown
            ``attend``.
    """
    if attend not in ATTEND:
        raise ValueError(f"attend must be one of {ATTEND}, got {attend!r}")
    log = scene_log(demo)
    start = log.check_start(start)
    if start < MIN_PAST - 1:
        raise ValueError(
            f"the style drivers are identified from the samples up to the start: it must be "
            f"sample {MIN_PAST - 1} or later ({MIN_PAST} samples of the past), got {start}"
        )
    vehicles = np.flatnonzero(log.present[start]).tolist()
    past = log.states[: start + 1][:, vehicles]  # samples 0 … start: nothing later
    sc = log.scenario
    w = sc.lane_width
    drivers = {}
    found = scene_candidates(posterior, past, sc, JOINT_SAMPLES, seed, demo.origin)
    for i, (j, candidates) in enumerate(zip(vehicles, found, strict=True)):
        style = candidates[0]  # the point prediction's driver
        drivers[j] = StyleDriver(j, style, lane_intent(past[:, i, 1], sc.dt, w), sc, attend=attend)
    return drivers


@dataclass(frozen=True)
class SceneStyles:
    """``Recorded-v0``'s ``posterior=``: each start's :func:`style_drivers` of a scene."""

    posterior: NeuralPosterior
    seed: int = 0

    def __call__(self, demo: Demonstration, start: int) -> dict[int, StyleDriver]:
        """:func:`style_drivers` of ``demo`` from ``start``."""
        return style_drivers(self.posterior, demo, start, self.seed)


@functools.lru_cache(maxsize=2)
def _opened(path: str) -> NeuralPosterior:
    """The posterior of ``path``, loaded once per process (many envs of one file)."""
    return open_posterior(path, "posterior=")


def scene_styles(posterior: NeuralPosterior | str | Path) -> SceneStyles:
    """The ``style`` entry point of the ``drivestyle.scene_drivers`` group (``Recorded-v0``).

    Args:
        posterior: the amortized posterior, or its file (build-posterior's
            ``OUT/posterior.npz``, opened once per process).

    Raises:
        FileNotFoundError: no such file.
        ValueError: a file that is no estimator of the stochastic driver, or neither a
            posterior nor a path.
        RuntimeError: torch or zuko (the ``sbi`` extra) missing.
    """
    if isinstance(posterior, (str, Path)):
        return SceneStyles(_opened(str(Path(posterior).resolve())))
    if not isinstance(posterior, NeuralPosterior):
        raise ValueError(
            "posterior= must be an amortized posterior or its file (drivestyle build-posterior's "
            f"OUT/posterior.npz), got {posterior!r}"
        )
    return SceneStyles(posterior)
