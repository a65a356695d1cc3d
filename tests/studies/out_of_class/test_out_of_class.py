"""Drivers outside the style class (studies/out_of_class/): order checks, the command.

The highway-env simulator's own tests: tests/agents/test_highway_drivers.py.
"""

import json

import pytest

from drivestyle.studies.out_of_class import EpisodeResult, order_checks, spearman


def _result(group: str, caution: float, p: float, inside: bool = False) -> EpisodeResult:
    return EpisodeResult("highway-env", group, caution, f"{group}-{p}", p, (p - 0.1, p + 0.1),
                         True, inside, inside, 3.0, 0.5 if inside else 2.0, True)  # fmt: skip


def test_spearman_on_a_hand_made_table():
    assert spearman([0, 1, 2, 3], [0.5, 0.6, 0.7, 0.9]) == (1.0, 0.0)
    rho, _ = spearman([0, 1, 2, 3], [0.9, 0.7, 0.6, 0.5])
    assert rho == pytest.approx(-1.0)
    rho, _ = spearman([0, 0, 1, 1], [0.5, 0.6, 0.7, 0.8])  # ties: mean ranks
    assert rho == pytest.approx(0.894, abs=1e-3)
    assert spearman([0, 1], [0.5, 0.6]) == (None, None)
    assert spearman([1, 1, 1], [0.5, 0.6, 0.7]) == (None, None)
    table = [_result("a", 0, 0.55), _result("a", 0, 0.7), _result("b", 1, 0.6),
             _result("b", 1, 0.8), _result("c", 2, 0.9, inside=True)]  # fmt: skip
    checks = {(o.scope, o.subset): o for o in order_checks(table)}
    everything = checks[("highway-env", "all")]
    assert everything.n == 5 and everything.rho_medians == pytest.approx(1.0)
    expected, _ = spearman([0, 0, 1, 1, 2], [0.55, 0.7, 0.6, 0.8, 0.9])
    assert everything.rho_episodes == pytest.approx(expected)
    assert not everything.met  # ρ over episodes ≈ 0.79 < 0.9
    assert checks[("highway-env", "in_region")].n == 4
    assert table[-1].verdict == "enters_region" and table[0].verdict == "informative"


@pytest.mark.slow  # a tiny end-to-end run of the command (≈ 1 min): CI runs it
def test_the_command_writes_its_report(tmp_path):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary
    from drivestyle.scripts.evaluate_out_of_class import main

    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    lib = tmp_path / "library.json"
    lib.write_text(json.dumps(library.to_json()))
    out = tmp_path / "out"
    payload = main(["--library", str(lib), "--out", str(out), "--per-class", "1",
                    "--max-runs", "1", "--risks", "0.5,0.9", "--scenarios", "1",
                    "--observe", "2"])  # fmt: skip
    assert (out / "out_of_class.md").read_text().startswith("# Drivers outside the style class")
    saved = json.loads((out / "out_of_class.json").read_text())
    assert saved["episodes"] and saved["order"] and "command" in saved
    assert {e["family"] for e in payload["episodes"]} >= {"smpc"}
    with pytest.raises(ValueError, match="no driver to study"):
        main(["--library", str(lib), "--out", str(out), "--no-highway", "--scenarios", "0"])


def test_the_study_refuses_an_observed_time_before_simulating(monkeypatch):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary
    from drivestyle.studies.out_of_class import study as out_of_class

    def simulated(*args, **kwargs):
        raise AssertionError("simulated before checking the observed times")

    monkeypatch.setattr(out_of_class, "highway_episodes", simulated)
    monkeypatch.setattr(out_of_class, "smpc_episodes", simulated)
    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.9))
    for t_obs, said in (((50.0,), "observe less than 8 s"), ((0.3,), "use 0.2 or 0.4 s")):
        with pytest.raises(ValueError, match=said):
            out_of_class.run_study(library, out_of_class.StudyConfig(t_obs=t_obs))
    spans = out_of_class.vehicle_spans(out_of_class.StudyConfig(per_class=0))
    assert [str(s) for s in spans] == ["SMPC drivers 6 s"]  # no highway-env without drivers
