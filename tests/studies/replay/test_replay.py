"""The replay study (studies/replay/): collisions in closed form, one replay against its log."""

import dataclasses

import numpy as np
import pytest

from drivestyle.envs.traffic import IDM
from drivestyle.prediction.physics import PhysicsParams
from drivestyle.studies.replay import (
    Collision,
    collisions,
    idm_parameters,
    replay_episode,
    replay_markdown,
    replay_recorded,
)


def test_collisions_are_the_pairs_whose_rectangles_overlap_with_first_time_and_samples():
    T = 5
    states = np.zeros((T, 3, 4))
    states[:, 1, 0] = [20.0, 10.0, 4.0, 4.9, 6.0]  # touches vehicle 0 (5 m long) at k = 2, 3
    states[:, 2, :2] = [-3.0, 2.0]  # beside vehicle 0, 2 m wide each: touching counts
    present = np.ones((T, 3), bool)
    present[:, 2] = [False, False, False, True, True]
    found = collisions(states, present, 5.0, 2.0, 0.2)
    assert found == (Collision(0, 1, 0.4, 2), Collision(0, 2, pytest.approx(0.6), 2))
    assert collisions(states, np.zeros((T, 3), bool), 5.0, 2.0, 0.2) == ()


def test_the_idm_parameters_are_the_calibrated_physics_or_the_traffic_envs():
    physics = PhysicsParams(v0_factor=1.2, time_gap_s=0.5, min_gap_m=1.0, accel_mps2=0.4,
                            decel_mps2=2.0)  # fmt: skip
    idm, rho = idm_parameters("calibrated", physics)
    assert (idm.a_max, idm.b, idm.s0, idm.time_gap, rho) == (0.4, 2.0, 1.0, 0.5, 1.2)
    assert idm_parameters("highway-env", physics) == (IDM, 1.0)
    with pytest.raises(ValueError, match="unknown IDM parameters 'x'"):
        idm_parameters("x", physics)


def test_a_replay_of_the_synthetic_scene_against_its_log(recorded_scene):
    replay = replay_episode("episodes", "synthetic-scene", recorded_scene, IDM, 1.0)
    assert (replay.start, replay.steps, replay.log_steps, replay.ended) == (5, 25, 25, "log end")
    assert replay.vehicles == 4 and replay.log_collisions == replay.replay_collisions == ()
    by_vehicle = {s.vehicle: s for s in replay.speeds}
    # vehicle 2 is recorded until sample 20: its recorded range is its constant 9 m/s; with
    # nobody ahead it keeps its v0 = 9 m/s (the IDM's free road at its desired speed)
    lead = by_vehicle[2]
    assert (lead.recorded_min, lead.recorded_max) == (9.0, 9.0)
    assert lead.replayed_min == pytest.approx(9.0) and lead.within
    # the TV, 20 m behind the EV in lane 1, brakes (T = 1.5 s wants 16 m + s0 = 10 m)
    tv = by_vehicle[1]
    assert tv.replayed_min < tv.recorded_min - 0.5 and tv.within is False


def test_a_collision_in_the_log_is_the_logs_and_not_new(recorded_scene):
    others = recorded_scene.others.copy()
    others[:, 0, 0] = recorded_scene.ev[:, 0] + 3.0  # the leader inside the EV, throughout
    others[:, 0, 1] = recorded_scene.ev[:, 1]
    crashed = dataclasses.replace(recorded_scene, others=others)
    replay = replay_episode("episodes", "crashed", crashed, IDM, 1.0)
    assert [(c.a, c.b) for c in replay.log_collisions] == [(0, 2)]
    assert replay.ended == "EV collision" and replay.steps == 1
    assert [(c.a, c.b) for c in replay.replay_collisions] == [(0, 2)]
    assert replay.new_collisions == ()


def test_the_study_summarises_every_episode_and_reports_them(recorded_scene):
    episodes = [("episodes", "a", recorded_scene), ("episodes", "b", recorded_scene)]
    study = replay_recorded(episodes, "two copies", "highway-env", PhysicsParams())
    s = study.summary()
    assert s["episodes"] == 2 and s["vehicles"] == 8 and s["new_collision_pairs"] == 0
    assert s["speeds_within"] == 2 * sum(bool(v.within) for v in study.replays[0].speeds)
    text = replay_markdown(study, "drivestyle replay-recorded")
    assert "| 2 | 8 | 0 | 0 | 0 | 0 (0) |" in text and text.count("| episodes | a |") == 1
    with pytest.raises(ValueError, match="nothing: no episode to replay"):
        replay_recorded([], "nothing", "calibrated", PhysicsParams())
