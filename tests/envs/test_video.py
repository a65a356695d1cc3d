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
