"""The ego's SMPC with a predicted path, and the cut-in study."""

from __future__ import annotations

import numpy as np
import pytest

from drivestyle.agents.aware_planner import AwareSMPC, ego_scenario
from drivestyle.agents.smpc import SMPCExpert
from drivestyle.envs.cut_in import CutInEnv
from drivestyle.irl.driver.driver_style import DriverStyle, expert_style
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.planning.description import SMPCConfig, nlp_parameters
from drivestyle.prediction.online import ConstantVelocityPredictor
from drivestyle.studies.cut_in import (
    CUT_IN_RANGES,
    PlanningStudy,
    cut_in_study,
    planning_goals,
    summarise_runs,
)

SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
LIBRARY = DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95))


def test_the_expert_is_its_own_style():
    assert expert_style(SMPCConfig(risk=0.8)) == DriverStyle(SMPC_WEIGHTS, risk=0.8)


@pytest.mark.slow  # ≈ 15–20 s (the default run's longest test): CI runs it
def test_a_constant_velocity_path_plans_exactly_as_todays_smpc():
    # the NLP with the CV mean path as parameters is the expert's NLP with the state:
    # the same plan at every step of a cut-in episode
    env = CutInEnv(randomize=CUT_IN_RANGES)
    obs, info = env.reset(seed=3)
    sc = info["scenario"]
    aware = AwareSMPC(ConstantVelocityPredictor(), SMPCConfig(risk=0.9), sc)
    aware.start(sc, info["cutter_risk"])
    plain = SMPCExpert(SMPCConfig(risk=0.9, compiled=True), ego_scenario(sc))
    for _ in range(12):
        a, b = aware.act(obs), plain.act(obs)
        np.testing.assert_allclose(a, b, atol=1e-6)
        obs, *_ = env.step(a)


def test_predicted_path_parameters_have_the_paths_layout():
    p = nlp_parameters(np.zeros(4), np.ones((1, 10, 2)), 7.875, 30.0, 1.28)
    assert p.shape == (4 + 20 + 3,)
    with pytest.raises(ValueError, match="weights must have 5 entries"):
        nlp_parameters(np.zeros(4), np.ones((1, 10, 2)), 7.875, 30.0, 1.28, weights=[1.0])


def test_ego_scenario_swaps_the_roles():
    sc = CUT_IN_RANGES.sample(np.random.default_rng(0))
    ego = ego_scenario(sc)
    assert ego.target_lane == sc.tv_lane and ego.tv_lane == sc.ev_lane
    assert ego.ev_x == pytest.approx(sc.ev_x + sc.tv_gap)
    assert ego.v_ref == pytest.approx(sc.tv_speed) and ego.ev_speed == pytest.approx(sc.tv_speed)


@pytest.fixture(scope="module")
def study() -> PlanningStudy:
    return cut_in_study(LIBRARY, 2, seed=7, workers=1)


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_the_cut_in_study_scores_every_scene_with_every_predictor(study):
    assert len(study.runs) == 6 and study.seeds == (7, 8)
    for r in study.runs:
        assert r.hardest_braking >= 0 and r.progress_m > 0 and r.min_distance_m > 0
        assert len(r.accel) == 40
        assert r.hardest_braking == pytest.approx(max(0.0, -min(r.accel)), abs=1e-4)
    cv = summarise_runs(study.runs, "cv")
    assert cv.n == 2
    assert cv.hardest_braking_mean == pytest.approx(
        np.mean([r.hardest_braking for r in study.runs if r.method == "cv"])
    )
    payload = study.to_json()
    assert set(payload["summaries"]) == {"cv", "style", "oracle"}
    assert payload["goals"] == planning_goals(study.summaries)
    with pytest.raises(ValueError, match="at least one scene"):
        cut_in_study(LIBRARY, 0, seed=7)


def test_the_compiled_interior_point_step_is_not_offered_for_predicted_paths():
    # its generated step predicts every vehicle at constant velocity: the generic solvers
    # must solve a predicted-path NLP
    from drivestyle.planning.plan_solver import compiled_solver

    assert compiled_solver(SMPCConfig(predicted_paths=True), CUT_IN_RANGES.base) is None
