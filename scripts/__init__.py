"""The command-line entry points, also installed as ``drivestyle <command>``.

Each module here is a script (``python scripts/learn_style.py …`` works from a checkout)
with a ``main(argv)``; :func:`main` dispatches ``drivestyle <command> [args]`` to it, so the
installed command and the script take the same arguments.
"""

from __future__ import annotations

import importlib
import sys

__all__ = ["COMMANDS", "main"]

COMMANDS: dict[str, str] = {
    "reproduce-paper": "the paper's whole study (the main job)",
    "generate-demo": "an SMPC demonstration in the lane-change env",
    "learn-style": "learn a style (θ) from one or more demonstrations",
    "build-style-library": "a style library: θ per risk level over shared scenarios",
    "identify-style": "identify a vehicle's risk level with a style library",
    "evaluate-identification": "identification on held-out scenarios, risks and noise",
    "predict-trajectory": "predict a vehicle's rest of trajectory after t_obs s (style vs CV)",
    "evaluate-prediction": "style-aware prediction vs CV on held-out and recorded vehicles",
    "evaluate-out-of-class": "identification and prediction of drivers outside the style class",
    "learn-population": "one style learned from the recorded benchmark's train split",
    "compare-av-human": "the automated car against human drivers (CATS): identified and observed",
    "mine-styles": "personal style and risk of many demonstrations (local or Ray)",
    "simulate-population": "SMPC vehicles with known risks (ground truth for mining)",
    "real-traffic": "styles of recorded lane changes (NGSIM, CATS)",
    "extract-episodes": "lane changes of your own trajectories as demonstrations",
    "train-baseline": "a stable-baselines3 policy on a learned style's reward",
    "compare-baseline": "SMPC vs spline reproduction vs SB3 policy",
    "deviating-tv": "drivers facing a TV that deviates from its prediction",
    "render-rollout": "a rollout rendered to mp4/gif",
    "replay-recorded": "recorded scenes replayed with every vehicle reactive: collisions, speeds",
    "evaluate-planning": "an SMPC ego planning around a cut-in: CV vs style-aware vs oracle",
    "calibrate-uncertainty": "the TV-uncertainty scale scan (DESIGN §3)",
    "capacity-study": "the style model classes' capacity: best fit vs held out",
    "bench-smpc": "benchmark the SMPC expert",
    "bench-irl": "benchmark ME-IRL and identification",
    "bench-population": "benchmark mining a population",
    "bench-tracker": "benchmark online identification: latency of one StyleTracker update",
    "bench-solver-paths": "faster solver paths against the product: their time, how far S(p) moves",
    "bench-env": "benchmark the Gymnasium envs' steps per second (plain, traffic, style rewards)",
    "bench-scene-prediction": "benchmark predicting a recorded minute: every vehicle, every window",
    "bench-stochastic": "benchmark simulating stochastic drivers from the prior: episodes/s/core",
    "build-posterior": "the amortized posterior over a stochastic driver's parameters, calibrated",
    "profile-inner": "profile the inner solvers: where a solve's time goes",
}
"""Subcommand → what it does; the module is the name with ``_`` for ``-``."""


def _usage() -> str:
    width = max(map(len, COMMANDS))
    lines = [f"  {name:<{width}}  {what}" for name, what in COMMANDS.items()]
    return (
        "usage: drivestyle <command> [options]   (drivestyle <command> --help for its options)\n\n"
        "commands:\n" + "\n".join(lines)
    )


def main(argv: list[str] | None = None) -> None:
    """``drivestyle <command> [args]``: run one script's ``main`` with the CLI's error handling."""
    from drivestyle.common.cli import run_cli

    args = sys.argv[1:] if argv is None else list(argv)
    if not args or args[0] in ("-h", "--help"):
        print(_usage())
        return
    name, rest = args[0], args[1:]
    if name not in COMMANDS:
        print(f"error: unknown command {name!r}\n\n{_usage()}", file=sys.stderr)
        sys.exit(2)
    module = importlib.import_module(f"drivestyle.scripts.{name.replace('-', '_')}")
    sys.argv[0] = f"drivestyle {name}"
    run_cli(module.main, rest)
