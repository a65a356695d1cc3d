"""Studies return typed, frozen results whose to_json() keeps the JSON files' keys; reports."""

import dataclasses

import pytest

from drivestyle.studies import reports
from drivestyle.studies.calibration import SCAN_KEYS, UncertaintyScan, uncertainty_scan
from drivestyle.studies.paper import PaperStudy, paper_study
from drivestyle.studies.population import Population, simulate_population


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
    assert "t_trg = 2.4 s (paper 3.0 s)" in reports.paper_console(odd)
    assert "t_trg = 2.4 s (paper: 3.0 s)" in reports.paper_markdown(odd, "cmd")
    assert "2.4000" not in reports.paper_console(odd) + reports.paper_markdown(odd, "cmd")
    never = dataclasses.replace(study, demo_summary=study.demo_summary | {"t_trg_s": None})
    assert "t_trg = never (paper 3.0 s)" in reports.paper_console(never)
    assert reports.seconds(None) == "never" and reports.seconds(12 * 0.2) == "2.4 s"


def test_uncertainty_scan_is_typed_and_keeps_the_calibration_keys():
    scan = uncertainty_scan([1.0], [0.7])
    assert isinstance(scan, UncertaintyScan) and list(scan.demos) == [0.7]
    js = scan.to_json()
    assert list(js) == ["base_uncertainty", "rows", "paper"]
    assert set(js["rows"][0]) == {"scale", "risk", *SCAN_KEYS, "final_y"}
    assert js["rows"][0]["t_trg_s"] == pytest.approx(3.0)


def test_population_is_typed_and_keeps_the_population_keys(tmp_path):
    pop = simulate_population(2, seed=1, out=tmp_path, workers=1)
    assert isinstance(pop, Population) and pop.n_ok == 2 and pop.n_failed == 0
    js = pop.to_json()
    assert list(js) == [
        "seed",
        "n",
        "risk_distribution",
        "traffic_share",
        "n_ok",
        "n_failed",
        "vehicles",
        "wall_s",
    ]
    assert js["wall_s"] > 0 and js["vehicles"][1]["id"] == "v000001"


def test_every_markdown_writer_lives_in_a_report_module():
    # studies/reports.py, or a study's own report.py (studies/<study>/report.py)
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    writers = []
    for folder in (
        "drivestyle", "envs", "recorded", "planning", "irl", "prediction", "agents", "studies"
    ):  # fmt: skip
        for path in (root / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.FunctionDef) and "markdown" in node.name:
                    writers.append(f"{path.relative_to(root)}:{node.name}")
    assert writers and all(
        w.startswith("studies/reports.py:")
        or (w.startswith("studies/") and w.split(":")[0].endswith("/report.py"))
        for w in writers
    ), writers
