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
states of both); from the episode's first state (less a draw of the tracker's error there
where the episode is noisy, :func:`start_state`); with the episode's measurement noise on
the EV and its tracker (the surrounding vehicles stay the episode's). Replicate k of a
check seeded s has the seed :func:`replicate_seed`(s, k).
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

__all__ = ["replicate", "replicate_seed", "scene_of", "start_state"]


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


def start_state(
    view: Demonstration, scenario: ScenarioConfig, noise: float, rng: np.random.Generator
) -> np.ndarray:
    """A replicate's start: the episode's first state, less a draw of the tracker's error there.

    With position noise σ > 0 the first state is the tracker's estimate ŝ_0 = s_0 + ε, at
    the edge of the smoother where it errs most (0.19 m of noise: 0.9 m/s and 0.09 rad in
    one episode). Starting every replicate at ŝ_0 makes them agree with each other where
    the episode's own start was elsewhere, and a speed change the tracked episode shows
    becomes an outlier. So the start is drawn from s_0 | ŝ_0 under a flat prior: ŝ_0 − ε_k,
    with ε_k the error of the tracker (:func:`~drivestyle.envs.tracking.observe`) on the
    episode's tracked path with fresh noise. The result is clipped into the planner's road,
    heading and speed bounds (from outside them no plan exists).

    Args:
        view: the episode as identification sees it.
        scenario: its scenario.
        noise: σ of the position noise [m] (0: the first state as it is).
        rng: the generator of the tracker's noise.

    Returns:
        [x, y, φ, v], shape (4,).
    """
    first = np.array(view.ev[0], dtype=float)
    if noise > 0:
        first -= observe(view, noise, rng, recover=False).ev[0] - view.ev[0]
    x, y, phi, v = (float(s) for s in first)
    sc = scenario
    lo, hi = sc.y_bounds
    return np.array([x, min(max(y, lo), hi), min(max(phi, -sc.phi_max), sc.phi_max),
                     min(max(v, 0.0), sc.v_max)])  # fmt: skip


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
            start, :func:`start_state`).
        noise: σ of the position noise on the EV [m].
        prior: the prior whose speed limit applies (default: :class:`StochasticPrior`'s).

    Returns:
        The simulated episode, its surrounding vehicles and observed mask the episode's.
    """
    style = style_of(theta, scenario.ev_speed)
    limit = (prior or StochasticPrior()).speed_limit(float(style.v_ref or 0.0), scenario.ev_speed)
    sc = replace(scenario, v_max=min(scenario.v_max, max(limit, scenario.v_ref, scenario.ev_speed)))
    start = start_state(view, sc, noise, np.random.default_rng([seed, 1]))
    sim = simulate_episode(style, sc, seed, vehicles=view.vehicles, noise=noise,
                           start=start)  # fmt: skip
    return replace(sim, tv=view.tv, observed=observed_mask(view))
