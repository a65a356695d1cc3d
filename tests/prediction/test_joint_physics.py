"""The joint physics predictor (prediction/joint_physics.py): IDM and MOBIL for every vehicle."""

import numpy as np
import pytest
from scipy.optimize import brentq

from drivestyle.envs.scenario import PAPER
from drivestyle.prediction.joint_physics import (
    JointPhysicsBaseline,
    JointPhysicsParams,
    joint_physics_forecast,
    joint_rollout,
    mobil,
    observed_scene,
    stack_scenes,
)
from drivestyle.prediction.methods import predict_demo
from drivestyle.prediction.physics import physics_forecast
from drivestyle.prediction.protocol import Observation

P = JointPhysicsParams()
W, DT, LENGTH = 3.7, 0.2, 4.5
NO_MOBIL = JointPhysicsParams(threshold_mps2=1e6)  # never worth a change


def _cruising(x: float, y: float, v: float, samples: int = 6, vy: float = 0.0) -> np.ndarray:
    """Observed states of a vehicle at constant speed: shape (samples, 4), the last at x."""
    t = (np.arange(samples) - (samples - 1)) * DT
    return np.column_stack([x + v * t, y + vy * t, np.zeros(samples), np.full(samples, v)])


def _scene(*vehicles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ev, surrounding vehicles (k + 1, m, 4)) of observed vehicles, the first predicted."""
    others = np.stack(vehicles[1:], axis=1) if len(vehicles) > 1 else np.zeros((6, 0, 4))
    return vehicles[0], others


def test_a_free_vehicle_accelerates_to_v0_as_the_idm_ode():
    # dv/dt = a (1 − (v/v0)^4) integrates to t(v) = v0/(2a) [artanh(v/v0) + arctan(v/v0)]
    params = JointPhysicsParams(v0_factor=2.0, accel_mps2=1.0)
    dt, v_start, v0 = 0.01, 10.0, 20.0  # v0 = ρ · v_90 = 2 · 10
    ev = _cruising(0.0, 1.85, v_start)
    xy = joint_physics_forecast(ev, np.zeros((6, 0, 4)), dt, 6000, W, LENGTH, 1, params)[:, 0]

    def t_of(v: float) -> float:
        u = v / v0
        return v0 / (2 * params.accel_mps2) * (np.arctanh(u) + np.arctan(u))

    mid = (np.diff(xy[:, 0]) / dt)[::100]  # the speed at t_j + dt/2
    times = (np.arange(6000)[::100] + 0.5) * dt
    exact = [brentq(lambda v, t=t: t_of(v) - t_of(v_start) - t, v_start, v0 - 1e-12) for t in times]
    assert np.allclose(mid, exact, atol=0.01)
    assert np.all(np.diff(xy[:, 0]) / dt < v0) and mid[-1] > 0.99 * v0
    assert np.all(xy[:, 1] == 1.85)  # no lateral motion, no lane change alone


@pytest.mark.parametrize("vy", [0.0, 0.5, -0.6, 0.05])
def test_one_vehicle_alone_is_the_single_vehicle_physics_prediction(vy):
    ev = _cruising(10.0, 5.0, 12.0, samples=11, vy=vy)
    joint = joint_physics_forecast(ev, np.zeros((11, 0, 4)), DT, 40, W, LENGTH, 3, P)
    single = physics_forecast(ev, np.zeros((0, 4)), DT, 40, W, LENGTH, P.physics())
    assert joint.shape == (41, 1, 2)
    assert np.allclose(joint[:, 0], single, rtol=0, atol=1e-9)


def test_a_follower_brakes_behind_a_braking_leader_only_when_rolled_out_jointly():
    # one lane: the follower F, its leader L at its speed, a stopped car S ahead of L; 4 s
    f, leader = _cruising(0.0, 1.85, 15.0), _cruising(30.0, 1.85, 15.0)
    ev, others = _scene(f, leader, _cruising(90.0, 1.85, 0.0))
    joint = joint_physics_forecast(ev, others, DT, 20, W, LENGTH, 1, P)
    v_leader, v_follower = (np.diff(joint[:, i, 0]) / DT for i in (1, 0))
    assert v_leader[-1] < 9.0  # L brakes for S
    assert v_follower[-1] < 11.5  # and F for L
    # the same scene with L at constant velocity (the single-vehicle baseline): F does not
    alone = physics_forecast(ev, others[-1], DT, 20, W, LENGTH, P.physics())
    assert np.min(np.diff(alone[:, 0]) / DT) > 14.0
    assert alone[-1, 0] > joint[-1, 0, 0] + 5.0


def test_mobil_changes_toward_a_faster_free_lane_and_not_into_an_unsafe_gap():
    ev = _cruising(0.0, 0.5 * W, 15.0)
    slow = _cruising(25.0, 0.5 * W, 5.0)
    free = joint_physics_forecast(*_scene(ev, slow), DT, 40, W, LENGTH, 2, P)
    assert free[-1, 0, 1] == pytest.approx(1.5 * W)  # in the left lane's centre
    assert free[-1, 0, 0] > free[-1, 1, 0]  # past the slow car
    assert free[-1, 1, 1] == 0.5 * W  # which keeps its lane (nowhere better to go)
    # a fast car just behind in the left lane: the change would brake it beyond b_safe
    fast = _cruising(-8.0, 1.5 * W, 25.0)
    ev_, others = _scene(ev, slow, fast)
    scene = observed_scene(ev_, others, DT, W, LENGTH, 2)
    lane = np.floor(scene.y / W).astype(int)
    args = (scene.x, scene.v, lane, lane, P.v0_factor * scene.v90, scene.present)
    rest = (scene.length, scene.lanes, P)
    assert mobil(*args, scene.present, *rest)[0][0, 0] == 0  # unsafe: stays
    alone = observed_scene(*_scene(ev, slow), DT, W, LENGTH, 2)
    lane1 = np.floor(alone.y / W).astype(int)
    side, gain = mobil(alone.x, alone.v, lane1, lane1, P.v0_factor * alone.v90, alone.present,
                       alone.present, *rest)  # fmt: skip
    assert side[0, 0] == 1 and gain[0, 0] > P.threshold_mps2  # free: to the left
    rolled = joint_physics_forecast(ev_, others, DT, 40, W, LENGTH, 2, P)
    behind = rolled[:, 2, 0] < rolled[:, 0, 0] + LENGTH  # while the fast car is not past it
    assert behind[:3].all() and np.all(rolled[behind, 0, 1] < W)  # the EV stays in its lane
    # no lane to the right of lane 0, nor beyond the road: the slow car never leaves it
    assert np.all(rolled[:, 1, 1] == 0.5 * W)


def test_two_vehicles_wishing_one_gap_do_not_both_take_it():
    # a slow car with a faster follower: MOBIL's politeness would move the slow car aside
    # while the follower overtakes; decided one after another, only the follower goes
    ev = _cruising(0.0, 1.5 * W, 15.0)
    slow = _cruising(25.0, 1.5 * W, 5.0)
    polite = JointPhysicsParams(politeness=1.0)
    xy = joint_physics_forecast(*_scene(ev, slow), DT, 40, W, LENGTH, 3, polite)
    lanes = np.floor(xy[-1, :, 1] / W)
    assert lanes[0] != 1 and lanes[1] == 1


def test_a_batch_of_padded_scenes_rolls_out_as_each_scene_alone():
    a = _scene(_cruising(0.0, 1.85, 15.0), _cruising(25.0, 1.85, 5.0), _cruising(-8, 5.55, 25.0))
    b = _scene(_cruising(3.0, 5.0, 12.0, vy=0.5))
    c = _scene(_cruising(0.0, 5.55, 20.0), _cruising(20.0, 5.55, 10.0))
    scenes = [observed_scene(ev, others, DT, W, LENGTH, 3) for ev, others in (a, b, c)]
    together = joint_rollout(stack_scenes(scenes), 30, P)
    for i, s in enumerate(scenes):
        n = s.x.shape[1]
        assert np.allclose(together[i, :, :n], joint_rollout(s, 30, P)[0], rtol=0, atol=1e-9)


def test_the_predictor_is_the_observed_vehicles_path_and_reads_nothing_after_k(
    paper_demo, as_recorded, change_the_future
):
    ev, others = _scene(_cruising(0.0, 1.85, 15.0), _cruising(25.0, 1.85, 5.0))
    seen = Observation(ev, others, PAPER)
    path = JointPhysicsBaseline(P).predict(seen, 30)
    expected = joint_physics_forecast(ev, others, PAPER.dt, 30, PAPER.lane_width,
                                      PAPER.vehicle_length, PAPER.n_lanes, P)  # fmt: skip
    assert np.array_equal(path.xy, expected[:, 0]) and path.risk is None
    # an observation built from a demonstration: its future moved, the prediction is not
    demo = as_recorded(paper_demo)
    for t_obs in (1.0, 2.0, 3.0):
        k = round(t_obs / demo.scenario.dt)
        a = predict_demo(demo, None, t_obs, methods=("joint_physics",), joint_physics=P)
        b = predict_demo(change_the_future(demo, k), None, t_obs, methods=("joint_physics",),
                         joint_physics=P)  # fmt: skip
        assert np.array_equal(a.methods["joint_physics"].xy, b.methods["joint_physics"].xy)
        assert not np.array_equal(a.actual, b.actual)  # the scored truth did change


def test_parameters_are_checked():
    with pytest.raises(ValueError, match="time_gap_s must be a finite number > 0"):
        JointPhysicsParams(time_gap_s=0.0)
    with pytest.raises(ValueError, match="politeness must be a finite number >= 0"):
        JointPhysicsParams(politeness=-0.1)
    assert JointPhysicsParams(politeness=0.0, threshold_mps2=0.0).politeness == 0.0
    assert P.physics().lc_duration_s == P.lc_duration_s
