"""Style libraries: library.json round trip, and validation of the whole file on load."""

import copy
import json
from dataclasses import replace

import numpy as np
import pytest

from drivestyle.common.io import write_json
from drivestyle.envs.scenario import PAPER
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import (
    DriverLibrary,
    LibraryError,
    StyleLibrary,
    load_driver_library,
    load_library,
)


def _write(tmp_path, raw):
    path = tmp_path / "library.json"
    path.write_text(json.dumps(raw))
    return path


def _mutated(style_library, mutate):
    raw = copy.deepcopy(style_library.to_json())
    mutate(raw)
    return raw


def test_library_round_trip(tmp_path, style_library):
    write_json(tmp_path / "library.json", style_library.to_json())
    back = load_library(tmp_path)
    assert replace(back, meta=style_library.meta) == style_library  # write_json adds provenance
    assert back.meta.items() >= style_library.meta.items()
    assert back.n_scenarios == 5 == len(back.members[0])
    assert back.to_json()["training_scenarios"] == [
        dict(sc) for sc in style_library.training_scenarios
    ]


def test_a_library_file_of_the_previous_layout_loads(tmp_path, style_library):
    # build_style_library.py wrote training_scenarios beside seeds and timings: same keys
    raw = style_library.to_json()
    raw = {k: raw[k] for k in ("feature_set", "features", "risks", "theta", "members")} | {
        "feature_config": raw["feature_config"],
        "training_scenarios": raw["training_scenarios"],
        "uncertainty": {"k_x": 1.0},
        "seed": 0,
        "per_risk": {},
    }
    lib = load_library(_write(tmp_path, raw))
    assert lib.meta["seed"] == 0 and "training_scenarios" not in lib.meta
    np.testing.assert_allclose(lib.members, style_library.members)


def _set_risk(raw, old, new):
    raw["risks"] = [new if p == old else p for p in raw["risks"]]
    for key in ("theta", "members"):
        raw[key][str(new)] = raw[key].pop(str(old))


def _repeat_first_risk(raw):
    raw["risks"] = [0.5, 0.5]
    for key in ("theta", "members"):
        raw[key].pop("0.95")


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda raw: _set_risk(raw, 0.95, 1.5), r"risk 1\.5 is not in \(0, 1\)"),
        (lambda raw: _set_risk(raw, 0.5, 0.0), r"risk 0\.0 is not in \(0, 1\)"),
        (lambda raw: raw.pop("training_scenarios"), "no 'training_scenarios'"),
        (
            lambda raw: raw.__setitem__("training_scenarios", raw["training_scenarios"][:3]),
            "5 member styles but the library has 3 training_scenarios",
        ),
        (
            lambda raw: raw["members"]["0.95"].pop(),
            "p=0.95 has 4 member styles but the library has 5",
        ),
        (
            lambda raw: raw["members"].__setitem__("0.7", raw["members"]["0.5"]),
            "entries for risks not in 'risks': 0.7",
        ),
        (
            lambda raw: raw["training_scenarios"][2].pop("tv_gap"),
            "training scenario 2 has no finite tv_gap",
        ),
        (lambda raw: raw["members"]["0.5"][1].__setitem__(0, -1.0), "member 1 of p=0.5"),
        (lambda raw: raw.__setitem__("features", ["x"]), "'features'"),
        (_repeat_first_risk, "distinct"),
    ],
    ids=[
        "risk 1.5",
        "risk 0",
        "no scenarios",
        "short scenarios",
        "short members",
        "extra members",
        "scenario without gap",
        "negative member",
        "other features",
        "repeated risk",
    ],
)
def test_an_inconsistent_library_is_refused_on_load(tmp_path, style_library, mutate, message):
    path = _write(tmp_path, _mutated(style_library, mutate))
    with pytest.raises(LibraryError, match=message) as info:
        load_library(path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_a_library_is_validated_when_built_in_memory():
    theta = (1.0,) * 10
    scenarios = (PAPER.to_dict(),)
    with pytest.raises(LibraryError, match="empty"):
        StyleLibrary("reactive", (), ())
    with pytest.raises(LibraryError, match=r"not in \(0, 1\)"):
        StyleLibrary(
            "reactive", (1.5,), (theta,), members=((theta,),), training_scenarios=scenarios
        )
    with pytest.raises(LibraryError, match="no training_scenarios"):
        StyleLibrary("reactive", (0.5, 0.9), (theta,) * 2, members=((theta,),) * 2)
    with pytest.raises(LibraryError, match="member sets"):
        StyleLibrary("reactive", (0.5, 0.9), (theta,) * 2, training_scenarios=scenarios)


def test_malformed_or_missing_files(tmp_path):
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(LibraryError, match="not valid JSON"):
        load_library(tmp_path / "bad.json")
    with pytest.raises(FileNotFoundError):
        load_library(tmp_path / "missing")


def test_nearest_members_follow_the_scenario():
    train = [
        PAPER.with_overrides(ev_speed=v, tv_gap=g).to_dict()
        for v, g in ((22.0, -30.0), (28.0, -10.0), (25.0, -20.0))
    ]
    members = (((1.0,) * 10, (2.0,) * 10, (3.0,) * 10),) * 2
    lib = StyleLibrary(
        "reactive", (0.5, 0.7), ((1.0,) * 10,) * 2, members=members,
        training_scenarios=tuple(train),
    )  # fmt: skip
    here = PAPER.with_overrides(ev_speed=27.5, tv_gap=-11.0)
    assert lib.styles(0, 1, here) == ((2.0,) * 10,)
    assert lib.styles(0, 2, here) == ((2.0,) * 10, (3.0,) * 10)
    assert lib.styles(0, None, here) == members[0]
    with pytest.raises(ValueError, match="scenario"):
        lib.styles(0, 1, None)


def test_learning_records_the_demonstrations_scenarios(style_library):
    # the fixture passes its drawn scenarios too; learn_library checks they are the demos'
    assert style_library.n_scenarios == 5
    assert "training_scenarios" not in style_library.meta
    assert set(style_library.meta["per_risk"]) == {"0.5", "0.95"}


def test_learning_refuses_risks_in_different_scenarios(paper_demo):
    from drivestyle.irl.identification.library import learn_library

    other = replace(
        paper_demo,
        meta={**paper_demo.meta, "scenario": PAPER.with_overrides(tv_gap=-25.0).to_dict()},
    )
    with pytest.raises(ValueError, match="same scenarios"):
        learn_library({0.5: [paper_demo], 0.9: [other]}, workers=1)


# ------------------------------------------------------------ libraries that cannot be meant
SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)


def _small_style_library(risks=(0.5, 0.9)):
    theta = (1.0,) * 10
    return StyleLibrary(
        "reactive", risks, (theta,) * len(risks), members=((theta,),) * len(risks),
        training_scenarios=(PAPER.to_dict(),),
    )  # fmt: skip


def _driver_library_json(**changes):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary

    return DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.5, 0.7, 0.9)).to_json() | changes


def test_one_risk_is_refused_when_built_and_when_loaded(tmp_path):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary, load_any_library

    with pytest.raises(LibraryError, match=r"at least 2 risks to tell styles apart, got 1 \(0.7\)"):
        _small_style_library((0.7,))
    with pytest.raises(LibraryError, match="at least 2 risks"):
        DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.7,))
    raw = _small_style_library().to_json()
    raw["risks"] = [0.5]
    for key in ("theta", "members"):
        raw[key].pop("0.9")
    with pytest.raises(LibraryError, match="at least 2 risks") as info:
        load_any_library(_write(tmp_path, raw))
    assert str(tmp_path) in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(LibraryError, match="at least 2 risks"):
        load_any_library(_write(tmp_path, _driver_library_json(risks=[0.7])))


def test_learning_refuses_one_risk_before_learning(paper_demo, monkeypatch):
    from drivestyle.irl.identification import library as lib_module

    def no_learning(*args, **kwargs):
        raise AssertionError("learned before refusing")

    monkeypatch.setattr(lib_module, "learn_driver", no_learning)
    monkeypatch.setattr(lib_module, "parallel_map", no_learning)
    with pytest.raises(LibraryError, match="at least 2 risks"):
        lib_module.learn_driver_library({0.7: [paper_demo]})
    with pytest.raises(LibraryError, match="at least 2 risks"):
        lib_module.learn_library({0.7: [paper_demo]})


@pytest.mark.parametrize("version", [99, 0, "1", True, None])
def test_an_unknown_version_is_refused(tmp_path, version):
    from drivestyle.irl.identification.library import load_any_library

    with pytest.raises(LibraryError, match=rf"unknown library version {version!r}"):
        load_any_library(_write(tmp_path, _driver_library_json(version=version)))
    raw = _small_style_library().to_json() | {"version": version}
    with pytest.raises(LibraryError, match="unknown library version"):
        load_any_library(_write(tmp_path, raw))


def test_the_current_version_and_none_load(tmp_path):
    from drivestyle.irl.identification.library import LIBRARY_VERSION, load_any_library

    raw = _small_style_library().to_json()
    assert raw["version"] == LIBRARY_VERSION
    assert "version" not in load_any_library(_write(tmp_path, raw)).meta
    raw.pop("version")  # paper-model files written before the version was recorded
    load_any_library(_write(tmp_path, raw))


@pytest.mark.parametrize("temperature", [1e-300, 0.0, -1.0, 0.05, 150.0, 1e300])
def test_a_temperature_outside_its_range_is_refused(tmp_path, temperature):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary, load_any_library

    with pytest.raises(LibraryError, match=r"temperature .* is outside \[0.1, 100\]"):
        DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.5, 0.9), temperature=temperature)
    path = _write(tmp_path, _driver_library_json(temperature=temperature))
    with pytest.raises(LibraryError, match="outside"):
        load_any_library(path)


def test_the_posterior_is_never_nan():
    """The posterior computation refuses what would be NaN (a library bypassing checks)."""
    from drivestyle.irl.driver.risk_profile import RiskProfile
    from drivestyle.irl.identification.paper_scorers import posterior_from_scores
    from drivestyle.irl.identification.posterior import risk_log_likelihood

    profile = RiskProfile((0.5, 0.7, 0.9), (3.0, 1.0, 2.0), 20, 5)
    assert np.isfinite(risk_log_likelihood([profile], 1.0)).all()
    # τ² overflows: no OverflowError, the (flat) likelihood of a prior
    np.testing.assert_array_equal(risk_log_likelihood([profile], 1e300), 0.0)
    with pytest.raises(LibraryError, match=r"not finite \(temperature 1e-300.*NaN"):
        risk_log_likelihood([profile], 1e-300)  # τ² underflows to 0: 0/0 at the best risk
    with pytest.raises(LibraryError, match="not finite"):
        risk_log_likelihood([RiskProfile((0.5, 0.9), (np.nan, 1.0), 20, 5)], 1.0)
    for tau in (np.nan, np.inf, 0.0):
        with pytest.raises(LibraryError, match="temperature must be a finite number > 0"):
            risk_log_likelihood([profile], tau)
    with pytest.raises(ValueError, match="temperature"):
        posterior_from_scores([[2.0, 1.0]], [True], temperature=np.nan)


def test_a_driver_library_is_loaded_and_a_paper_one_refused_naming_the_purpose(
    tmp_path, style_library
):
    driver = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.9))
    write_json(tmp_path / "driver" / "library.json", driver.to_json())
    assert load_driver_library(tmp_path / "driver", "prediction").style == driver.style
    write_json(tmp_path / "paper" / "library.json", style_library.to_json())
    with pytest.raises(LibraryError, match=r"paper.*prediction needs a driver library"):
        load_driver_library(tmp_path / "paper", "prediction")
