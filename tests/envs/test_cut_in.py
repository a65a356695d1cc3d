"""drivestyle/CutIn-v0: the ego in the target lane, a plug-in lane changer cutting in ahead."""

import gymnasium as gym
import numpy as np
import pytest

import drivestyle.envs  # noqa: F401 (registers the ids)
from drivestyle.envs import ScenarioConfig, ScenarioRanges, rk4_step
from drivestyle.envs.cut_in import CUT_IN, RISK_BOUNDS, CutInEnv
from drivestyle.envs.reward_model import COLLISION_PENALTY
from drivestyle.envs.safety import elliptical_index


class ScriptedDriver:
    """A CutInDriver applying a constant input; it records what it is shown."""

    def __init__(self, u=(0.0, 0.0)):
        self.u = np.asarray(u, float)
        self.resets = []
        self.seen = []

    def reset(self, scenario, risk):
        self.resets.append((scenario, risk))
        self.seen = []

    def act(self, cutter, ego):
        self.seen.append((cutter.copy(), ego.copy()))
        return self.u.copy()


def _episode(env, seed, actions):
    obs, info = env.reset(seed=seed)
    out = [obs]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        out.append(np.concatenate([obs, [r], info["cutter_input"]]))
        if term or trunc:
            break
    return out


# ------------------------------------------------------------ dynamics and step order
def test_both_vehicles_follow_rk4_and_the_driver_sees_the_states_at_t_k():
    driver = ScriptedDriver([-0.5, 0.01])
    env = CutInEnv(randomize=False, risk=0.7, driver=driver, tv_gap=-30.0)
    obs, info = env.reset(seed=0)
    sc = info["scenario"]
    assert driver.resets == [(sc, 0.7)]
    np.testing.assert_array_equal(obs[:4], sc.tv_initial_state)  # the ego is the TV
    np.testing.assert_array_equal(obs[4:], sc.ev_initial_state)  # the cutter is the EV
    ego, cutter = obs[:4].copy(), obs[4:].copy()
    u_ego = np.array([1.0, -0.002])
    for k in range(12):
        before = obs
        obs, _, term, trunc, info = env.step(u_ego)
        seen_cutter, seen_ego = driver.seen[k]
        np.testing.assert_array_equal(seen_cutter, before[4:])  # inputs from the states at t_k
        np.testing.assert_array_equal(seen_ego, before[:4])
        ego = rk4_step(ego, u_ego, sc.dt, sc.l_f, sc.l_r)
        cutter = rk4_step(cutter, driver.u, sc.dt, sc.l_f, sc.l_r)
        np.testing.assert_allclose(obs[:4], ego, rtol=0, atol=1e-9)
        np.testing.assert_allclose(obs[4:], cutter, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(info["cutter_input"], driver.u)
        np.testing.assert_array_equal(info["action"], u_ego)
        assert not (term or trunc or info["action_clipped"])


def test_straight_constant_inputs_give_the_closed_form_motion():
    # δ = 0: x = x0 + v0 t + a t²/2 exactly (RK4 integrates the quadratic without error)
    driver = ScriptedDriver([-1.0, 0.0])
    env = CutInEnv(randomize=False, driver=driver)
    obs0, _ = env.reset(seed=0)
    for k in range(1, 11):
        obs, *_ = env.step(np.array([2.0, 0.0]))
        t = k * CUT_IN.dt
        assert obs[0] == pytest.approx(obs0[0] + obs0[3] * t + t**2, abs=1e-9)
        assert obs[3] == pytest.approx(obs0[3] + 2.0 * t, abs=1e-12)
        assert obs[4] == pytest.approx(obs0[4] + obs0[7] * t - 0.5 * t**2, abs=1e-9)
        assert obs[7] == pytest.approx(obs0[7] - t, abs=1e-12)
        assert obs[1] == obs0[1] and obs[5] == obs0[5]


def test_info_and_reward_are_the_egos():
    env = CutInEnv(randomize=False, driver=ScriptedDriver([0.0, 0.02]), risk=0.8)
    _, info = env.reset(seed=0)
    assert info["cutter_risk"] == 0.8 and info["t"] == 0.0 and not info["action_clipped"]
    for _ in range(5):
        obs, r, _, _, info = env.step(np.array([-3.0, 0.01]))
    ego, cutter = obs[:4], obs[4:]
    np.testing.assert_array_equal(info["cutter"], cutter)
    s_e = elliptical_index(cutter[0] - ego[0], cutter[1] - ego[1], CUT_IN.l_a, CUT_IN.l_b)
    assert info["s_e"] == pytest.approx(float(s_e)) and info["d_k"] == pytest.approx(s_e - 1)
    assert info["ego_lane_index"] == CUT_IN.target_lane and info["t"] == pytest.approx(1.0)
    # lane error and speed error against the ego's own lane and initial speed
    y_lane = CUT_IN.lane_centres[CUT_IN.tv_lane]
    expected = (
        -(((ego[1] - y_lane) / CUT_IN.lane_width) ** 2) - ((ego[3] - CUT_IN.tv_speed) / 10) ** 2
    )
    assert r == pytest.approx(expected) and r < -0.1


def test_actions_of_both_vehicles_are_clipped():
    env = CutInEnv(randomize=False, driver=ScriptedDriver([20.0, -1.0]))
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([100.0, 0.0]))
    assert info["action_clipped"]
    np.testing.assert_array_equal(info["action"], [CUT_IN.a_max, 0.0])
    np.testing.assert_array_equal(info["cutter_input"], [CUT_IN.a_max, -CUT_IN.delta_max])


# ------------------------------------------------------------ episode end
def test_truncation_after_the_horizon_then_step_raises():
    env = CutInEnv(randomize=False, driver=ScriptedDriver())
    env.reset(seed=0)
    steps, trunc = 0, False
    while not trunc:
        _, _, term, trunc, info = env.step(np.zeros(2))
        assert not term
        steps += 1
    assert steps == CUT_IN.n_steps == 40 and info["t"] == pytest.approx(8.0)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2))


def test_collision_terminates():
    # the cutter steers into the target lane while braking; the ego closes in fast behind
    env = CutInEnv(
        randomize=False, driver=ScriptedDriver([-6.0, 0.05]), tv_gap=-12.0, tv_speed=32.0
    )
    env.reset(seed=0)
    for _ in range(40):
        _, r, term, trunc, info = env.step(np.array([3.0, 0.0]))
        if term or trunc:
            break
    assert term and not trunc and info["collision"] and not info["off_road"]
    assert r <= -COLLISION_PENALTY
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2))


def test_leaving_the_road_terminates():
    env = CutInEnv(randomize=False, driver=ScriptedDriver(), tv_gap=-60.0)
    env.reset(seed=0)
    for _ in range(40):
        _, _, term, _, info = env.step(np.array([0.0, 0.05]))  # steer left, off the edge
        if term:
            break
    assert term and info["off_road"] and not info["collision"]


# ------------------------------------------------------------ randomness
def test_the_risk_is_drawn_per_reset_within_the_range():
    env = CutInEnv(driver=ScriptedDriver(), risk_range=(0.6, 0.7))
    risks = [env.reset(seed=1)[1]["cutter_risk"]] + [
        env.reset()[1]["cutter_risk"] for _ in range(5)
    ]
    assert all(0.6 <= p <= 0.7 for p in risks)
    assert len(set(risks)) == len(risks)
    assert env.reset(seed=1)[1]["cutter_risk"] == risks[0]


def test_a_fixed_risk_keeps_the_scenario_draws():
    drawn = CutInEnv(driver=ScriptedDriver())
    fixed = CutInEnv(driver=ScriptedDriver(), risk=0.9)
    optioned = CutInEnv(driver=ScriptedDriver())
    for k in range(4):  # later resets continue the seed's stream
        seed = 3 if k == 0 else None
        _, a = drawn.reset(seed=seed)
        _, b = fixed.reset(seed=seed)
        _, c = optioned.reset(seed=seed, options={"risk": 0.55})
        assert b["cutter_risk"] == 0.9 != a["cutter_risk"] and c["cutter_risk"] == 0.55
        assert a["scenario"] == b["scenario"] == c["scenario"]  # the same scenes whatever p
    driver = ScriptedDriver()
    env = CutInEnv(driver=driver)
    sc = CUT_IN.with_overrides(tv_gap=-25.0)
    _, info = env.reset(seed=0, options={"scenario": sc, "risk": 0.95})
    assert info["scenario"] is sc and driver.resets[-1] == (sc, 0.95)


def test_random_scenarios_keep_the_ego_in_the_target_lane():
    base = ScenarioConfig(horizon_s=8.0, ev_lane=1, target_lane=2, tv_lane=2)
    env = CutInEnv(base, driver=ScriptedDriver())
    scenarios = [env.reset(seed=s)[1]["scenario"] for s in range(8)]
    assert len(set(scenarios)) == 8
    for sc in scenarios:
        assert sc.tv_lane == sc.target_lane == 2 and sc.ev_lane == 1
        assert 22 <= sc.ev_speed <= 28 and 25 <= sc.tv_speed <= 32 and -30 <= sc.tv_gap <= -10


def test_same_seed_same_episode_with_the_smpc_driver():
    rng = np.random.default_rng(0)
    actions = rng.uniform([-3, -0.01], [2, 0.01], (40, 2))
    a = _episode(gym.make("drivestyle/CutIn-v0"), 4, actions)
    b = _episode(gym.make("drivestyle/CutIn-v0"), 4, actions)
    assert len(a) == len(b) > 10
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


# ------------------------------------------------------------ the SMPC(p) cutter
def _cutter_lateral(risk, **scene):
    env = CutInEnv(randomize=False, risk=risk, **scene)
    env.reset(seed=0)
    ys = []
    for _ in range(CUT_IN.n_steps):
        obs, _, term, trunc, info = env.step(np.zeros(2))
        ys.append(obs[5])
        assert not info["collision"]
        if term or trunc:
            break
    return np.array(ys)


def test_the_smpc_cutter_cuts_in_ahead_of_a_far_ego():
    ys = _cutter_lateral(0.5, tv_gap=-40.0, tv_speed=25.0)
    assert len(ys) == CUT_IN.n_steps
    assert abs(ys[-1] - CUT_IN.y_ref) < 0.1  # in the target lane's centre


def test_the_smpc_cutter_receives_its_risk():
    # ego close and fast: the bold cutter pushes ahead, the cautious one yields first
    bold = _cutter_lateral(0.5, tv_gap=-10.0, tv_speed=32.0)
    cautious = _cutter_lateral(0.99, tv_gap=-10.0, tv_speed=32.0)
    assert bold[9] > cautious[9] + 1.0  # lateral position at t = 2 s
    assert cautious[9] < CUT_IN.lane_width  # still in its own lane


# ------------------------------------------------------------ errors
@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"risk": 0.3}, ValueError, r"risk must lie in \[0.5, 0.99\], got 0.3"),
        ({"risk": float("nan")}, ValueError, r"risk must lie in .*nan"),
        ({"risk": "high"}, TypeError, "risk must be a number"),
        ({"risk_range": (0.9, 0.6)}, ValueError, r"low <= high, got \(0.9, 0.6\)"),
        ({"risk_range": (0.4, 0.6)}, ValueError, r"risk_range\[0\] must lie in .*0.4"),
        ({"risk_range": 0.7}, TypeError, "risk_range must be a pair"),
        ({"tv_lane": 2}, ValueError, "ego .* target lane.*tv_lane=2 and target_lane=1"),
        ({"tv_speed": 80.0}, ValueError, "tv_speed=80.0 exceeds v_max"),
        ({"randomize": ScenarioRanges(base=CUT_IN, tv_lanes=(1, 2))}, ValueError, "tv_lanes"),
        ({"randomize": "yes"}, TypeError, "randomize"),
        ({"driver": object()}, TypeError, "driver must be a CutInDriver"),
        ({"render_mode": "video"}, ValueError, "render_mode"),
        ({"ev_sped": 20.0}, TypeError, "unknown scenario parameter"),
    ],
)
def test_bad_construction_is_a_one_line_error(kwargs, exc, match):
    kwargs = {"driver": ScriptedDriver(), **kwargs}
    with pytest.raises(exc, match=match) as err:
        CutInEnv(**kwargs)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("options", "exc", "match"),
    [
        ({"riks": 0.7}, ValueError, r"unknown reset option\(s\) \['riks'\]"),
        ({"risk": 1.0}, ValueError, r"options\['risk'\] must lie in .*1.0"),
        ({"scenario": "nope"}, KeyError, r"options\['scenario'\].*'nope'"),
        ({"scenario": CUT_IN.with_overrides(tv_lane=2)}, ValueError, "target lane"),
        ("risk", TypeError, "options must be a dict"),
    ],
)
def test_bad_reset_options_are_one_line_errors(options, exc, match):
    env = CutInEnv(driver=ScriptedDriver())
    with pytest.raises(exc, match=match) as err:
        env.reset(seed=0, options=options)
    assert "\n" not in str(err.value)


def test_a_bad_driver_output_and_a_missing_plugin_are_clear_errors(monkeypatch):
    env = CutInEnv(driver=ScriptedDriver([np.nan, 0.0]))
    env.reset(seed=0)
    with pytest.raises(ValueError, match="cutter's driver must return 2 finite numbers"):
        env.step(np.zeros(2))
    import drivestyle.envs.cut_in as cut_in

    monkeypatch.setattr(cut_in, "entry_points", lambda **_: ())
    with pytest.raises(RuntimeError, match=r"plug-in 'smpc' .*'drivestyle.drivers'"):
        CutInEnv()


def test_risk_bounds_are_the_documented_ones():
    assert RISK_BOUNDS == (0.5, 0.99)
    CutInEnv(driver=ScriptedDriver(), risk=0.5, risk_range=(0.99, 0.99))  # both ends admitted


# ------------------------------------------------------------ rendering
def test_rgb_frames_are_not_blank():
    env = CutInEnv(randomize=False, driver=ScriptedDriver([0.0, 0.02]), render_mode="rgb_array")
    env.reset(seed=0)
    frames = [env.render()]
    for _ in range(4):
        env.step(np.array([1.0, 0.0]))
        frames.append(env.render())
    env.close()
    for f in frames:
        assert f.ndim == 3 and f.shape[2] == 3 and f.dtype == np.uint8
        assert f.std() > 5  # not a uniform fill
        colours = f.reshape(-1, 3).astype(int)
        red = (colours[:, 0] > 180) & (colours[:, 1] < 90) & (colours[:, 2] < 90)
        blue = (colours[:, 2] > 180) & (colours[:, 0] < 90)
        assert red.sum() > 50 and blue.sum() > 50  # the cutter (red) and the ego (blue)
    assert not np.array_equal(frames[0], frames[-1])
