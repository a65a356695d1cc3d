import json
import runpy
from pathlib import Path

import numpy as np
import pytest

from drivestyle.agents.sb3_baseline import SB3Policy, TrainConfig, make_rl_env, train_baseline
from drivestyle.envs import LaneChangeEnv
from drivestyle.irl import FeatureConfig, IRLConfig
from drivestyle.irl.paper.style import fit_style

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def style_file(tmp_path_factory, paper_demo):
    from drivestyle.common.io import write_json
    from drivestyle.envs import save_demonstration

    folder = tmp_path_factory.mktemp("style")
    demo_path = save_demonstration(paper_demo, folder / "demo.npz")
    payload = fit_style(
        paper_demo, FeatureConfig(feature_set="reactive"), IRLConfig(), demo_paths=[str(demo_path)]
    ).to_json()
    return write_json(folder / "style.json", payload)


def test_rl_env_passes_sb3_check(style_file):
    import warnings

    from stable_baselines3.common.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(make_rl_env(style_file))
    env = make_rl_env(style_file)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (8,) and obs[4] == pytest.approx(-20.0)  # x_TV − x_EV
    assert env.action_space.low.tolist() == [-1.0, -1.0]


def test_rl_env_of_a_driver_style_file_trains_on_its_cost(tmp_path):
    from drivestyle.common.io import write_json
    from drivestyle.irl.driver.driver_cost import DriverCostConfig, DriverCostReward
    from drivestyle.irl.driver.driver_style import DRIVER_STYLE_KIND, DriverStyle

    style = DriverStyle((0.2, 34.0, 0.2, 1.0, 76.0), risk=0.9)
    path = write_json(
        tmp_path / "style.json", {"kind": DRIVER_STYLE_KIND, "style": style.to_json()}
    )
    env = make_rl_env(path, randomize=True, crash_penalty=7.0)
    wrapper = env.get_wrapper_attr("style_reward")
    assert isinstance(env.unwrapped, LaneChangeEnv) and wrapper.crash_penalty == 7.0
    assert wrapper.style == style
    cfg = DriverCostConfig(chance_weight=1.0)
    env = make_rl_env(style, driver_cost=cfg)
    obs, _ = env.reset(seed=0)
    _, r, *_ = env.step(np.zeros(2, np.float32))
    assert obs.shape == (8,) and np.isfinite(r) and r < 0
    assert any(isinstance(w, DriverCostReward) for w in _wrappers(env))


def test_log_std_init_is_validated():
    assert TrainConfig(log_std_init=-1.0).log_std_init == -1.0
    with pytest.raises(ValueError, match="log_std_init"):
        TrainConfig(log_std_init=9.0)


def _wrappers(env):
    while hasattr(env, "env"):
        yield env
        env = env.env


@pytest.mark.slow  # trains two policies end to end
@pytest.mark.parametrize("algo", ["sac", "ppo"])
def test_train_save_reload_identical_actions(tmp_path, style_file, algo):
    cfg = TrainConfig(algo=algo, timesteps=128 if algo == "sac" else 256, eval_freq=128)
    summary = train_baseline(style_file, tmp_path / algo, cfg, progress=False)
    assert (tmp_path / algo / "model.zip").is_file()
    assert (tmp_path / algo / "monitor.csv").is_file() and summary["train_time_s"] > 0
    a, b = SB3Policy(tmp_path / algo), SB3Policy(tmp_path / algo / "model.zip")
    env = LaneChangeEnv()
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        ua, ub = a.act(env, obs), b.act(env, obs)
        np.testing.assert_array_equal(ua, ub)
        # the numpy forward pass equals SB3's own predict on the normalised observation
        from drivestyle.envs.rl import rl_observation

        o = rl_observation(obs, env.k, env.scenario)
        sb3, _ = a.model.predict(a.norm.normalize_obs(o[None, :]), deterministic=True)
        np.testing.assert_allclose(a.forward(o), sb3[0], atol=1e-5)
        assert np.all(ua >= env.action_space.low) and np.all(ua <= env.action_space.high)
        obs, *_ = env.step(ua)


@pytest.mark.slow  # trains two policies: CI runs it (pytest -m slow)
def test_training_is_deterministic_given_seed(tmp_path, style_file):
    cfg = TrainConfig(algo="ppo", timesteps=256, eval_freq=256, seed=3)
    train_baseline(style_file, tmp_path / "a", cfg, progress=False)
    train_baseline(style_file, tmp_path / "b", cfg, progress=False)
    env = LaneChangeEnv()
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(
        SB3Policy(tmp_path / "a").act(env, obs), SB3Policy(tmp_path / "b").act(env, obs)
    )


@pytest.mark.slow  # end to end: the whole command
def test_scripts_train_compare_render(tmp_path, style_file):
    def main(name):
        return runpy.run_path(
            str(ROOT / "scripts" / f"{name}.py"),
            run_name="x",
        )["main"]

    model = tmp_path / "model"
    main("train_baseline")(
        [
            "--style",
            str(style_file),
            "--algo",
            "ppo",
            "--timesteps",
            "256",
            "--eval-freq",
            "128",
            "--out",
            str(model),
        ]
    )
    for f in ("model.zip", "vecnormalize.pkl", "monitor.csv", "learning_curve.png", "train.json"):
        assert (model / f).is_file(), f
    out = tmp_path / "cmp"
    res = main("compare_baseline")(
        ["--style", str(style_file), "--model", str(model), "--out", str(out)]
    )
    assert set(res["methods"]) == {"smpc", "spline", "sb3"}
    for m in res["methods"].values():
        for key in (
            "learned_cost",
            "feature_error",
            "rmse_y_m",
            "rmse_xy_m",
            "min_d_k",
            "collision",
            "compute_time_s",
        ):
            assert key in m
    spline = res["methods"]["spline"]
    # r*_θ minimises θᵀf: never costlier than the demonstration under the same θ
    assert spline["learned_cost"] <= res["methods"]["smpc"]["learned_cost"] + 1e-6
    assert (out / "compare.png").is_file() and "| SB3 policy |" in (out / "compare.md").read_text()
    js = json.loads((out / "compare.json").read_text())
    assert js["methods"]["smpc"]["rmse_y_m"] == pytest.approx(0.0, abs=1e-9)

    import imageio.v3 as iio

    for policy, extra in (
        ("expert", []),
        ("spline", ["--style", str(style_file)]),
        ("sb3", ["--model", str(model)]),
    ):
        video = tmp_path / f"{policy}.mp4"
        summary = main("render_rollout")(["--policy", policy, "--video", str(video), *extra])
        frames = iio.imread(video)
        assert frames.shape[0] == summary["frames"]
        if policy != "sb3":  # the untrained policy may crash early
            assert summary["frames"] == 31
        assert frames.shape[1:] == (180, 900, 3)
        for f in frames[:: max(1, len(frames) // 4)]:
            assert f.std() > 5  # not blank
    gif = tmp_path / "expert.gif"
    main("render_rollout")(["--policy", "expert", "--video", str(gif)])
    assert iio.imread(gif).shape[0] == 31


def test_heldout_comparison_scores_every_method(style_file, tmp_path):
    from drivestyle.irl.paper.style import load_style
    from drivestyle.studies.compare import HeldoutComparison, heldout_comparison
    from drivestyle.studies.compare.figures import plot_heldout

    res = heldout_comparison(load_style(style_file), {}, k=2, seed=3000, risk=0.7)
    assert isinstance(res, HeldoutComparison)
    summary = res.summary
    assert set(summary) == {"smpc", "spline"}
    assert summary["smpc"].median_rmse_y_m == pytest.approx(0.0, abs=1e-12)
    assert 0 < summary["spline"].median_rmse_y_m < 5
    assert summary["smpc"].collisions == 0 and summary["spline"].n == 2
    js = res.to_json()  # heldout.json's keys
    assert list(js) == ["per_scenario", "summary"]
    assert set(js["summary"]["spline"]) == {
        "median_rmse_y_m",
        "collisions",
        "median_cost",
        "decision_ms",
        "min_d_k",
        "n",
        "median_rmse_xy_m",
        "enters_ellipse",
    }
    assert plot_heldout(res, tmp_path / "h.png").stat().st_size > 5_000
    with pytest.raises(ValueError, match="held-out"):
        heldout_comparison(load_style(style_file), {}, k=0, seed=1, risk=0.7)


def test_a_deviating_tv_brakes_as_documented_and_the_smpc_reacts(style_file):
    from drivestyle.agents import generate_demonstration
    from drivestyle.envs.lane_change import LaneChangeEnv, TVDeviation
    from drivestyle.irl.paper.style import load_style
    from drivestyle.studies.compare.deviation import deviating_tv_study

    with pytest.raises(ValueError, match="duration"):
        TVDeviation(duration=0.0)
    env = LaneChangeEnv(tv_deviation=TVDeviation(t_start=1.0, accel=-4.0, duration=1.0))
    env.reset()
    for _ in range(15):
        env.step(np.zeros(2))
    assert env.tv[3] == pytest.approx(28.0 - 4.0 * 1.0)  # braked for exactly 1 s
    style = load_style(style_file)
    nominal = generate_demonstration(0.7)[0]
    res = deviating_tv_study(style, nominal, TVDeviation())
    assert set(res.methods) == {"smpc", "spline_open_loop", "spline_receding"}
    smpc = res.methods["smpc"]
    assert smpc.rmse_y_vs_smpc_m == 0.0
    assert not smpc.collision and smpc.min_d_k > 0
    braking_steps = sum(1.5 <= k * 0.2 < 3.0 for k in range(30))  # steps starting inside
    assert res.tv[-1, 3] == pytest.approx(28.0 - 4.0 * 0.2 * braking_steps)
    js = res.to_json()  # deviation.json's study keys
    assert list(js) == ["deviation", "replan_every", "methods"]
    assert js["deviation"] == {"t_start": 1.5, "accel": -4.0, "duration": 1.5}
    assert set(js["methods"]["smpc"]) == {"collision", "min_d_k", "rmse_y_vs_smpc_m", "n_samples"}


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_traffic_training_env_passes_sb3_check_and_a_policy_trains(style_file, tmp_path):
    import warnings

    from stable_baselines3.common.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(make_rl_env(style_file, traffic=True, randomize=True))
    cfg = TrainConfig(timesteps=256, eval_freq=256, traffic=True, randomize=True)
    train_baseline(style_file, tmp_path / "traffic", cfg, progress=False)
    from drivestyle.envs.traffic import TrafficEnv

    env = TrafficEnv()
    obs, _ = env.reset(seed=0)
    u = SB3Policy(tmp_path / "traffic").act(env, obs)
    assert np.all(u >= env.action_space.low) and np.all(u <= env.action_space.high)
