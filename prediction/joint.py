"""Joint prediction: every observed vehicle drives its own identified style, together (§23).

DESIGN §23. A scene's vehicles — the predicted one and each vehicle observed around it —
are each identified from their *own* past by the amortized posterior (one pass each,
:func:`identify_vehicles`; nothing after sample k is read), then rolled out together
(:func:`joint_rollout`): at every step each vehicle re-plans with its stochastic style's
planner against the others' *rolled-out* current states (the braking of the car ahead
reaches the car behind), applies the plan's input plus its style's correlated deviation,
and all move on. The point prediction is the rollout of every vehicle's posterior median
without deviation (a zero-mean disturbance's best guess); each of S further rollouts draws
every vehicle's parameters from its posterior (draw s of each) and its deviation, so their
spread is the prediction's uncertainty: the 90 % region around the point prediction comes
from them (:class:`JointPrediction`). A vehicle re-plans every :data:`REPLAN_STEPS` steps
(0.4 s at T_s = 0.2 s, a driver's reaction time), applying its plan's inputs in between: half
the solves of re-planning every step.

The same rollout with the others at constant velocity from their last observed states
(``react=False``: only the predicted vehicle is driven by its style) is the single-vehicle
rollout it is compared with (``style_alone``).

A vehicle's view of the scene (:func:`own_view`): its states as the EV, the others as its
neighbours (nearest first), in the road frame moved so that its own lane is lane 0 (the
frame the posterior was trained in: the EV starts in lane 0) and mirrored when it moves
towards −y, its inputs recovered from its states (:func:`~drivestyle.envs.dynamics.
recover_inputs`). Its lateral intent is the physics baseline's rule with a trigger chosen on
validation (:func:`lane_intent`): a vehicle moving laterally faster than it heads for the
next lane's centre in that direction, any other keeps its lateral position — the posterior's
onset, trained on drivers who all change lane, is not used to start a change.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.dynamics import recover_inputs, rk4_step
from drivestyle.envs.lanes import LATERAL_WINDOW_S, lane_change_target
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.amortized.identify import observed_series, one_thread
from drivestyle.irl.amortized.simulations import PARAMETERS, style_of
from drivestyle.irl.driver.driver_style import MIN_GAP_RANGE
from drivestyle.irl.driver.stochastic import StochasticStyle, StochasticStyleError, ar1_deviation
from drivestyle.irl.driver.style_planner import (
    Link,
    PlanRow,
    RowsResult,
    StylePlanner,
    planner_for,
)
from drivestyle.prediction.protocol import ForecastError, Observation, PredictedPath

if TYPE_CHECKING:
    from drivestyle.irl.amortized.estimator import NeuralPosterior

__all__ = [
    "ADMITTED_SHARE",
    "CONSISTENCY_CHECKS",
    "JOINT_SAMPLES",
    "LANE_TRIGGER_MPS",
    "MEDIAN_DRAWS",
    "JointPrediction",
    "JointStyle",
    "admitted",
    "best_explaining",
    "constraining",
    "driven_mask",
    "identify_vehicles",
    "joint_rollout",
    "lane_intent",
    "led",
    "own_view",
    "scene_candidates",
    "scene_states",
]

JOINT_SAMPLES = 8
"""Stochastic rollouts per prediction (posterior draws per vehicle, each with its deviation),
besides the point prediction's: each costs every vehicle one plan per step."""
ADMITTED_SHARE = 0.5
"""The share of the smallest observed gap ahead a vehicle's region may take (:func:`admitted`):
below 1 so that the chance constraint's tightening still finds room."""
CONSISTENCY_CHECKS = 3
"""The last observed samples at which each candidate driver's plan is compared with the
recorded input (:func:`best_explaining`)."""
MEDIAN_DRAWS = 64
"""Posterior draws whose medians make each vehicle's point-prediction driver."""
LANE_TRIGGER_MPS = 0.2
"""The observed lateral speed from which a vehicle is taken to change lane [m/s]. Chosen on
the validation split of every vehicle's episodes (the lateral rule alone, t_obs = 1, 2, 3 s):
the final lateral error's mean 1.02 m over every kind against 1.56 m at the physics
baseline's 0.1 m/s (a lane keeper's wobble taken for a change), the lane changes' median
1.86 m against 1.67 m (a change seen later); 0.3 m/s: 0.80 m and 2.00 m."""
REPLAN_STEPS = 2
"""Steps between a vehicle's plans in a rollout (its plan's inputs applied in between)."""
PLANNER_SLOTS = 4
"""Vehicles each plan constrains (the stochastic driver's planner of traffic scenes)."""


def scene_states(seen: Observation) -> np.ndarray:
    """Every observed vehicle's states, the predicted one first: shape (k + 1, 1 + m, 4)."""
    return np.concatenate([np.asarray(seen.ev)[:, None], np.asarray(seen.vehicles)], axis=1)


def lane_intent(y: np.ndarray, dt: float, lane_width: float) -> float:
    """Where a vehicle heads laterally: the next lane's centre, or its own position [m].

    Args:
        y: its observed lateral positions y_0 … y_k, shape (k + 1,) [m] (lane i covers
            [i·w, (i + 1)·w)).
        dt: T_s [s].
        lane_width: w [m].

    Returns:
        y_ref: the target lane's centre when its lateral speed over the last
        :data:`~drivestyle.envs.lanes.LATERAL_WINDOW_S` reaches :data:`LANE_TRIGGER_MPS`
        (:func:`~drivestyle.envs.lanes.lane_change_target`), else y_k.
    """
    y = np.asarray(y, dtype=float)
    m = min(len(y) - 1, max(1, round(LATERAL_WINDOW_S / dt)))
    if m < 1 or abs(y[-1] - y[-1 - m]) / (m * dt) < LANE_TRIGGER_MPS:
        return float(y[-1])
    lane, _ = lane_change_target(y, dt, lane_width)
    return (lane + 0.5) * lane_width


def constraining(states: np.ndarray, i: int, y_ref: float, lane_width: float) -> np.ndarray:
    """The vehicles vehicle i's plan keeps clear of (ahead; changing lane, the target lane's).

    Those ahead of it, and when it changes lane the target lane's vehicles behind too. The
    planner keeps its vehicle out of every constrained vehicle's region, which is the
    paper's rule for the lane changer and its target-lane follower. Applied to every vehicle
    of dense traffic it makes a vehicle flee a car close behind it in the next lane
    (recorded gaps are often inside those regions: 7 m at 11 m/s on US-101); a driver
    keeping its lane reacts to what is ahead, the car behind being that car's concern.

    Args:
        states: every vehicle's current state [x, y, φ, v], shape (V, 4).
        i: the planning vehicle.
        y_ref: where it heads laterally [m] (its own y: it keeps its lane).
        lane_width: w [m].

    Returns:
        The indices j ≠ i of the vehicles it plans against, shape (≤ V − 1,).
    """
    x, y = states[:, 0], states[:, 1]
    ahead = x > x[i]
    target = math.floor(y_ref / lane_width)
    changing = target != math.floor(y[i] / lane_width)
    beside = changing & (np.floor(y / lane_width) == target)
    keep = ahead | beside
    keep[i] = False
    return np.flatnonzero(keep)


def led(states: np.ndarray, i: int, lane_width: float) -> bool:
    """Whether vehicle i has an observed vehicle ahead in its lane (then it is driven).

    The scene is the observed vehicles only: what limits the head of an observed platoon
    (its own leader, a queue further on) is not in it. Driven by its style on a free road it
    would speed up to its desired speed where the recorded one was held back; so a
    surrounding vehicle without an observed leader keeps its velocity (the open boundary of
    a traffic simulation), and the vehicles behind it react to it.

    Args:
        states: every vehicle's current state [x, y, φ, v], shape (V, 4).
        i: the vehicle.
        lane_width: w [m].
    """
    lanes = np.floor(states[:, 1] / lane_width)
    ahead = (lanes == lanes[i]) & (states[:, 0] > states[i, 0])
    return bool(ahead.any())


def driven_mask(states: np.ndarray, react: bool, lane_width: float) -> np.ndarray:
    """Which vehicles a rollout drives by their style (the others keep their velocity).

    Vehicle 0, and with ``react`` every vehicle with an observed leader (:func:`led`).

    Args:
        states: every vehicle's current state, shape (V, 4).
        react: the others react (``style_joint``) or not (``style_alone``).
        lane_width: w [m].

    Returns:
        Shape (V,) bool.
    """
    return np.array([i == 0 or (react and led(states, i, lane_width)) for i in range(len(states))])


def own_view(states: np.ndarray, j: int, scenario: ScenarioConfig, origin: str) -> Demonstration:
    """Vehicle j's observed past as the EV of a demonstration (module docstring).

    Args:
        states: every vehicle's observed states, shape (k + 1, V, 4), k ≥ 2.
        j: the vehicle.
        scenario: the scene's scenario (lane width, T_s, geometry).
        origin: the scene's origin (``"recorded"`` or ``"simulated"``).

    Returns:
        A demonstration of k + 1 samples: vehicle j as the EV in its lane 0 (mirrored when
        it moves towards −y), the others as its TV and ``others``, nearest first; one
        phantom 1 km behind when it is alone (the extraction's convention).
    """
    states = np.asarray(states, dtype=float)
    n, v = states.shape[:2]
    w, dt = scenario.lane_width, scenario.dt
    ev = states[:, j].copy()
    lane = min(max(math.floor(ev[0, 1] / w), 0), scenario.n_lanes - 1)
    m = min(n - 1, max(1, round(LATERAL_WINDOW_S / dt)))
    sign = -1.0 if ev[-1, 1] - ev[-1 - m, 1] <= -LANE_TRIGGER_MPS * m * dt else 1.0
    rest = [i for i in range(v) if i != j]
    rest.sort(key=lambda i: float(np.hypot(*(states[-1, i, :2] - ev[-1, :2]))))

    def moved(s: np.ndarray) -> np.ndarray:
        out = s.copy()
        if sign > 0:
            out[..., 1] = s[..., 1] - lane * w
        else:  # its lane's left edge becomes y = 0 and −y becomes +y
            out[..., 1] = (lane + 1) * w - s[..., 1]
            out[..., 2] = -s[..., 2]
        return out

    ev = moved(ev)
    if rest:
        others = moved(states[:, rest])
    else:
        others = ev[:, None].copy()
        others[:, 0, 0] -= 1000.0
        others[:, 0, 1] = 1.5 * w
    sc = replace(
        scenario, ev_lane=0, target_lane=1, ev_speed=float(max(ev[0, 3], 0.0)),
        tv_lane=int(np.clip(math.floor(others[0, 0, 1] / w), 0, scenario.n_lanes - 1)),
    )  # fmt: skip
    t = np.arange(n) * dt
    return Demonstration(
        t=t, ev=ev, tv=others[:, 0], u=recover_inputs(ev, sc, t), meta={"scenario": sc.to_dict()},
        others=others[:, 1:] if others.shape[1] > 1 else None, origin=origin,  # type: ignore[arg-type]
        observed=np.ones((others.shape[1], n), bool),
    )  # fmt: skip


def identify_vehicles(
    posterior: NeuralPosterior,
    states: np.ndarray,
    scenario: ScenarioConfig,
    samples: int,
    seed: int,
    origin: str = "recorded",
) -> list[list[StochasticStyle]]:
    """Each vehicle's stochastic styles from its posterior, in one pass over the scene.

    Args:
        posterior: the amortized posterior (parameters :data:`~drivestyle.irl.amortized.
            simulations.PARAMETERS`).
        states: every vehicle's observed states, shape (k + 1, V, 4).
        scenario: the scene's scenario.
        samples: S, draws per vehicle (≥ 1).
        seed: seeds the draws.
        origin: the scene's origin.

    Returns:
        Per vehicle S + 1 styles: first its posterior median (every parameter's median over
        :data:`MEDIAN_DRAWS` draws) without deviation — the point prediction's driver — then
        S draws with their deviations (v_ref = the drawn speed ratio × its first observed
        speed).

    Raises:
        ForecastError: an estimator of other parameters.
    """
    if tuple(posterior.config.names) != PARAMETERS:
        raise ForecastError(
            f"the joint prediction needs an estimator of {PARAMETERS}, got {posterior.config.names}"
        )
    views = [own_view(states, j, scenario, origin) for j in range(states.shape[1])]
    series = [observed_series(view) for view in views]
    with one_thread():
        draws = posterior.sample_batch(series, max(samples, MEDIAN_DRAWS), seed=seed)
    sigma = [PARAMETERS.index(name) for name in ("sigma_a", "sigma_delta")]
    out = []
    for view, theta in zip(views, draws, strict=True):
        speed = float(view.ev[0, 3])
        median = np.median(theta, axis=0)
        median[sigma] = 0.0  # the point prediction drives without the deviation
        out.append([_style(median, speed)] + [_style(theta[s], speed) for s in range(samples)])
    return out


def _style(theta: np.ndarray, speed: float) -> StochasticStyle:
    """:func:`style_of` of a draw; a style's hard ranges enforced (the box is the prior's)."""
    try:
        return style_of(theta, max(speed, 0.5))
    except StochasticStyleError:  # a speed ratio that puts v_ref outside its range
        theta = theta.copy()
        theta[PARAMETERS.index("speed_ratio")] = 1.0
        return style_of(theta, max(speed, 0.5))


@dataclass(frozen=True)
class JointPrediction:
    """Every vehicle's rollouts of one scene, and what is read off them."""

    paths: np.ndarray
    """Positions per rollout, step and vehicle, shape (1 + S, H + 1, V, 2) [m] (rollout 0:
    the point prediction, every vehicle its posterior median without deviation; 1 … S: the
    posterior draws with their deviations; step 0: the last observed positions; vehicle 0
    the predicted one)."""
    reactive: tuple[bool, ...]
    """Per vehicle whether it was driven by its style (else constant velocity)."""
    failures: int = 0
    """Plans no solver solved (the braking fallback applied)."""
    seconds: float = field(default=0.0, compare=False)
    """Wall time of identification and rollouts [s]."""

    @property
    def point(self) -> np.ndarray:
        """The point prediction of every vehicle, shape (H + 1, V, 2)."""
        return self.paths[0]

    @property
    def median(self) -> np.ndarray:
        """The median path of the draws (pointwise), shape (H + 1, V, 2)."""
        return np.median(self.paths[1:], axis=0)

    def region_radius(self, level: float = 0.9) -> np.ndarray:
        """Radius around the point prediction's final position holding ``level`` of the draws'.

        Returns:
            Per vehicle the radius [m], shape (V,).
        """
        final = self.paths[1:, -1]  # (S, V, 2)
        d = np.linalg.norm(final - self.point[-1][None], axis=-1)
        return np.quantile(d, level, axis=0)


def joint_rollout(
    start: np.ndarray,
    styles: Sequence[Sequence[StochasticStyle]],
    y_refs: Sequence[float],
    scenario: ScenarioConfig,
    steps: int,
    seed: int,
    react: bool = True,
    replan: int = REPLAN_STEPS,
) -> tuple[np.ndarray, int]:
    """S rollouts of a scene, every vehicle re-planning against the others' rollouts.

    Args:
        start: every vehicle's current state [x, y, φ, v], shape (V, 4).
        styles: per vehicle its S styles (rollout s drives style s of each).
        y_refs: per vehicle the lateral position its plans aim for [m] (:func:`lane_intent`).
        scenario: road, bounds and T_s (every vehicle's: they share the road frame).
        steps: H.
        seed: seeds the deviations.
        react: False: only vehicle 0 is driven, the others keep their velocity; True: every
            vehicle with an observed vehicle ahead in its lane is driven too (:func:`led`),
            the others keep their velocity.
        replan: steps between a vehicle's plans (≥ 1; 1: every step).

    Returns:
        (states per rollout, step and vehicle, shape (S, H + 1, V, 4); failed plans).
    """
    start = np.asarray(start, dtype=float)
    v_count = start.shape[0]
    s_count = len(styles[0])
    driven = np.flatnonzero(driven_mask(start, react, scenario.lane_width)).tolist()
    sc = scenario
    dt = sc.dt
    planner = planner_for(sc, styles[0][0].horizon, PLANNER_SLOTS)
    rng = np.random.default_rng(seed)
    deviation = np.zeros((s_count, v_count, steps, 2))
    for s in range(s_count):
        for i in driven:
            st = styles[i][s]
            if not st.deterministic:
                deviation[s, i] = ar1_deviation(steps, dt, st.sigma, st.tau, rng)
    xs = np.empty((s_count, steps + 1, v_count, 4))
    xs[:, 0] = start
    lo, hi = np.array([sc.a_min, -sc.delta_max]), np.array([sc.a_max, sc.delta_max])
    drive = [style.driver_style() for per in styles for style in per]  # index i·S + s
    previous: dict[tuple[int, int], object] = {}
    spare: dict[tuple[int, int], np.ndarray] = {}  # the last plan's inputs not yet applied
    failures = 0
    for k in range(steps):
        rows, keys = [], []
        for s in range(s_count):
            for i in driven:
                if k % replan and len(spare.get((s, i), ())):
                    continue  # between plans: the last plan's next input
                others = xs[s, k, constraining(xs[s, k], i, float(y_refs[i]), sc.lane_width)]
                if not len(others):  # nothing to keep clear of: one far behind
                    others = (xs[s, k, i] - np.array([1000.0, 0.0, 0.0, 0.0]))[None]
                guess = planner.guess(xs[s, k, i], previous.get((s, i)))  # type: ignore[arg-type]
                rows.append(PlanRow(xs[s, k, i], others, drive[i * s_count + s],
                                    Link(given=guess), float(y_refs[i])))  # fmt: skip
                keys.append((s, i))
        # a failed plan applies the previous plan's next input (the closed loop's rule), so
        # the generic solvers' far slower re-solve is not needed
        out = planner.solve_rows(rows, sc, fallback=False) if rows else None
        planned = {key: r for r, key in enumerate(keys)}
        for s in range(s_count):
            for i in driven:
                u0 = _next_input(out, planned.get((s, i)), (s, i), previous, spare, planner)
                failures += int(u0 is None)
                if u0 is None:
                    rest = spare.get((s, i), np.empty((0, 2)))
                    u0, spare[s, i] = (rest[0], rest[1:]) if len(rest) else (_brake(sc), rest)
                u = np.clip(u0 + deviation[s, i, k], lo, hi)
                u[0] = max(u[0], min(-xs[s, k, i, 3] / dt, 0.0))  # braking stops the car
                xs[s, k + 1, i] = rk4_step(xs[s, k, i], u, dt, sc.l_f, sc.l_r)
        for i in set(range(v_count)) - set(driven):
            phi, v = xs[:, k, i, 2], xs[:, k, i, 3]
            xs[:, k + 1, i] = xs[:, k, i]
            xs[:, k + 1, i, 0] += v * np.cos(phi) * dt
            xs[:, k + 1, i, 1] += v * np.sin(phi) * dt
    return xs, failures


def admitted(
    style: StochasticStyle, states: np.ndarray, i: int, lane_width: float
) -> StochasticStyle:
    """The style with its region shrunk to the gap vehicle i was seen to accept ahead of it.

    The planner keeps its vehicle out of each vehicle's region l_a = s_0 + T·v ahead
    (a hard constraint). A recorded driver following closer than the identified region
    (CATS: 9 m at 4.5 m/s against l_a = 10 m; the posterior's prior never saw such queues)
    starts inside it, no plan exists, and the closed loop's fallback brakes it to a stop
    where the driver went on following. The smallest centre distance it kept to a vehicle
    ahead in its lane over the observation is a gap it accepts: s_0 and T are scaled down
    together until l_a at its current speed is :data:`ADMITTED_SHARE` of that distance
    (s_0 no lower than the style's range allows). A vehicle without one ahead keeps its
    style.

    Args:
        style: one of its candidate drivers.
        states: every vehicle's observed states, shape (k + 1, V, 4).
        i: the vehicle.
        lane_width: w [m].

    Returns:
        The style, its region admitting the observed gap.
    """
    x, y = states[:, :, 0], states[:, :, 1]
    lanes = np.floor(y / lane_width)
    ahead = (lanes == lanes[:, i : i + 1]) & (x > x[:, i : i + 1])
    ahead[:, i] = False
    if not ahead.any():
        return style
    gap = float(np.min(np.where(ahead, x - x[:, i : i + 1], np.inf)))
    v = float(states[-1, i, 3])
    s0 = style.min_gap if style.min_gap is not None else MIN_GAP_RANGE[0]
    region = s0 + style.time_gap * v
    room = ADMITTED_SHARE * gap
    if region <= room:
        return style
    scale = max(room, MIN_GAP_RANGE[0]) / region
    return replace(
        style,
        min_gap=max(s0 * scale, MIN_GAP_RANGE[0]),
        time_gap=style.time_gap * scale,
    )


def best_explaining(
    states: np.ndarray,
    i: int,
    styles: Sequence[StochasticStyle],
    scenario: ScenarioConfig,
    checks: int = CONSISTENCY_CHECKS,
) -> StochasticStyle:
    """The candidate driver whose plans best reproduce vehicle i's last observed inputs.

    The amortized posterior answers for recorded drivers outside its training scenes too;
    its median may then be a driver who would not have driven as observed (in dense traffic a
    cautious p ≈ 0.96 that brakes to a stop 21 m behind a leader the recorded driver kept
    following). Each candidate — the median and the draws, without deviation — plans at
    each of the last ``checks`` observed samples against the others' observed states; the one
    whose first accelerations are nearest the recorded ones (recovered from the states, least
    squares) drives the point prediction. The draws themselves are left as drawn.

    Args:
        states: every vehicle's observed states, shape (k + 1, V, 4).
        i: the vehicle.
        styles: its candidates (:func:`identify_vehicles`' list: the median first).
        scenario: the scene's scenario.
        checks: observed samples checked (the last ones, each with the input after it).

    Returns:
        The chosen driver, without deviation (the median on a tie).
    """
    n = states.shape[0]
    sc = scenario
    t = np.arange(n) * sc.dt
    u = recover_inputs(states[:, i], sc, t)  # (k, 2): the input over each observed step
    samples = list(range(max(n - 1 - checks, 0), n - 1))
    if not samples:
        return replace(styles[0], sigma_a=0.0, sigma_delta=0.0)
    planner = planner_for(sc, styles[0].horizon, PLANNER_SLOTS)
    y_ref = lane_intent(states[:, i, 1], sc.dt, sc.lane_width)
    best, best_cost = styles[0], math.inf
    for candidate in styles:
        drive = replace(candidate, sigma_a=0.0, sigma_delta=0.0).driver_style()
        cost = 0.0
        for k in samples:
            near = constraining(states[k], i, y_ref, sc.lane_width)
            others = states[k, near] if len(near) else (states[k, i] - [1000.0, 0, 0, 0])[None]
            res = planner.plan(states[k, i], others, drive, sc, y_ref=y_ref)
            cost += float((res.u0[0] - u[k, 0]) ** 2)
        if cost < best_cost - 1e-9:
            best, best_cost = candidate, cost
    return replace(best, sigma_a=0.0, sigma_delta=0.0)


def scene_candidates(
    posterior: NeuralPosterior,
    states: np.ndarray,
    scenario: ScenarioConfig,
    samples: int,
    seed: int,
    origin: str = "recorded",
) -> list[list[StochasticStyle]]:
    """Every vehicle's drivers as a rollout drives them, from its own past (one pass).

    :func:`identify_vehicles`, each candidate's region :func:`admitted` to the gap the
    vehicle kept, and the point-prediction driver first: the candidate that
    :func:`best_explaining` its last observed inputs (without deviation).

    Args:
        posterior: the amortized posterior.
        states: every vehicle's observed states, shape (k + 1, V, 4).
        scenario: the scene's scenario.
        samples: S, posterior draws per vehicle.
        seed: seeds the draws.
        origin: the scene's origin.

    Returns:
        Per vehicle S + 1 drivers: the point prediction's, then the S draws.
    """
    w = scenario.lane_width
    found = identify_vehicles(posterior, states, scenario, samples, seed, origin)
    admitting = [[admitted(style, states, i, w) for style in per] for i, per in enumerate(found)]
    return [
        [best_explaining(states, i, per, scenario), *per[1:]] for i, per in enumerate(admitting)
    ]


def _brake(scenario: ScenarioConfig) -> np.ndarray:
    """[a_min/2, 0]: a failed plan with nothing left of the last one (the expert's rule)."""
    return np.array([scenario.a_min / 2, 0.0])


def _next_input(
    out: RowsResult | None,
    row: int | None,
    key: tuple[int, int],
    previous: dict[tuple[int, int], object],
    spare: dict[tuple[int, int], np.ndarray],
    planner: StylePlanner,
) -> np.ndarray | None:
    """A vehicle's input this step: a new plan's first, the last plan's next, or None."""
    if row is None or out is None:  # between plans
        rest = spare[key]
        u0, spare[key] = rest[0], rest[1:]
        return u0
    res = out.result(row)
    if res.ok and res.point is not None:
        previous[key] = res.point
        spare[key] = res.point.w[planner.layout.iu][1:]
        return res.u0
    previous[key] = None
    return None


_IDENTIFIED: dict[tuple, list[list[StochasticStyle]]] = {}
"""The last scene's identification (:meth:`JointStyle._identified`)."""


@dataclass
class JointStyle:
    """``style_joint`` / ``style_alone``: the stochastic styles rolled out together (or alone).

    A stateful shell around the posterior (:class:`~drivestyle.prediction.protocol.
    Predictor`); :meth:`predict_scene` returns every vehicle's rollouts, :meth:`predict` the
    predicted vehicle's point path and its 90 % radius (``PredictedPath.radius``).
    """

    posterior: NeuralPosterior
    react: bool = True
    """The others re-plan with their styles (False: constant velocity)."""
    samples: int = JOINT_SAMPLES
    seed: int = 0
    origin: str = "recorded"

    def predict_scene(self, seen: Observation, steps: int) -> JointPrediction:
        """Every observed vehicle's rollouts after sample k (module docstring)."""
        import time

        if steps < 1:
            raise ForecastError(f"steps must be >= 1, got {steps}")
        t0 = time.perf_counter()
        states = scene_states(seen)
        if states.shape[0] < 3:
            raise ForecastError(f"identification needs >= 3 observed samples, got {len(states)}")
        sc = seen.scenario
        # every vehicle present at the last observed sample (a phantom 1 km away is none)
        near = np.abs(states[-1, :, 0] - states[-1, 0, 0]) < 500.0
        near[0] = True
        states = states[:, near]
        styles = self._identified(states, sc)
        y_refs = [lane_intent(states[:, i, 1], sc.dt, sc.lane_width) for i in range(len(styles))]
        xs, failures = joint_rollout(states[-1], styles, y_refs, sc, steps, self.seed, self.react)
        reactive = tuple(driven_mask(states[-1], self.react, sc.lane_width).tolist())
        return JointPrediction(xs[..., :2], reactive, failures, time.perf_counter() - t0)

    def _identified(self, states: np.ndarray, sc: ScenarioConfig) -> list[list[StochasticStyle]]:
        """:func:`identify_vehicles` of the scene, kept for the next predictor of it.

        ``style_alone`` and ``style_joint`` of one observation then drive the very same
        draws, and the posterior is sampled once.
        """
        key = (states.tobytes(), sc, self.samples, self.seed, self.origin, id(self.posterior))
        if key not in _IDENTIFIED:
            _IDENTIFIED.clear()  # one observation at a time: the methods of one prediction
            _IDENTIFIED[key] = scene_candidates(
                self.posterior, states, sc, self.samples, self.seed, self.origin
            )
        return _IDENTIFIED[key]

    def predict(self, seen: Observation, steps: int) -> PredictedPath:
        """The predicted vehicle's point path and its 90 % radius (the Predictor protocol)."""
        scene = self.predict_scene(seen, steps)
        return PredictedPath(scene.point[:, 0], radius=float(scene.region_radius()[0]))
