"""A replicate of an episode: the driver of θ in the episode's own scene (DESIGN §22).

The posterior-predictive check (:mod:`drivestyle.irl.amortized.predictive_check`) compares
an episode with replicates of it, one per parameter draw θ_k. A replicate is the
stochastic driver of θ_k (:func:`~drivestyle.irl.amortized.simulations.style_of`: v_ref =
speed ratio × the scenario's EV start speed) driven by
:func:`~drivestyle.irl.driver.stochastic.simulate_episode` in the episode's scene: the
scenario and bounds identification solves on (:func:`scene_of`: a recorded episode beyond
its heading bound under the recorded bounds, as
:func:`~drivestyle.irl.identification.posterior.identify_driver` sees it), under the
prior's speed limit of its driver; every surrounding vehicle replayed as the episode has
it (they do not react; a recorded episode's constant-velocity continuations are replayed
too, and its observed mask is the replicate's, so the behaviour statistics read the same
states of both), the planner predicting them from velocities re-fitted to their positions
(:func:`planned_vehicles`: a tracker's course at the smoother's edge drifts them
sideways); from the episode's first state; where the episode is noisy, the start and the
TV the replicate's driver sees less a draw of the tracker's error (:func:`truth_draw`);
with the episode's measurement noise on the EV and its tracker (the statistics read the
episode's own surrounding vehicles). Replicate k of a check
seeded s has the seed :func:`replicate_seed`(s, k).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.tracking import observe
from drivestyle.irl.amortized.simulations import style_of
from drivestyle.irl.driver.driver_style import check_demo
from drivestyle.irl.driver.stochastic import simulate_episode
from drivestyle.irl.driver.stochastic_prior import StochasticPrior
from drivestyle.recorded.observed import observed_mask
from drivestyle.recorded.real_data import recorded_view

__all__ = [
    "VEHICLE_FIT_S",
    "planned_vehicles",
    "replicate",
    "replicate_seed",
    "scene_of",
    "truth_draw",
]


def replicate_seed(seed: int, k: int) -> int:
    """The seed of replicate k of a check seeded ``seed`` (independent streams for every pair)."""
    return int(np.random.SeedSequence([seed, k]).generate_state(1)[0])


def scene_of(demo: Demonstration) -> tuple[Demonstration, ScenarioConfig]:
    """The episode as identification sees it, and the scenario its replicates drive in.

    :func:`~drivestyle.recorded.real_data.recorded_view` (a recorded episode beyond its
    scenario's heading bound under the recorded bounds, its inputs recovered under them;
    anything else as it is), then :func:`~drivestyle.irl.driver.driver_style.check_demo`
    (samples T_s apart): the rule of
    :func:`~drivestyle.irl.identification.posterior.identify_driver`.

    Returns:
        (the view, its scenario).
    """
    view = recorded_view(demo)
    return view, check_demo(view)


def truth_draw(
    view: Demonstration, scenario: ScenarioConfig, noise: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """A draw of what the tracker saw: the EV's true start and the surrounding vehicles.

    With position noise σ > 0 the episode's EV and TV states are a tracker's estimates
    ŝ = s + ε (:func:`~drivestyle.envs.tracking.observe`: noise on both, the further
    vehicles exact). Replicates that all start at ŝ_0 and plan against the tracked TV agree
    with each other where the episode's driver, who started at s_0 and saw the true TV, did
    not: a driver who waits for a TV decided 0.7 s later against the true one than against
    any tracked one, and the check called the episode outside. So each replicate draws the
    truth from s | ŝ under a flat prior, ŝ − ε_k, with ε_k the tracker's error on the
    episode's tracked states with fresh noise: the EV's first state (clipped into the
    planner's road, heading and speed bounds, from outside which no plan exists) and the
    TV's whole path. Without noise both are the episode's.

    Args:
        view: the episode as identification sees it.
        scenario: its scenario.
        noise: σ of the position noise [m].
        rng: the generator of the tracker's noise.

    Returns:
        (the EV's start [x, y, φ, v], shape (4,); the surrounding vehicles, shape (n, m, 4),
        TV first).
    """
    first = np.array(view.ev[0], dtype=float)
    vehicles = np.array(view.vehicles, dtype=float)
    if noise > 0:
        tracked = observe(view, noise, rng, recover=False)
        first -= tracked.ev[0] - view.ev[0]
        vehicles[:, 0] -= tracked.tv - view.tv
    x, y, phi, v = (float(s) for s in first)
    sc = scenario
    lo, hi = sc.y_bounds
    start = np.array([x, min(max(y, lo), hi), min(max(phi, -sc.phi_max), sc.phi_max),
                      min(max(v, 0.0), sc.v_max)])  # fmt: skip
    return start, vehicles


VEHICLE_FIT_S = 1.0
"""Half-width of the window over which :func:`planned_vehicles` fits each velocity [s]."""


def planned_vehicles(vehicles: np.ndarray, dt: float) -> np.ndarray:
    """The surrounding vehicles as a replicate's planner sees them: velocities re-fitted.

    The planner predicts every vehicle at constant velocity from its current state (DESIGN
    §21), so a heading error becomes a lateral drift of v·Δφ·t: a tracked TV's course
    errs by 0.03 rad at the edge of the smoother (0.19 m of noise), 1.2 m over a 2 s
    horizon at 20 m/s, and replicates braked for a TV the episode's driver (who saw the
    true one) ignored — speed changes of 3.1 m/s against its 5.2 m/s, recovered to 4.5 with
    this fit. Each velocity (v_x, v_y) is the slope of a least-squares line through the
    vehicle's positions within ±:data:`VEHICLE_FIT_S` (the window shrinking at the ends),
    φ = atan2(v_y, v_x) and v = ‖(v_x, v_y)‖; positions stay as they are. Exact for a
    vehicle at constant velocity and, inside the episode, at constant acceleration; within
    :data:`VEHICLE_FIT_S`/2 × its acceleration at the first and last sample.

    Args:
        vehicles: the episode's surrounding vehicles [x, y, φ, v], shape (n, m, 4).
        dt: T_s [s].

    Returns:
        Shape (n, m, 4).
    """
    vehicles = np.asarray(vehicles, dtype=float)
    n = vehicles.shape[0]
    h = max(round(VEHICLE_FIT_S / dt), 1)
    out = vehicles.copy()
    for k in range(n):
        window = vehicles[max(k - h, 0) : min(k + h, n - 1) + 1, :, :2]  # (w, m, 2)
        t = np.arange(window.shape[0]) * dt
        t = t - t.mean()
        slope = np.einsum("w,wmc->mc", t, window - window.mean(axis=0)) / np.sum(t * t)
        out[k, :, 2] = np.arctan2(slope[:, 1], slope[:, 0])
        out[k, :, 3] = np.hypot(slope[:, 0], slope[:, 1])
    return out


def replicate(
    theta: np.ndarray,
    view: Demonstration,
    scenario: ScenarioConfig,
    seed: int,
    noise: float,
    prior: StochasticPrior | None = None,
) -> Demonstration:
    """One replicate of an episode: the driver of θ in its scene (module docstring).

    The scene's speed bound is lowered to the prior's speed limit of this driver
    (:meth:`~drivestyle.irl.driver.stochastic_prior.StochasticPrior.speed_limit`, never
    below the scenario's v_ref or the EV's start speed): the class is the driver as the
    prior simulates it, and without a limit a cautious driver's speed-scaled region makes
    it run away (DESIGN §21) — on a recorded scene (v_max 70 m/s) replicates gained
    30 m/s in 8 s. A simulated episode's scene already has its driver's limit, so
    replicates of its own θ drive under the same bound.

    Args:
        theta: θ, shape (D,), :data:`~drivestyle.irl.amortized.simulations.PARAMETERS` order.
        view: the episode as identification sees it (:func:`scene_of`).
        scenario: its scenario (:func:`scene_of`).
        seed: the replicate's seed (its driver's deviation and noise; [seed, 1] seeds its
            draw of the truth, :func:`truth_draw`).
        noise: σ of the position noise on the EV [m].
        prior: the prior whose speed limit applies (default: :class:`StochasticPrior`'s).

    Returns:
        The simulated episode, its surrounding vehicles (not the planner's,
        :func:`planned_vehicles`) and observed mask the episode's.
    """
    style = style_of(theta, scenario.ev_speed)
    limit = (prior or StochasticPrior()).speed_limit(float(style.v_ref or 0.0), scenario.ev_speed)
    sc = replace(scenario, v_max=min(scenario.v_max, max(limit, scenario.v_ref, scenario.ev_speed)))
    start, vehicles = truth_draw(view, sc, noise, np.random.default_rng([seed, 1]))
    sim = simulate_episode(style, sc, seed, vehicles=planned_vehicles(vehicles, sc.dt),
                           noise=noise, start=start)  # fmt: skip
    return replace(sim, tv=view.tv, others=view.others, observed=observed_mask(view))
