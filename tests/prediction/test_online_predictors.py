"""The online predictors of the vehicle cutting in (prediction/online.py)."""

import numpy as np
import pytest

from drivestyle.envs.cut_in import CutInEnv
from drivestyle.irl.driver.driver_style import DriverStyle, expert_style
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.planning.description import SMPCConfig
from drivestyle.prediction.online import OraclePredictor, StylePredictor
from drivestyle.studies.cut_in import CUT_IN_RANGES

SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
LIBRARY = DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95))


def test_the_oracle_predicts_the_cutter_exactly_while_the_ego_holds_its_speed():
    # with the ego at constant velocity (what the cutter's SMPC assumes), the cutter's true
    # model rolled out is the cutter's future
    env = CutInEnv(randomize=CUT_IN_RANGES, risk=0.6)
    obs, info = env.reset(seed=5)
    oracle = OraclePredictor(expert_style(SMPCConfig()))
    oracle.reset(info["scenario"], info["cutter_risk"])
    path = oracle.predict(obs[4:], obs[:4], 10)
    actual = []
    for _ in range(10):
        obs, *_ = env.step(np.zeros(2))
        actual.append(obs[4:6])
    np.testing.assert_allclose(path, np.array(actual), atol=0.05)


def test_the_style_predictor_tracks_and_refuses_use_before_reset():
    pred = StylePredictor(LIBRARY)
    with pytest.raises(RuntimeError, match="before reset"):
        pred.predict(np.zeros(4), np.zeros(4), 10)
    env = CutInEnv(randomize=CUT_IN_RANGES, risk=0.7)
    obs, info = env.reset(seed=1)
    pred.reset(info["scenario"], 0.0)  # the true risk is not used
    for _ in range(3):
        path = pred.predict(obs[4:], obs[:4], 10)
        obs, *_ = env.step(np.zeros(2))
    assert path.shape == (10, 2) and pred.tracker is not None and pred.tracker.n_samples == 3
