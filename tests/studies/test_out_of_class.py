"""Drivers outside the style class (studies/out_of_class.py): frame, simulation, order."""

import json

import numpy as np
import pytest

from drivestyle.recorded.episodes import ExtractionConfig, extract_episodes
from drivestyle.studies.out_of_class import (
    HIGHWAY_CLASSES,
    LANE_WIDTH,
    EpisodeResult,
    Spawn,
    TrafficConfig,
    draw_traffic,
    highway_recording,
    order_checks,
    project_frame,
    simulate_highway,
    spearman,
)

# a fast vehicle closing on a slow one far ahead on the middle lane, the other lanes empty:
# MOBIL's gain passes the threshold after ≈ 5 s, so the change has 3 s of track before it
OVERTAKE = [Spawn("moderate", 1, 0.0, 32.0, 32.0), Spawn("reckless", 1, 650.0, 20.0, 20.0)]
SHORT = TrafficConfig(duration_s=12.0)


def test_the_caution_order_is_monotone_in_every_constant():
    ranks = [c.caution for c in HIGHWAY_CLASSES]
    assert ranks == sorted(ranks) and len(set(ranks)) == len(ranks)
    for name in ("time_wanted", "distance_wanted", "politeness"):
        values = [getattr(c, name) for c in HIGHWAY_CLASSES]
        assert values == sorted(values), name
    braking = [c.max_braking_imposed for c in HIGHWAY_CLASSES]
    assert braking == sorted(braking, reverse=True)
    vehicle = HIGHWAY_CLASSES[-1].vehicle_type()
    assert vehicle.TIME_WANTED == HIGHWAY_CLASSES[-1].time_wanted


def test_highway_env_lanes_map_to_the_project_frame():
    # highway-env: lane i's centre at y = 4 i, y to the right; lane 0 is the leftmost
    y, phi, markings = project_frame(np.array([0.0, 4.0, 8.0]), np.array([0.1, 0.0, -0.2]), 3)
    assert markings == (0.0, 4.0, 8.0, 12.0)
    assert np.allclose(y, [10.0, 6.0, 2.0]) and np.allclose(phi, [-0.1, 0.0, 0.2])
    t = np.arange(3) * 0.1
    rows = {
        "left": np.column_stack([t, 20 * t, np.zeros(3), np.full(3, 20.0), np.zeros(3)]),
        "right": np.column_stack([t, 20 * t, np.full(3, 2 * LANE_WIDTH), np.full(3, 20.0),
                                  np.zeros(3)]),
    }  # fmt: skip
    road = highway_recording(rows, 3).carriageways[0]
    lanes = {tr.vehicle_id: int(road.lane_of(tr.y)[0]) for tr in road.tracks}
    assert lanes == {"left": 2, "right": 0}  # project: lane 0 rightmost


def test_a_tiny_simulation_yields_a_lane_change_of_a_known_class():
    rec, classes = simulate_highway(OVERTAKE, SHORT)
    track = rec.carriageways[0].tracks[0]
    assert np.allclose(np.diff(track.t), 0.1)  # recorded at 10 Hz
    episodes = [e for e in extract_episodes(rec, ExtractionConfig(dt=0.2, l_a=None)) if e.usable]
    assert [(classes[e.vehicle_id], abs(e.to_lane - e.from_lane)) for e in episodes] == [
        ("moderate", 1)
    ]
    assert episodes[0].demo is not None and "episode_id" in episodes[0].demo.meta


def test_traffic_is_deterministic_given_its_seed():
    cfg = TrafficConfig(vehicles_per_lane=2, duration_s=2.0)
    assert draw_traffic(cfg, 3) == draw_traffic(cfg, 3) != draw_traffic(cfg, 4)
    a, ca = simulate_highway(draw_traffic(cfg, 3), cfg)
    b, cb = simulate_highway(draw_traffic(cfg, 3), cfg)
    assert ca == cb
    for ta, tb in zip(a.carriageways[0].tracks, b.carriageways[0].tracks, strict=True):
        assert np.array_equal(ta.x, tb.x) and np.array_equal(ta.y, tb.y)


def test_bad_spawns_are_refused_with_one_line():
    with pytest.raises(ValueError, match="unknown driver class 'nobody'"):
        simulate_highway([Spawn("nobody", 0, 0.0, 20.0, 20.0)], SHORT)
    with pytest.raises(ValueError, match="lane 3 is not a lane"):
        simulate_highway([Spawn("reckless", 3, 0.0, 20.0, 20.0)], SHORT)


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
    from drivestyle.studies import out_of_class

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
