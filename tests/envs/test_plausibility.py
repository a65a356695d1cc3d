"""Physically impossible or inconsistent demonstrations are refused with what is wrong."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from drivestyle.envs.demonstration import Demonstration, DemonstrationError
from drivestyle.envs.plausibility import check_plausible, plausibility_problems

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"


def _with_scenario(demo, **fields):
    return replace(demo, meta={**demo.meta, "scenario": {**demo.meta["scenario"], **fields}})


def _ev(demo, column, values):
    ev = demo.ev.copy()
    ev[:, column] = values
    return replace(demo, ev=ev)


def _tv_on_ev_at_start(demo):
    tv = demo.tv.copy()
    tv[0, :2] = demo.ev[0, :2]  # the reproduced defect: s_e 0.0, "informative", risk 0.6
    return replace(demo, tv=tv)


def _x_decreasing(demo):
    return _ev(demo, 0, 2 * demo.ev[0, 0] - demo.ev[:, 0])


def _negative_speed(demo):
    return _ev(_x_decreasing(demo), 3, -demo.ev[:, 3])


def _rightward_scenario(demo):
    """The paper demonstration mirrored to a change from lane 1 to lane 0, said so."""
    w = demo.scenario.lane_width
    ev, tv = demo.ev.copy(), demo.tv.copy()
    ev[:, 1], tv[:, 1] = 2 * w - ev[:, 1], 2 * w - tv[:, 1]
    ev[:, 2], tv[:, 2] = -ev[:, 2], -tv[:, 2]
    return _with_scenario(replace(demo, ev=ev, tv=tv), ev_lane=1, target_lane=0, tv_lane=0)


def _rightward_data(demo):
    return _ev(demo, 1, 2 * demo.ev[0, 1] - demo.ev[:, 1])


def _two_lanes_data(demo):
    return _ev(demo, 1, demo.ev[0, 1] + 2 * (demo.ev[:, 1] - demo.ev[0, 1]))


def _two_lanes_scenario(demo):
    return _with_scenario(_two_lanes_data(demo), target_lane=2)


def _standing_but_y_changes(demo):
    ev = demo.ev.copy()
    ev[:, 0], ev[:, 3] = ev[0, 0], 0.0
    return replace(demo, ev=ev)


def _lane_change_in_a_tenth_of_the_time(demo):
    k = np.minimum(10 * np.arange(demo.n), demo.n - 1)
    return _ev(demo, 1, demo.ev[k, 1])


def _lanes_half_as_wide(demo):
    """Lateral positions of 2.625 m lanes under the metadata's 5.25 m."""
    ev, tv = demo.ev.copy(), demo.tv.copy()
    ev[:, 1], tv[:, 1] = ev[:, 1] / 2, tv[:, 1] / 2
    return replace(demo, ev=ev, tv=tv)


def _positions_in_feet(demo):
    ev, tv = demo.ev.copy(), demo.tv.copy()
    for a in (ev, tv):
        a[:, :2] *= 1 / 0.3048
    return replace(demo, ev=ev, tv=tv)


def _ev_jumps(metres, k=15):
    """The EV's positions from sample k on shifted by ``metres`` along x: a jump in one step."""

    def make(demo):
        ev = demo.ev.copy()
        ev[k:, 0] += metres
        return replace(demo, ev=ev)

    return make


def _spike(metres, k=15, who="ev"):
    """One sample displaced by ``metres`` along x (a glitch of the recording)."""

    def make(demo):
        a = getattr(demo, who).copy()
        a[k, 0] += metres
        return replace(demo, **{who: a})

    return make


def _speed_at(value, k=15):
    def make(demo):
        ev = demo.ev.copy()
        ev[k, 3] = value
        return replace(demo, ev=ev)

    return make


def _tv_on_ev_later(demo, k=15):
    tv = demo.tv.copy()
    tv[k, :2] = demo.ev[k, :2]
    return replace(demo, tv=tv)


CASES = {
    "overlap at t = 0": (_tv_on_ev_at_start, r"the TV overlaps the EV at t = 0"),
    "overlap later": (_tv_on_ev_later, r"the TV overlaps the EV at t = 3 s \(sample 15;"),
    "EV jumps 50 m": (
        _ev_jumps(50.0),
        r"the EV moves 55.8 m between t = 2.8 and 3 s \(samples 14 and 15\): 279 m/s, but .*"
        r"v_max = 70 m/s",
    ),
    "EV jumps 5 m": (_ev_jumps(5.0), r"the EV's positions imply an acceleration of 1\d\d m/s²"),
    "EV glitch of 2 m": (
        _spike(2.0),
        r"EV.s .*acceleration of 98.9 m/s² at t = 3 s \(sample 15\)",
    ),
    "TV glitch of 3 m": (_spike(3.0, who="tv"), r"the TV's positions imply an acceleration"),
    "speed beyond v_max": (_speed_at(80.0), r"the EV's speed v = 80 m/s at t = 3 s \(sample 15\)"),
    "x decreasing": (_x_decreasing, r"drives backwards: x falls"),
    "negative speed": (_negative_speed, r"drives backwards: speed v = -2\d"),
    "rightward (scenario)": (_rightward_scenario, r"lane 1 to lane 0, towards −y.*\+y"),
    "rightward (data)": (_rightward_data, r"changes lane towards −y.*mirror y"),
    "two lanes (data)": (_two_lanes_data, r"lane 2, past its target lane 1.*two-lane"),
    "two lanes (scenario)": (_two_lanes_scenario, r"lane 0 to lane 2, across 2 lanes"),
    "standing, y changes": (_standing_but_y_changes, r"lateral motion without speed"),
    "lateral speed": (_lane_change_in_a_tenth_of_the_time, r"beyond what the heading allows"),
    "lane width too small": (
        lambda d: _with_scenario(d, lane_width=3.0, l_b=1.7),
        r"do not fit lanes 3 m wide.*TV.*lane 2",
    ),
    "lane width larger than the data's": (
        _lanes_half_as_wide,
        r"do not fit lanes 5.25 m wide.*TV.*lane 0",
    ),
    "lane width in feet": (
        lambda d: _with_scenario(d, lane_width=12.1),
        r"lanes 12.1 m wide.*feet.*convert",
    ),
    "positions in feet": (_positions_in_feet, r"positions and speeds disagree.*3.28×"),
}


def test_smpc_demonstration_is_plausible(paper_demo):
    assert plausibility_problems(paper_demo) == []
    check_plausible(paper_demo)


@pytest.mark.parametrize("case", CASES)
def test_implausible_demonstration_is_refused(paper_demo, case):
    make, message = CASES[case]
    with pytest.raises(DemonstrationError, match=message) as exc:
        check_plausible(make(paper_demo))
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("case", CASES)
def test_learning_and_identification_refuse_it(paper_demo, case):
    """check_learnable (MaxEntIRL, identify, mining) runs the plausibility check."""
    from drivestyle.irl.paper.learner import check_learnable

    make, message = CASES[case]
    with pytest.raises(DemonstrationError, match=message):
        check_learnable(make(paper_demo))


def test_random_family_and_traffic_demonstrations_are_plausible():
    from drivestyle.agents.demo_generation import (
        generate_demonstration,
        generate_traffic_demonstration,
    )
    from drivestyle.agents.smpc import SMPCConfig
    from drivestyle.envs.scenario import ScenarioRanges

    rng = np.random.default_rng(1)
    for _ in range(3):
        sc = ScenarioRanges().sample(rng)
        for p in (0.5, 0.9):
            demo, _ = generate_demonstration(p, sc, SMPCConfig(risk=p))
            assert plausibility_problems(demo) == [], sc
    demo, _ = generate_traffic_demonstration(0.7, seed=1, randomize=True)
    assert plausibility_problems(demo) == []


def test_small_noise_around_standstill_passes(paper_demo):
    rng = np.random.default_rng(0)
    ev = np.repeat(paper_demo.ev[:1], paper_demo.n, axis=0)
    ev[:, 3] = 0.0
    ev[:, :2] += rng.normal(0, 0.01, (paper_demo.n, 2))  # 1 cm of position noise
    assert plausibility_problems(replace(paper_demo, ev=ev)) == []


@pytest.mark.parametrize("risk", [7, 0.0, 1.0, -0.2, float("nan"), "0.7", True])
def test_metadata_risk_must_lie_in_0_1(paper_demo, risk):
    with pytest.raises(DemonstrationError, match=r"meta 'risk' must .*\(0, 1\)"):
        Demonstration(paper_demo.t, paper_demo.ev, paper_demo.tv, paper_demo.u, {"risk": risk})


def test_metadata_risk_7_in_a_file_names_the_file(tmp_path, paper_demo):
    from drivestyle.envs.demonstration import load_demonstration, save_demonstration

    path = save_demonstration(paper_demo, tmp_path / "d.npz")
    meta = {**paper_demo.meta, "risk": 7}
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files if k != "meta"}
    np.savez(path, **arrays, meta=np.array(__import__("json").dumps(meta)))
    with pytest.raises(DemonstrationError, match=rf"^{path}: meta 'risk' must lie in \(0, 1\)"):
        load_demonstration(path)


def test_tracked_demonstrations_pass_the_step_checks(paper_demo):
    """The RTS tracker's view, even with 1 m of position noise, is within every step limit."""
    from drivestyle.envs.plausibility import step_problems
    from drivestyle.envs.tracking import observe

    rng = np.random.default_rng(3)
    for sigma in (0.0, 0.3, 1.0):
        demo = observe(paper_demo, sigma, rng)
        assert step_problems(demo.t, demo.ev, demo.vehicles, demo.scenario) == []


@pytest.mark.slow  # reads every recorded episode: CI runs it (pytest -m slow)
@pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not beside the checkout")
def test_every_recorded_episode_passes_the_step_checks():
    from drivestyle.envs.plausibility import step_problems
    from drivestyle.recorded.real_data import load_cats, load_ngsim

    episodes = [*load_ngsim(DATA / "ngsim"), *load_cats(DATA / "cats-av-lanechange")]
    demos = [e.demo for e in episodes if e.demo is not None]
    assert len(demos) > 40
    for d in demos:
        assert step_problems(d.t, d.ev, d.vehicles, d.scenario) == [], d.meta["episode_id"]


def test_step_messages_count_from_the_window_start(paper_demo):
    from drivestyle.envs.plausibility import step_problems

    demo = _ev_jumps(50.0, k=2)(paper_demo)
    (msg,) = [m for m in step_problems(demo.t[:3], demo.ev[:3], demo.vehicles[:3],
                                       demo.scenario, first=40) if "moves" in m]  # fmt: skip
    assert "(samples 41 and 42)" in msg
