r"""Train a stable-baselines3 policy (SAC or PPO) on a learned style's reward.

The style is either model's file: a receding-horizon driver style (``learn_style.py``, the
default model) trains on its per-step cost — stage cost plus its constraints as penalties
(``drivestyle.irl.driver.driver_cost.DriverCostReward``); a paper-model style on −θᵀΔf.

Writes ``OUT/model.zip``, ``OUT/vecnormalize.pkl``, ``OUT/monitor.csv``,
``OUT/evaluations.npz``, ``OUT/learning_curve.png`` and ``OUT/train.json``.
Deterministic given ``--seed`` (single-threaded torch).

Default budget (PPO, 60 000 steps) ≈ 4 min on 2 cores; the longer budget:
``--timesteps 300000`` (≈ 18 min). SAC (``--algo sac``, 20 000 steps ≈ 6 min) was less
stable on this reward (docs/RESULTS.md).

Example:
    python scripts/train_baseline.py --style runs/paper/reactive/style.json --algo ppo \\
        --timesteps 20000 --out runs/baseline
    python scripts/train_baseline.py --style runs/driver_p06/style.json \\
        --env drivestyle/LaneChangeRandom-v0 --out runs/ppo_p06
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drivestyle.common.cli import HelpFormatter, count, positive_float, positive_int, run_cli, seed
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--style", type=Path, required=True, help="style.json (or its folder)")
    p.add_argument("--algo", default="ppo", choices=("ppo", "sac"), help="SB3 algorithm")
    p.add_argument(
        "--timesteps",
        type=count(100_000_000, 4e-3, "training env steps"),
        default=60_000,
        help="training env steps",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/baseline"), help="output folder (replaced whole)"
    )
    p.add_argument(
        "--eval-freq", type=positive_int, default=2_000, help="env steps between evaluations"
    )
    p.add_argument(
        "--env",
        default="drivestyle/LaneChange-v0",
        choices=(
            "drivestyle/LaneChange-v0",
            "drivestyle/LaneChangeRandom-v0",
            "drivestyle/Traffic-v0",
            "drivestyle/TrafficRandom-v0",
        ),
        help="training env: the style's fixed scenario, the random family, or traffic",
    )
    p.add_argument(
        "--randomize", action="store_true", help="same as --env drivestyle/LaneChangeRandom-v0"
    )
    p.add_argument(
        "--crash-penalty",
        type=positive_float,
        help="cost of a crash (default: 10x the style's cost of its demonstration; driver "
        "style: 100 reward units)",
    )
    p.add_argument(
        "--chance-weight",
        type=float,
        help="driver style: penalty per unit of chance-margin violation (default 10)",
    )
    p.add_argument(
        "--look-ahead",
        type=int,
        help="driver style: the chance penalty's look-ahead J [steps of T_s] (default 0)",
    )
    p.add_argument(
        "--norm-reward",
        action="store_true",
        help="normalise rewards during training (evaluations stay raw)",
    )
    p.add_argument(
        "--log-std-init",
        type=float,
        help="initial log std of the Gaussian policy (default: SB3's 0)",
    )
    p.add_argument("--seed", type=seed, default=0, help="training seed")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Run the training; returns the summary written to train.json."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[args.style])
    try:
        from drivestyle.agents.sb3_baseline import TrainConfig, load_reward_style, train_baseline
        from drivestyle.studies.plotting import plot_learning_curve
    except ImportError as exc:
        raise RuntimeError(
            f"{exc}; install the rl extra: pip install -c constraints-cpu.txt -e '.[rl]'"
        ) from None
    from drivestyle.irl.driver.driver_cost import DriverCostConfig
    from drivestyle.irl.driver.driver_style import DriverStyle

    style = load_reward_style(args.style)
    cost = None
    if isinstance(style, DriverStyle):
        knobs = {"chance_weight": args.chance_weight, "look_ahead": args.look_ahead}
        cost = DriverCostConfig(**{k: v for k, v in knobs.items() if v is not None})
    elif args.chance_weight is not None or args.look_ahead is not None:
        raise ValueError("--chance-weight and --look-ahead need a driver-style file")
    cfg = TrainConfig(
        algo=args.algo,
        timesteps=args.timesteps,
        seed=args.seed,
        eval_freq=min(args.eval_freq, args.timesteps),
        randomize=args.randomize or args.env.endswith("Random-v0"),
        traffic=args.env.startswith("drivestyle/Traffic"),
        crash_penalty=args.crash_penalty,
        norm_reward=args.norm_reward,
        driver_cost=cost,
        log_std_init=args.log_std_init,
    )
    with atomic_output_dir(args.out) as tmp:
        summary = train_baseline(style, tmp, cfg)
        summary["style"] = str(args.style)
        reward = "driver style's cost" if cost is not None else "learned reward"
        plot_learning_curve(tmp, f"{args.algo.upper()} on the {reward} ({args.style})")
        write_json(tmp / "train.json", summary, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"wrote {args.out}/model.zip ({summary['train_time_s']:.0f} s of training); "
        f"final evaluation return {summary['final_eval_return']}"
    )
    return summary


if __name__ == "__main__":
    run_cli(main)
