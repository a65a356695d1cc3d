"""A stable-baselines3 policy trained on a learned style's reward (the RL baseline).

Needs the ``rl`` extra (stable-baselines3, torch). The training env is
:func:`make_rl_env` (learned reward, translation-invariant observation, actions in
[−1, 1]) inside SB3's ``VecNormalize`` (observations normalised, rewards left as the
learned cost so that returns stay comparable with θᵀf). A receding-horizon driver style
(:mod:`drivestyle.irl.driver.driver_style`) trains on its per-step cost instead
(:class:`drivestyle.irl.driver.driver_cost.DriverCostReward`).
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from drivestyle.common.io import read_json
from drivestyle.envs.lane_change import LaneChangeEnv
from drivestyle.envs.rl import NormalisedAction, RLObservation, physical_action, rl_observation
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.traffic import TrafficEnv
from drivestyle.irl.driver.driver_cost import DriverCostConfig, DriverCostReward
from drivestyle.irl.driver.driver_style import DRIVER_STYLE_KIND, DriverStyle, load_driver_style
from drivestyle.irl.paper.style import Style, StyleError, load_style
from drivestyle.irl.paper.style_reward import LearnedStyleReward

__all__ = [
    "ALGOS",
    "SB3Policy",
    "TrainConfig",
    "load_reward_style",
    "make_rl_env",
    "train_baseline",
]

ALGOS = ("sac", "ppo")


@dataclass(frozen=True)
class TrainConfig:
    """Training settings of the SB3 baseline."""

    algo: str = "ppo"
    """'ppo' (default: stable here) or 'sac'."""
    timesteps: int = 60_000
    """Environment steps (PPO: ≈ 4 min on 2 cores; 300 000 for the longer budget)."""
    seed: int = 0
    """Seeds SB3, torch, numpy and the envs."""
    eval_freq: int = 2_000
    """Evaluate every this many steps."""
    n_eval_episodes: int = 1
    """Episodes per evaluation (the paper scenario is deterministic: one suffices)."""
    randomize: bool = False
    """Train on the random scenario family instead of the fixed scenario."""
    traffic: bool = False
    """Train in traffic (``Traffic-v0`` / ``TrafficRandom-v0``)."""
    crash_penalty: float | None = None
    """Cost of a crash (None: the reward's default, see drivestyle.irl.paper.style_reward)."""
    norm_reward: bool = False
    """Normalise rewards during training (VecNormalize); evaluations stay raw."""
    driver_cost: DriverCostConfig | None = None
    """Penalties and scale of a driver style's reward (None: the defaults;
    ``crash_penalty`` above, when set, overrides its crash penalty)."""
    log_std_init: float | None = None
    """Initial log standard deviation of the Gaussian policy (None: SB3's default 0, i.e.
    exploration noise as wide as the normalised action range). Smaller keeps PPO's clipped
    noisy actions from biasing the mean on a cost quadratic in the input."""

    def __post_init__(self) -> None:
        if self.algo not in ALGOS:
            raise ValueError(f"algo must be one of {ALGOS}, got {self.algo!r}")
        for name in ("timesteps", "eval_freq", "n_eval_episodes"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.log_std_init is not None and not (-5.0 <= self.log_std_init <= 2.0):
            raise ValueError(f"log_std_init must lie in [-5, 2], got {self.log_std_init!r}")


def load_reward_style(path: str | Path) -> Style | DriverStyle:
    """A style file of either model: a driver style (``kind`` driver-style) or a paper style.

    Args:
        path: ``style.json`` or its folder.

    Raises:
        FileNotFoundError: no such file.
        StyleError, DriverStyleError: the file is malformed.
    """
    _, raw = read_json(path, "style.json", StyleError, "style file")
    if raw.get("kind") == DRIVER_STYLE_KIND:
        return load_driver_style(path)
    return load_style(path)


def _reward_wrapper(
    env: gym.Env,
    style: Style | DriverStyle | str | Path,
    crash_penalty: float | None,
    driver_cost: DriverCostConfig | None,
) -> gym.Env:
    """The style's reward around ``env``: a driver style's per-step cost or θᵀΔf."""
    if isinstance(style, (str, Path)):
        style = load_reward_style(style)
    if isinstance(style, DriverStyle):
        cfg = driver_cost or DriverCostConfig()
        if crash_penalty is not None:
            cfg = replace(cfg, crash_penalty=crash_penalty)
        return DriverCostReward(env, style, cfg)
    return LearnedStyleReward(env, style, crash_penalty)


def make_rl_env(
    style: Style | DriverStyle | str | Path,
    scenario: str | ScenarioConfig = "paper",
    randomize: bool = False,
    monitor_file: str | Path | None = None,
    render_mode: str | None = None,
    crash_penalty: float | None = None,
    traffic: bool = False,
    driver_cost: DriverCostConfig | None = None,
    **overrides: Any,
) -> gym.Env:
    """The RL training env: learned reward, RL observation, actions in [−1, 1].

    Args:
        style: ``style.json`` path (either model) or a loaded
            :class:`drivestyle.irl.paper.style.Style` or
            :class:`drivestyle.irl.driver.driver_style.DriverStyle`.
        scenario: scenario name or config.
        randomize: draw scenarios per reset (``LaneChangeRandom``).
        monitor_file: write SB3 ``Monitor`` episode statistics to this CSV.
        render_mode: passed to the env.
        crash_penalty: see :class:`drivestyle.irl.paper.style_reward.StyleReward`.
        traffic: the traffic env (``Traffic-v0``, or ``TrafficRandom-v0`` with randomize)
            instead of the single-TV one (``scenario`` then ignored).
        driver_cost: penalties and scale of a driver style's reward.
        **overrides: scenario overrides.

    Returns:
        The wrapped env.
    """
    from stable_baselines3.common.monitor import Monitor

    env: gym.Env
    if traffic:
        env = TrafficEnv(randomize=randomize, render_mode=render_mode, **overrides)
    else:
        env = LaneChangeEnv(
            scenario=scenario, randomize=randomize, render_mode=render_mode, **overrides
        )
    env = _reward_wrapper(env, style, crash_penalty, driver_cost)
    env = Monitor(
        env,
        None if monitor_file is None else str(monitor_file),
        info_keywords=("collision", "off_road"),
    )
    return NormalisedAction(RLObservation(env))


def _vec_env(
    style: Any,
    scenario: Any,
    seed: int,
    monitor: Path | None,
    randomize: bool,
    crash_penalty: float | None,
    traffic: bool = False,
    driver_cost: DriverCostConfig | None = None,
):
    from stable_baselines3.common.vec_env import DummyVecEnv

    def make():
        env = make_rl_env(
            style,
            scenario,
            randomize=randomize,
            monitor_file=monitor,
            crash_penalty=crash_penalty,
            traffic=traffic,
            driver_cost=driver_cost,
        )
        env.reset(seed=seed)
        env.action_space.seed(seed)
        return env

    return DummyVecEnv([make])


def train_baseline(
    style: Any,
    out: str | Path,
    config: TrainConfig | None = None,
    scenario: str | ScenarioConfig = "paper",
    progress: bool = True,
) -> dict[str, Any]:
    """Train an SB3 policy on the learned reward and save it.

    Writes ``OUT/model.zip``, ``OUT/vecnormalize.pkl``, ``OUT/monitor.csv`` (training
    episodes), ``OUT/evaluations.npz`` (EvalCallback) and returns a summary.

    Args:
        style: ``style.json`` path or loaded style.
        out: output folder.
        config: training settings.
        scenario: scenario name or config.
        progress: show a progress bar.

    Returns:
        Summary: algorithm, timesteps, training time, final evaluation return, paths.
    """
    import torch
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import BaseCallback, EvalCallback
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import VecNormalize
    from tqdm import tqdm

    cfg = config or TrainConfig()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)  # small networks: threads cost more than they give
    set_random_seed(cfg.seed)
    # rewards may be normalised for learning only; evaluation reports the raw learned cost
    train_env = VecNormalize(
        _vec_env(
            style,
            scenario,
            cfg.seed,
            out / "monitor.csv",
            cfg.randomize,
            cfg.crash_penalty,
            cfg.traffic,
            cfg.driver_cost,
        ),
        norm_obs=True,
        norm_reward=cfg.norm_reward,
        gamma=0.99,
    )
    eval_env = VecNormalize(
        _vec_env(
            style,
            scenario,
            cfg.seed + 1,
            None,
            cfg.randomize,
            cfg.crash_penalty,
            cfg.traffic,
            cfg.driver_cost,
        ),
        norm_obs=True,
        norm_reward=False,
        training=False,
    )

    class Progress(BaseCallback):
        def _on_training_start(self) -> None:
            self.bar = tqdm(
                total=cfg.timesteps, desc=f"{cfg.algo.upper()} training", disable=not progress
            )

        def _on_step(self) -> bool:
            self.bar.update(1)
            return True

        def _on_training_end(self) -> None:
            self.bar.close()

    eval_cb = EvalCallback(
        eval_env,
        eval_freq=cfg.eval_freq,
        n_eval_episodes=cfg.n_eval_episodes,
        log_path=str(out),
        best_model_save_path=None,
        deterministic=True,
        verbose=0,
    )
    # hyper-parameters: stable-baselines3's defaults (learning rates 3e-4, PPO clip 0.2,
    # GAE λ 0.95, 10 epochs; SAC τ 0.005, automatic entropy) except rollout and batch sizes
    # sized for 30-step episodes (PPO n_steps 512 = 17 episodes per update, batch 128; SAC
    # learning_starts 500, batch 256) and a 128 × 128 network as in the RL Zoo's
    # continuous-control settings
    sac = cfg.algo == "sac"
    algo: type[SAC] | type[PPO] = SAC if sac else PPO
    # per-algorithm keywords, checked by SB3's constructors
    extra: dict[str, Any] = (
        {"learning_starts": 500, "batch_size": 256} if sac else {"n_steps": 512, "batch_size": 128}
    )
    model = algo(
        "MlpPolicy",
        train_env,
        seed=cfg.seed,
        verbose=0,
        gamma=0.99,
        policy_kwargs={"net_arch": [128, 128]}
        | ({} if cfg.log_std_init is None else {"log_std_init": cfg.log_std_init}),
        **extra,
    )
    t0 = time.perf_counter()
    model.learn(total_timesteps=cfg.timesteps, callback=[Progress(), eval_cb])
    train_s = time.perf_counter() - t0
    model.save(out / "model.zip")
    train_env.save(str(out / "vecnormalize.pkl"))
    summary = {
        "algo": cfg.algo,
        "timesteps": cfg.timesteps,
        "seed": cfg.seed,
        "train_time_s": train_s,
        "randomize": cfg.randomize,
        "traffic": cfg.traffic,
        "driver_cost": None if cfg.driver_cost is None else asdict(cfg.driver_cost),
        "log_std_init": cfg.log_std_init,
        "final_eval_return": (
            float(eval_cb.last_mean_reward) if np.isfinite(eval_cb.last_mean_reward) else None
        ),
        "model": "model.zip",  # relative: the folder may be renamed into place
        "vecnormalize": "vecnormalize.pkl",
    }
    (out / "train_summary.json").write_text(json.dumps(summary, indent=2))
    return summary


class SB3Policy:
    """A trained baseline acting on the *raw* drivestyle observation in physical units.

    Args:
        folder: output folder of :func:`train_baseline` (model.zip, vecnormalize.pkl,
            train_summary.json).
    """

    def __init__(self, folder: str | Path) -> None:
        from stable_baselines3 import PPO, SAC
        from stable_baselines3.common.vec_env import VecNormalize

        folder = Path(folder)
        if folder.suffix == ".zip":
            folder = folder.parent
        summary_path = folder / "train_summary.json"
        if not (folder / "model.zip").is_file() or not summary_path.is_file():
            raise FileNotFoundError(
                f"no trained baseline in {folder} (model.zip and "
                "train_summary.json expected; run train_baseline.py)"
            )
        self.summary = json.loads(summary_path.read_text())
        algos: dict[str, type[SAC] | type[PPO]] = {"sac": SAC, "ppo": PPO}
        algo = algos[self.summary["algo"]]
        self.model = algo.load(folder / "model.zip", device="cpu")
        with open(folder / "vecnormalize.pkl", "rb") as fh:
            import pickle

            self.norm: VecNormalize = pickle.load(fh)
        self.norm.training = False
        self._numpy_network()

    def act(self, env: Any, obs: np.ndarray) -> np.ndarray:
        """Deterministic action [a, δ] in physical units for the env's raw observation.

        Args:
            env: the drivestyle env (its unwrapped state gives time and bounds).
            obs: raw observation, shape (8,).

        Returns:
            [a, δ] [m/s², rad].
        """
        base = env.unwrapped
        o = rl_observation(obs, base.k, base.scenario)
        a = self.forward(o)
        low, high = base.action_space.low, base.action_space.high
        return physical_action(a, low, high, base.ev, base.scenario)

    def _numpy_network(self) -> None:
        """Copy the deterministic action path into numpy (a decision in microseconds).

        PPO: the policy MLP then the Gaussian mean, clipped to [−1, 1] (SB3's ``predict``);
        SAC: the actor MLP then tanh of the mean (its squashing). Observations are
        normalised with the stored VecNormalize statistics, as ``predict`` would see them.
        """
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.running_mean_std import RunningMeanStd

        model = self.model
        if isinstance(model, PPO):  # loaded as summary["algo"]
            policy = model.policy
            body, head, self._squash = policy.mlp_extractor.policy_net, policy.action_net, False
        else:
            actor = model.policy.actor
            body, head, self._squash = actor.latent_pi, actor.mu, True
        layers: list[tuple[str, Any]] = []
        for module in [*body, head]:
            if isinstance(module, torch.nn.Linear):
                w = module.weight.detach().cpu().numpy().astype(np.float64)
                b = module.bias.detach().cpu().numpy().astype(np.float64)
                layers.append(("linear", (w, b)))
            elif isinstance(module, torch.nn.Tanh):
                layers.append(("tanh", None))
            elif isinstance(module, torch.nn.ReLU):
                layers.append(("relu", None))
            else:
                raise TypeError(f"unsupported layer {module!r} in the policy network")
        self._layers = layers
        rms = self.norm.obs_rms
        if not isinstance(rms, RunningMeanStd):  # a dict: a Dict observation space
            raise TypeError("the baseline expects one Box observation, not a Dict space")
        self._obs_mean: np.ndarray = np.asarray(rms.mean, float)
        self._obs_scale: np.ndarray = 1.0 / np.sqrt(np.asarray(rms.var, float) + self.norm.epsilon)
        self._clip_obs: float = float(self.norm.clip_obs)

    def forward(self, observation: np.ndarray) -> np.ndarray:
        """Deterministic normalised action in [−1, 1]² of an RL observation (numpy only)."""
        z = np.clip(
            (np.asarray(observation, float) - self._obs_mean) * self._obs_scale,
            -self._clip_obs,
            self._clip_obs,
        )
        for kind, params in self._layers:
            if kind == "linear":
                w, b = params
                z = w @ z + b
            elif kind == "tanh":
                z = np.tanh(z)
            else:
                z = np.maximum(z, 0.0)
        return np.tanh(z) if self._squash else np.clip(z, -1.0, 1.0)
