r"""Train a stable-baselines3 policy (SAC or PPO) on a learned style's reward.

Writes ``OUT/model.zip``, ``OUT/vecnormalize.pkl``, ``OUT/monitor.csv``,
``OUT/evaluations.npz``, ``OUT/learning_curve.png`` and ``OUT/train.json``.
Deterministic given ``--seed`` (single-threaded torch).

Default budget (PPO, 60 000 steps) ≈ 4 min on 2 cores; the longer budget:
``--timesteps 300000`` (≈ 18 min). SAC (``--algo sac``, 20 000 steps ≈ 6 min) was less
stable on this reward (docs/RESULTS.md).

Example:
    python scripts/train_baseline.py --style runs/paper/reactive/style.json --algo ppo \\
        --timesteps 20000 --out runs/baseline
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from envs.io import write_json
from envs.plotting import save_figure


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--style", type=Path, required=True, help="style.json (or its folder)")
    p.add_argument("--algo", default="ppo", choices=("ppo", "sac"))
    p.add_argument("--timesteps", type=int, default=60_000)
    p.add_argument("--out", type=Path, default=Path("runs/baseline"))
    p.add_argument("--eval-freq", type=int, default=2_000)
    p.add_argument("--randomize", action="store_true", help="train on random scenarios")
    p.add_argument(
        "--crash-penalty",
        type=float,
        help="cost of a crash (default: 10x the style's cost of its demonstration)",
    )
    p.add_argument(
        "--norm-reward",
        action="store_true",
        help="normalise rewards during training (evaluations stay raw)",
    )
    p.add_argument("--seed", type=int, default=0)
    return p.parse_args(argv)


def plot_learning_curve(out: Path, title: str) -> Path:
    """Training episode returns (monitor.csv) and evaluation returns (evaluations.npz)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    monitor = out / "monitor.csv"
    if monitor.is_file():
        data = np.genfromtxt(monitor, delimiter=",", skip_header=2, usecols=(0, 1))
        data = np.atleast_2d(data)
        if data.size:
            steps = np.cumsum(data[:, 1])
            ax.plot(steps, data[:, 0], ".", ms=2, alpha=0.4, label="training episodes")
            k = min(25, len(data))
            smooth = np.convolve(data[:, 0], np.ones(k) / k, mode="valid")
            ax.plot(steps[k - 1 :], smooth, lw=1.5, label=f"training, mean of {k}")
    evals = out / "evaluations.npz"
    if evals.is_file():
        with np.load(evals) as ev:
            ax.plot(ev["timesteps"], ev["results"].mean(axis=1), "o-", label="evaluation")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return (−learned cost)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend()
    return save_figure(fig, out / "learning_curve.png", dpi=120)


def main(argv: list[str] | None = None) -> dict:
    """Run the training; returns the summary written to train.json."""
    args = parse_args(argv)
    try:
        from agents.sb3_baseline import TrainConfig, train_baseline
        from irl.style import load_style

        style = load_style(args.style)
        cfg = TrainConfig(
            algo=args.algo,
            timesteps=args.timesteps,
            seed=args.seed,
            eval_freq=min(args.eval_freq, args.timesteps),
            randomize=args.randomize,
            crash_penalty=args.crash_penalty,
            norm_reward=args.norm_reward,
        )
    except ImportError as exc:
        sys.exit(
            f"error: {exc}; install the rl extra: pip install -c constraints-cpu.txt -e '.[rl]'"
        )
    except (FileNotFoundError, ValueError) as exc:
        sys.exit(f"error: {exc}")
    summary = train_baseline(style, args.out, cfg)
    summary["style"] = str(args.style)
    plot_learning_curve(args.out, f"{args.algo.upper()} on the learned reward ({args.style})")
    write_json(args.out / "train.json", summary, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"wrote {args.out}/model.zip ({summary['train_time_s']:.0f} s of training); "
        f"final evaluation return {summary['final_eval_return']}"
    )
    return summary


if __name__ == "__main__":
    main()
