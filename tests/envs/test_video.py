"""Recording frames: an env that does not render RGB arrays is a clear error."""

import numpy as np
import pytest

from drivestyle.envs import PAPER
from drivestyle.envs.lane_change import LaneChangeEnv
from drivestyle.envs.video import record_policy, record_states


def _hold(env, obs):
    return np.zeros(2)


def test_record_states_needs_rgb_array_mode():
    env = LaneChangeEnv()  # render_mode None: render() draws nothing
    states = np.array([PAPER.ev_initial_state] * 2), np.array([PAPER.tv_initial_state] * 2)
    with pytest.raises(ValueError, match="render_mode='rgb_array'"):
        record_states(env, *states)


def test_record_policy_needs_rgb_array_mode():
    env = LaneChangeEnv()
    with pytest.raises(ValueError, match="render_mode='rgb_array'"):
        record_policy(env, _hold)


def test_record_scene_renders_one_frame_per_sample_of_a_recorded_replay(recorded_scene):
    from drivestyle.envs.video import record_scene

    frames = record_scene(recorded_scene, "idm", agent=0, others="idm")
    assert len(frames) == recorded_scene.n - 5  # from the observed part's end (sample 5)
    assert frames[0].std() > 10 and np.abs(frames[0].astype(int) - frames[-1]).mean() > 1
    with pytest.raises(ValueError, match="policy must be one of"):
        record_scene(recorded_scene, "expert")
