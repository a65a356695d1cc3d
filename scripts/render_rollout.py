r"""Render a rollout of the SMPC expert, the spline reproduction or an SB3 policy to video.

Headless (pygame off-screen surfaces through highway-env's viewer): EV red, TV blue,
safety ellipse and λ-scaled ellipse, a caption with t, v and s_e. The spline reproduction
r*_θ is replayed by setting the env to its states at every sample (position, heading
atan2(ṙ^y, ṙ^x), speed |ṙ|).

``--episode FILE.npz`` renders a recorded scene (``drivestyle/Recorded-v0``, DESIGN §24) from
the end of its observed part: the agent (``--agent``, 0 the EV; red) drives ``--policy
replay`` (its recorded inputs), ``--policy idm`` (the reactive vehicles' IDM along its
log's lateral path) or ``--policy style`` (its own style identified from the samples up to
the start; with ``--others style``), the others follow their log or react (``--others
log|idm``, or ``--others style --posterior FILE``: each its own style, identified by the
amortized posterior of build-posterior); the nearest vehicle is blue, the rest grey.

Example:
    python scripts/render_rollout.py --policy expert --video runs/videos/expert.mp4
    drivestyle render-rollout --episode runs/episodes/SOME.npz --policy idm --others idm \
        --video runs/videos/scene.gif
    drivestyle render-rollout --episode runs/episodes/SOME.npz --policy style --others style \
        --posterior runs/posterior/posterior.npz --video runs/videos/styles.gif
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from drivestyle.common.cli import (
    HelpFormatter,
    nonnegative_int,
    positive_int,
    risk_value,
    run_cli,
    seed,
)
from drivestyle.common.io import atomic_output_file, check_output_file, write_json
from drivestyle.envs import load_demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.traffic import DEFAULT_TRAFFIC, TrafficRanges, TrafficScene
from drivestyle.envs.video import SCENE_POLICIES, record_scene, write_video
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.irl.paper.style import load_style
from drivestyle.studies.compare import policy_frames


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--policy",
        required=True,
        choices=("expert", "spline", "sb3", *SCENE_POLICIES),
        help="SMPC expert, spline reproduction of --style, or SB3 policy of --model; with "
        "--episode: replay (the agent's recorded inputs), idm, or style (its identified "
        "style; with --others style)",
    )
    p.add_argument(
        "--episode", type=Path, help="a recorded episode's .npz (extract-episodes): its scene"
    )
    p.add_argument(
        "--agent",
        type=nonnegative_int,
        default=0,
        help="with --episode: the vehicle the policy drives (0 the EV, j the j-th of the "
        "episode's surrounding vehicles)",
    )
    p.add_argument(
        "--others",
        choices=("log", "idm", "style"),
        default="log",
        help="with --episode: the other vehicles follow their log or react (IDM, or each its "
        "style identified by --posterior)",
    )
    p.add_argument(
        "--posterior",
        type=Path,
        help="with --others style: the amortized posterior (build-posterior's "
        "OUT/posterior.npz) that identifies every vehicle's style",
    )
    p.add_argument("--style", type=Path, help="style.json (spline)")
    p.add_argument("--model", type=Path, help="train_baseline.py output folder (sb3)")
    p.add_argument(
        "--demo",
        type=Path,
        help="demonstration whose scenario to use "
        "(default: the style's own demonstration, else the paper scenario)",
    )
    p.add_argument("--risk", type=risk_value, default=0.7, help="SMPC risk p (expert)")
    p.add_argument(
        "--scenario",
        choices=("traffic", "traffic-random"),
        help="drive in the default traffic scene or one drawn with --seed (expert)",
    )
    p.add_argument("--video", type=Path, required=True, help="output .mp4 or .gif")
    p.add_argument("--fps", type=positive_int, default=5, help="frames per second")
    p.add_argument("--seed", type=seed, default=0, help="env seed")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Render; returns a small summary (also written next to the video as JSON)."""
    args = parse_args(argv)
    inputs = [args.style, args.model, args.demo, args.episode, args.posterior]
    check_output_file(args.video, "--video", inputs=inputs)
    if args.video.suffix.lower() not in (".mp4", ".gif"):
        raise ValueError(f"--video must end in .mp4 or .gif, got {args.video.name}")
    # its summary beside it (never over its style.json: --video style.mp4)
    check_output_file(args.video.with_suffix(".json"), "--video", inputs=inputs)
    if args.episode is not None or args.policy in SCENE_POLICIES:
        frames = _scene_frames(args)
    elif args.agent != 0 or args.others != "log":
        raise ValueError("--agent and --others choose the vehicles of an --episode's scene")
    elif args.posterior is not None:
        raise ValueError("--posterior identifies the styles of an --episode's scene")
    else:
        frames = _policy_frames(args)
    summary = {
        "policy": args.policy,
        "video": str(args.video),
        "frames": len(frames),
        "fps": args.fps,
        "frame_shape": list(frames[0].shape),
    }
    if args.episode is not None:
        summary |= {"episode": str(args.episode), "agent": args.agent, "others": args.others}
        if args.posterior is not None:
            summary["posterior"] = str(args.posterior)
    # two files beside each other in a folder that may hold other videos: each is written
    # atomically in place (a folder swap would replace or mix the folder's other files)
    with atomic_output_file(args.video, "--video") as tmp:
        write_video(frames, tmp, args.fps)
    write_json(args.video.with_suffix(".json"), summary, [sys.argv[0], *(argv or sys.argv[1:])])
    print(f"wrote {args.video} ({len(frames)} frames at {args.fps} fps)")
    return summary


def _scene_frames(args: argparse.Namespace) -> list[np.ndarray]:
    """The frames of a recorded scene (``--episode``); its options checked."""
    if args.episode is None:
        raise ValueError(f"--policy {args.policy} drives a recorded scene: give --episode FILE.npz")
    if args.policy not in SCENE_POLICIES:
        raise ValueError(
            f"--episode renders a recorded scene: --policy must be one of {SCENE_POLICIES}, "
            f"got {args.policy}"
        )
    given = [o for o, v in (("--style", args.style), ("--model", args.model), ("--demo", args.demo),
             ("--scenario", args.scenario)) if v is not None]  # fmt: skip
    if given:
        raise ValueError(f"--episode renders its own scene; drop {', '.join(given)}")
    if (args.others == "style") != (args.posterior is not None):
        raise ValueError("--others style and --posterior go together: the posterior identifies "
                         "the styles the vehicles drive")  # fmt: skip
    if args.policy == "style" and args.others != "style":
        raise ValueError("--policy style drives the agent by its identified style: add "
                         "--others style --posterior FILE")  # fmt: skip
    if args.posterior is None:
        return record_scene(args.episode, args.policy, args.agent, args.others)
    posterior = open_posterior(args.posterior)  # read and checked before the scene
    return record_scene(args.episode, args.policy, args.agent, args.others, posterior=posterior)


def _policy_frames(args: argparse.Namespace) -> list[np.ndarray]:
    """The frames of the expert, the spline or an SB3 policy in a simulated scene."""
    style = None
    if args.style is not None:
        style = load_style(args.style)
    demo_path = args.demo
    if demo_path is None and style is not None:
        demo_path = style.demo_path(args.style)
    demo = load_demonstration(demo_path) if demo_path else None
    scenario: ScenarioConfig | TrafficScene | str = demo.scenario if demo is not None else "paper"
    if args.scenario == "traffic":
        scenario = DEFAULT_TRAFFIC
    elif args.scenario == "traffic-random":
        scenario = TrafficRanges().sample(np.random.default_rng(args.seed))
    try:
        return policy_frames(args.policy, scenario, args.risk, style, demo, args.model, args.seed)
    except ImportError as exc:
        raise RuntimeError(f"{exc} (install the extras: pip install -e '.[rl,video]')") from None


if __name__ == "__main__":
    run_cli(main)
