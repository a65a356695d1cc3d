"""The paper study returns a typed, frozen result whose to_json() keeps results.json's keys."""

import dataclasses

import pytest

from drivestyle.studies.formatting import seconds
from drivestyle.studies.paper import PaperStudy, paper_console, paper_markdown, paper_study


@pytest.fixture(scope="module")
def study():
    return paper_study(ablations=False)


def test_paper_study_is_typed_and_keeps_the_results_keys(study):
    assert isinstance(study, PaperStudy)
    with pytest.raises(dataclasses.FrozenInstanceError):
        study.learning = {}
    js = study.to_json()
    assert list(js) == [
        "paper",
        "demo",
        "learning",
        "reaction_window_x_m",
        "reactive_closer_in_reaction_window",
        "reactive_closer_overall",
    ]
    assert js["learning"]["reactive"]["rmse_y_m"] == pytest.approx(0.166, abs=5e-4)
    assert js["reactive_closer_overall"] is True and study.reactive_closer_in_reaction_window
    done = dataclasses.replace(study, wall_time_total_s=1.5)
    assert done.to_json()["wall_time_total_s"] == 1.5 and "wall_time_total_s" not in js


def test_printed_and_reported_times_are_rounded(study):
    # sample times are k·0.2 s: 12 · 0.2 = 2.4000000000000004
    odd = dataclasses.replace(study, demo_summary=study.demo_summary | {"t_trg_s": 12 * 0.2})
    assert "t_trg = 2.4 s (paper 3.0 s)" in paper_console(odd)
    assert "t_trg = 2.4 s (paper: 3.0 s)" in paper_markdown(odd, "cmd")
    assert "2.4000" not in paper_console(odd) + paper_markdown(odd, "cmd")
    never = dataclasses.replace(study, demo_summary=study.demo_summary | {"t_trg_s": None})
    assert "t_trg = never (paper 3.0 s)" in paper_console(never)
    assert seconds(None) == "never" and seconds(12 * 0.2) == "2.4 s"
