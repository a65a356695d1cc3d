"""Features, learned reward and SMPC among several vehicles; the single-TV case unchanged."""

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

from drivestyle.agents.demo_generation import generate_traffic_demonstration
from drivestyle.common.io import write_json
from drivestyle.envs.demonstration import Demonstration, load_demonstration, save_demonstration
from drivestyle.envs.traffic import TrafficScene, VehicleSpec
from drivestyle.irl.paper.features import FeatureConfig, event_times, feature_basis, tiv_reference
from drivestyle.irl.paper.inner import InnerProblem
from drivestyle.irl.paper.learner import IRLConfig
from drivestyle.irl.paper.style import fit_style


@pytest.fixture(scope="module")
def traffic_demo():
    demo, summary = generate_traffic_demonstration(0.7)
    assert not summary["collision"] and summary["n_solver_failures"] == 0
    return demo


def test_traffic_demo_is_safe_against_every_vehicle(traffic_demo):
    d = traffic_demo
    assert d.others.shape == (d.n, 3, 4)
    veh = d.vehicles
    s_e = np.hypot(
        (d.ev[:, None, 0] - veh[:, :, 0]) / 15.0, (d.ev[:, None, 1] - veh[:, :, 1]) / 3.0
    )
    assert s_e.min() > 1.0


def test_one_tv_gives_todays_features(paper_demo):
    fc = FeatureConfig()
    today = InnerProblem(paper_demo, fc).f_demo
    empty = dataclasses.replace(paper_demo, others=np.zeros((paper_demo.n, 0, 4)))
    np.testing.assert_array_equal(InnerProblem(empty, fc).f_demo, today)
    # a vehicle far behind in the third lane is neither leader nor critical: no change
    far = paper_demo.tv.copy()
    far[:, 0] -= 300.0
    far[:, 1] = 13.125
    with_far = dataclasses.replace(paper_demo, others=far[:, None, :])
    np.testing.assert_allclose(InnerProblem(with_far, fc).f_demo, today, rtol=1e-12)


def test_tiv_refers_to_the_leader_in_the_ev_lane_and_the_trigger_to_the_critical(paper_demo):
    sc = paper_demo.scenario
    leader = paper_demo.ev.copy()
    leader[:, 0] += 40.0  # 40 m ahead in the EV's own lane, always
    others = leader[:, None, :]
    ref = tiv_reference(paper_demo.ev, paper_demo.tv, sc, others)
    assert ref[0] == 1  # the leader, not the TV, at the start
    events = event_times(paper_demo.t, paper_demo.ev, paper_demo.tv, sc, FeatureConfig(), others)
    assert events.critical in (0, 1) and events.reactive_active
    basis = feature_basis(dataclasses.replace(paper_demo, others=others))
    assert basis.x_tv[0] == pytest.approx(leader[0, 0], abs=0.5)  # first node, not t = 0


def test_learned_reward_telescopes_in_traffic(traffic_demo, tmp_path):
    payload = fit_style(traffic_demo, FeatureConfig(), IRLConfig(max_iter=5)).to_json()
    write_json(tmp_path / "style.json", payload)
    env = gym.make("drivestyle/Traffic-v0", style=str(tmp_path / "style.json"))
    env.reset()
    total = sum(env.step(u)[1] for u in traffic_demo.u)
    expected = -np.dot(payload["theta"], payload["feature_values_demo"])
    assert total == pytest.approx(expected, rel=1e-8)


def test_traffic_demo_file_round_trip_and_old_files_load(traffic_demo, paper_demo, tmp_path):
    back = load_demonstration(save_demonstration(traffic_demo, tmp_path / "t.npz"))
    np.testing.assert_array_equal(back.others, traffic_demo.others)
    np.savez(
        tmp_path / "old.npz", t=paper_demo.t, ev=paper_demo.ev, tv=paper_demo.tv, u=paper_demo.u
    )
    old = load_demonstration(tmp_path / "old.npz")
    assert old.others.shape == (paper_demo.n, 0, 4)
    with pytest.raises(ValueError, match="others"):
        Demonstration(paper_demo.t, paper_demo.ev, paper_demo.tv, paper_demo.u, others=np.zeros(3))


def test_a_custom_scene_with_a_slow_leader_keeps_the_ev_behind_it():
    scene = TrafficScene(others=(VehicleSpec(lane=0, gap=30.0, speed=20.0, behaviour="constant"),))
    _, summary = generate_traffic_demonstration(0.95, scene)
    assert not summary["collision"] and summary["min_d_k"] > 0


def test_traffic_rollout_video_frames_show_the_expert_driving():
    from drivestyle.envs.traffic import DEFAULT_TRAFFIC
    from drivestyle.studies.compare import policy_frames

    frames = policy_frames("expert", DEFAULT_TRAFFIC, 0.7)
    assert len(frames) == 31 and frames[0].std() > 5
    with pytest.raises(ValueError, match="single-TV"):
        policy_frames("spline", DEFAULT_TRAFFIC)
