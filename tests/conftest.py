import os
import pickle
from dataclasses import replace

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # headless pygame for every test
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def paper_demo():
    """The paper scenario's p = 0.7 SMPC demonstration (generated once per session)."""
    from drivestyle.agents import generate_demonstration

    return generate_demonstration(0.7, "paper")[0]


def _build_style_library(workers: int):
    from drivestyle.agents.demo_generation import (
        draw_interactive_scenarios,
        generate_demonstrations,
    )
    from drivestyle.irl.identification.library import learn_library
    from drivestyle.irl.identification.paper_scorers import MIN_MEMBERS

    scenarios = draw_interactive_scenarios(MIN_MEMBERS, seed=0)
    demos = generate_demonstrations([0.5, 0.95], scenarios, workers=workers)
    meta = {"seed": 0, "training_scenarios": [sc.to_dict() for sc in scenarios]}
    return learn_library(demos, "reactive", workers=workers, meta=meta)


@pytest.fixture(scope="session")
def style_library(tmp_path_factory, worker_id):
    """A small style library: p = 0.5 and 0.95 learned in 5 interactive scenarios (seed 0),
    the fewest training scenarios identification answers from.

    Built once per run: under xdist the first worker to ask builds it (one process: the
    other worker keeps its core) and pickles it beside the workers' temp folders; the
    others wait on the lock and load it (≈ 14 s each saved)."""
    if worker_id == "master":
        return _build_style_library(workers=2)
    from filelock import FileLock

    shared = tmp_path_factory.getbasetemp().parent / "style_library.pkl"
    with FileLock(str(shared) + ".lock"):
        if shared.is_file():
            return pickle.loads(shared.read_bytes())
        library = _build_style_library(workers=1)
        shared.write_bytes(pickle.dumps(library))
        return library


@pytest.fixture(autouse=True)
def _the_solver_cache_stays_where_it_was():
    """A test that moves ``$DRIVESTYLE_CACHE`` and leaves it moved makes every later test of
    its worker process compile its solvers again (≈ 20 s each): fail the test that does."""
    before = os.environ.get("DRIVESTYLE_CACHE")
    yield
    assert os.environ.get("DRIVESTYLE_CACHE") == before, "the test left $DRIVESTYLE_CACHE moved"


def _as_recorded(demo):
    """A simulated demonstration presented as a recorded episode (observed_view applies)."""
    rng = np.random.default_rng(0)
    others = np.repeat(demo.tv[:, None, :], 2, axis=1).copy()
    others[:, 0, 0] += 30.0  # a leader in the target lane, speed varying (as recorded)
    others[:, 1, 0] += 60.0
    others[:, 1, 1] -= demo.scenario.lane_width
    others[:, :, 3] += 0.01 * rng.standard_normal(others.shape[:2])
    return replace(
        demo, meta={**demo.meta, "episode_id": "sim-as-recorded"}, others=others, origin="recorded"
    )


def _change_the_future(demo, k):
    """The demonstration with its EV, TV and other vehicles moved after sample k."""
    ev, tv, others = demo.ev.copy(), demo.tv.copy(), demo.other_vehicles.copy()
    ev[k + 1 :, 0] += np.linspace(0, 30, demo.n - k - 1)
    ev[k + 1 :, 1] -= 2.0
    ev[k + 1 :, 3] *= 0.5
    tv[k + 1 :, :2] += 7.0
    others[k + 1 :, :, 0] -= 12.0
    others[k + 1 :, :, 3] += 5.0
    return replace(demo, ev=ev, tv=tv, others=others)


@pytest.fixture(scope="session")
def as_recorded():
    """:func:`_as_recorded`: a simulated demonstration presented as a recorded episode."""
    return _as_recorded


@pytest.fixture(scope="session")
def change_the_future():
    """:func:`_change_the_future`: a demonstration whose samples after k are moved."""
    return _change_the_future


@pytest.fixture(scope="session")
def tiny_posterior(tmp_path_factory):
    """A tiny amortized posterior over the stochastic driver's parameters, and its file.

    Trained in about a second on 48 fake series of the encoder's width (whatever channels
    it has: ``series_width``) with θ uniform in the prior's box: its answers mean nothing,
    but it is an estimator of the real shape, for the code that reads one."""
    pytest.importorskip("zuko")
    from drivestyle.irl.amortized.encoder import EncoderConfig
    from drivestyle.irl.amortized.estimator import EstimatorConfig
    from drivestyle.irl.amortized.simulations import (
        EPISODE_FEATURES,
        PARAMETERS,
        parameter_box,
        series_width,
    )
    from drivestyle.irl.amortized.training import Simulations, TrainingConfig, train
    from drivestyle.irl.driver.stochastic_prior import StochasticPrior

    low, high = parameter_box(StochasticPrior())
    rng = np.random.default_rng(0)
    n, width = 48, series_width()
    theta = low + (high - low) * rng.random((n, len(PARAMETERS)))
    xs = tuple(rng.standard_normal((int(rng.integers(5, 30)), width)) for _ in range(n))
    config = EstimatorConfig(
        PARAMETERS, tuple(low), tuple(high), EncoderConfig(width, hidden=8, embedding=4),
        transforms=1, flow_hidden=(16, 16), features=EPISODE_FEATURES,
    )  # fmt: skip
    training = TrainingConfig(epochs=2, batch_size=16, patience=2, seed=0)
    posterior, _ = train(Simulations(theta, xs), config, training, progress=False)
    path = posterior.save(tmp_path_factory.mktemp("posterior") / "posterior.npz")
    return posterior, path


def _recorded_scene(n: int = 31):
    """A small synthetic recorded episode (``origin="recorded"``, an observed mask).

    The EV (lane 0, 10 m/s) changes into lane 1 under the inputs stored in ``u`` (its states
    are their RK4 steps: the recorded inputs reproduce it exactly); the TV follows 20 m
    behind in lane 1 at 11 m/s; vehicle 2, the own-lane leader 30 m ahead at 9 m/s, is
    recorded until sample 20 and continued at constant velocity after it; vehicle 3, 45 m
    ahead in lane 1 at 10 m/s, is recorded from sample 10 on. Observed part: 1 s (5 samples).
    """
    from drivestyle.envs.demonstration import Demonstration
    from drivestyle.envs.dynamics import rk4_step
    from drivestyle.envs.scenario import ScenarioConfig

    dt = 0.2
    sc = ScenarioConfig(
        lane_width=3.75, ev_x=0.0, ev_speed=10.0, tv_gap=-20.0, tv_speed=11.0, v_ref=10.0,
        horizon_s=(n - 1) * dt, check_start=False,
    )  # fmt: skip
    t = np.arange(n) * dt
    u = np.zeros((n - 1, 2))
    u[5:12, 1], u[12:19, 1] = 0.02, -0.02  # steer left, then back
    u[:, 0] = 0.1 * np.sin(np.arange(n - 1) / 4)
    ev = np.zeros((n, 4))
    ev[0] = [0.0, sc.lane_centres[0], 0.0, 10.0]
    for k in range(n - 1):
        ev[k + 1] = rk4_step(ev[k], u[k], dt, sc.l_f, sc.l_r)
    y1, y0 = sc.lane_centres[1], sc.lane_centres[0]
    tv = np.column_stack([-20.0 + 11.0 * t, np.full(n, y1), np.zeros(n), np.full(n, 11.0)])
    lead = np.column_stack([30.0 + 9.0 * t, np.full(n, y0), np.zeros(n), np.full(n, 9.0)])
    late = np.column_stack([45.0 + 10.0 * t, np.full(n, y1), np.zeros(n), np.full(n, 10.0)])
    observed = np.ones((3, n), bool)
    observed[1, 21:] = False
    observed[2, :10] = False
    meta = {"scenario": sc.to_dict(), "episode_id": "synthetic-scene", "observed_until_s": 1.0}
    return Demonstration(
        t=t, ev=ev, tv=tv, u=u, meta=meta, others=np.stack([lead, late], axis=1),
        origin="recorded", observed=observed,
    )  # fmt: skip


@pytest.fixture(scope="session")
def recorded_scene():
    """:func:`_recorded_scene`: a small synthetic recorded episode for ``Recorded-v0``."""
    return _recorded_scene()


@pytest.fixture(scope="session")
def make_env(recorded_scene):
    """``gym.make`` of any drivestyle id; ``Recorded-v0`` gets :func:`_recorded_scene`."""
    import gymnasium as gym

    def make(env_id, **kwargs):
        if env_id == "drivestyle/Recorded-v0":
            kwargs.setdefault("episode", recorded_scene)
        return gym.make(env_id, **kwargs)

    return make
