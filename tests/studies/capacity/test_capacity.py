"""The capacity study (RESULTS §10): its objective and a tiny run (its search: test_nelder_mead)."""

import json
import math

import pytest

from drivestyle.studies.capacity import (
    CLASSES,
    CapacityError,
    RiskCapacity,
    capacity_markdown,
    capacity_of_risk,
    reproduction_score,
)


def test_the_objective_weighs_a_lateral_metre_like_two_longitudinal_ones():
    assert reproduction_score(1.0, 1.0) == pytest.approx(1.0)  # all lateral
    assert reproduction_score(0.0, 2.0) == pytest.approx(1.0)  # all longitudinal
    assert reproduction_score(0.3, 0.29) == pytest.approx(0.3)  # rounding: rmse_xy < rmse_y


@pytest.fixture(scope="module")
def tiny_capacity(paper_demo):
    from drivestyle.agents import generate_demonstration
    from drivestyle.agents.demo_generation import draw_interactive_scenarios
    from drivestyle.agents.smpc import SMPCConfig

    held_out = draw_interactive_scenarios(1, seed=500)[0]
    test_demo = generate_demonstration(0.7, held_out, SMPCConfig(risk=0.7))[0]
    quick = {"screen": 1, "restarts": 1, "max_iter": 1}
    return capacity_of_risk(0.7, [paper_demo], [test_demo], 3, quick, irl_max_iter=2)


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_a_tiny_capacity_run_returns_every_class_with_finite_errors(tiny_capacity):
    row = tiny_capacity
    assert isinstance(row, RiskCapacity)
    assert tuple(c.name for c in row.classes) == CLASSES
    for c in row.classes:
        values = [*c.train_rmse_y, *c.train_rmse_xy, *c.test_rmse_y, *c.test_rmse_xy]
        assert len(values) == 4 and all(math.isfinite(v) and v >= 0 for v in values), c.name
        assert math.isfinite(c.objective) and c.evaluations <= 3
    json.dumps(row.to_json())  # JSON-ready


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_a_fitted_class_is_never_worse_in_sample_than_its_learner(tiny_capacity):
    by = tiny_capacity.by_name()
    # the Nelder–Mead runs start from the better of a generic start and the learner's answer
    assert by["paper_nm"].objective <= by["paper_irl"].objective + 1e-9
    assert by["rh_chance_nm"].objective <= by["rh_learned"].objective + 1e-6
    assert by["rh_cost_nm"].params["risk"] == 0.5


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_the_capacity_report_has_one_row_per_class(tiny_capacity):
    from drivestyle.studies.capacity import CapacityStudy

    study = CapacityStudy((0.7,), 3, (), (), (tiny_capacity,), 1.0)
    text = capacity_markdown(study, "cmd")
    assert sum(line.startswith("| 0.7 | ") for line in text.splitlines()) == len(CLASSES) + 1


def test_the_study_refuses_an_empty_held_out_set(paper_demo):
    with pytest.raises(CapacityError, match="held-out"):
        capacity_of_risk(0.7, [paper_demo], [], 3)
