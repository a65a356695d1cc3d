"""evaluate-planning and bench-tracker end to end (tiny runs)."""

from __future__ import annotations

import json

import pytest

from drivestyle.common.io import write_json
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary, LibraryError

LIBRARY = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))


@pytest.fixture
def library(tmp_path):
    write_json(tmp_path / "lib" / "library.json", LIBRARY.to_json())
    return tmp_path / "lib"


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
def test_evaluate_planning_writes_the_study_and_one_video_per_predictor(tmp_path, library):
    from drivestyle.scripts.evaluate_planning import main

    out = tmp_path / "plan"
    payload = main(["--library", str(library), "--scenes", "1", "--seed", "3", "--workers",
                    "1", "--videos", "--out", str(out)])  # fmt: skip
    saved = json.loads((out / "planning.json").read_text())
    assert saved["n_scenes"] == 1 and set(saved["summaries"]) == {"cv", "style", "oracle"}
    assert saved["command"] and saved["video_scene"] == 3 == payload["video_scene"]
    assert {p.name for p in (out / "videos").iterdir()} == {"cv.mp4", "style.mp4", "oracle.mp4"}
    assert (out / "planning.png").stat().st_size > 10_000
    assert "| style |" in (out / "planning.md").read_text()


# the refusal itself: tests/irl/identification/test_library.py (load_driver_library)
@pytest.mark.slow
def test_evaluate_planning_refuses_a_paper_library(tmp_path, style_library):
    from drivestyle.irl.identification.library import StyleLibrary
    from drivestyle.scripts.evaluate_planning import main

    assert isinstance(style_library, StyleLibrary)
    write_json(tmp_path / "paper" / "library.json", style_library.to_json())
    with pytest.raises(LibraryError, match="needs a driver library"):
        main(["--library", str(tmp_path / "paper"), "--out", str(tmp_path / "o")])


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_bench_tracker_reports_the_update_latency(tmp_path, library):
    from drivestyle.scripts.bench_tracker import main

    payload = main(["--library", str(library), "--vehicles", "1", "--out",
                    str(tmp_path / "b.json")])  # fmt: skip
    assert payload["updates"] == 31
    assert 0 < payload["median_ms"] <= payload["p95_ms"] <= payload["max_ms"]
    assert json.loads((tmp_path / "b.json").read_text())["goal_median_ms"] == 20.0
