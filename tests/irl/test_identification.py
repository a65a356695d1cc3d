import json
import runpy
from pathlib import Path

import numpy as np
import pytest
from drivestyle.agents import generate_demonstration
from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstrations
from drivestyle.envs import Demonstration
from drivestyle.irl.identification import (
    LibraryError,
    StyleLibrary,
    identify,
    identify_all,
    learn_library,
    load_library,
)

from drivestyle.common.io import write_json

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def small_library():
    scenarios = draw_interactive_scenarios(2, seed=0)
    demos = generate_demonstrations([0.5, 0.95], scenarios, workers=1)
    return learn_library(
        demos, "reactive", workers=1, meta={"training_scenarios": [s.to_dict() for s in scenarios]}
    )


def test_small_library_identifies_fresh_demos(small_library):
    held_out = draw_interactive_scenarios(1, seed=123)[0]
    for p in (0.5, 0.95):
        demo, _ = generate_demonstration(p, held_out)
        results = identify_all(demo, small_library)
        assert results["suboptimality"]["risk_estimate"] == p, results["suboptimality"]
        assert results["suboptimality"]["ranking"][0] == p
        assert set(results["rmse_y"]["scores"]) == {"0.5", "0.95"}


def test_library_round_trip(tmp_path, small_library):
    path = write_json(tmp_path / "library.json", small_library.to_json())
    back = load_library(tmp_path)
    assert back.risks == small_library.risks
    np.testing.assert_allclose(np.array(back.thetas), np.array(small_library.thetas))
    assert back.features == small_library.features
    assert back.meta["training_scenarios"] == small_library.meta["training_scenarios"]
    assert path.exists()


def test_empty_or_corrupt_library(tmp_path, small_library):
    with pytest.raises(LibraryError, match="empty"):
        StyleLibrary("reactive", (), ())
    raw = small_library.to_json()
    raw["theta"].pop("0.95")
    (tmp_path / "library.json").write_text(json.dumps(raw))
    with pytest.raises(LibraryError, match="corrupt"):
        load_library(tmp_path)
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(LibraryError, match="not valid JSON"):
        load_library(tmp_path / "bad.json")
    with pytest.raises(FileNotFoundError):
        load_library(tmp_path / "missing")


def test_demo_of_another_kind_is_rejected(small_library, paper_demo):
    tv = paper_demo.tv.copy()
    tv[:, 0] = tv[0, 0]
    tv[:, 3] = 0.0  # a TV that never moves: no interaction partner
    no_tv = Demonstration(paper_demo.t, paper_demo.ev, tv, paper_demo.u, dict(paper_demo.meta))
    with pytest.raises(LibraryError, match="no target vehicle"):
        identify(no_tv, small_library)
    with pytest.raises(ValueError, match="scorer"):
        identify(paper_demo, small_library, scorer="likelihood")


def test_identify_script(tmp_path, small_library, paper_demo):
    from drivestyle.envs import save_demonstration

    write_json(tmp_path / "lib" / "library.json", small_library.to_json())
    demo = save_demonstration(paper_demo, tmp_path / "demo.npz")
    main = runpy.run_path(str(ROOT / "scripts" / "identify_style.py"), run_name="x")["main"]
    res = main([str(demo), "--library", str(tmp_path / "lib"), "--out", str(tmp_path / "o")])
    js = json.loads((tmp_path / "o" / "identify.json").read_text())
    for key in ("risk_estimate", "scores", "ranking"):
        assert key in js
    assert res["risk_estimate"] in (0.5, 0.95)
