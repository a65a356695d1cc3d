r"""Replay recorded scenes with every vehicle reactive: collisions and speeds against the log.

Each episode of the shipped samples' benchmark ``--split`` (NGSIM and CATS in ``--data-dir``;
validation by default; ``--split-file``: another split than the shipped one) or every usable
episode of an ``--episodes`` folder (written by ``drivestyle extract-episodes``) is replayed
once in ``drivestyle/Recorded-v0`` from the end of its observed part to the end of its log:
every surrounding vehicle drives the IDM behind its leader along its log's lateral path, the
EV the same IDM through the bicycle (DESIGN §24).
``--idm calibrated`` (default) takes the IDM's parameters from the physics baseline
calibrated on the train split (drivestyle/data/benchmark_physics.json, or ``--physics``);
``--idm highway-env`` the traffic env's. ``--others style --posterior FILE`` replays the same
scenes with every vehicle, the EV included, driving its own style identified from the
samples up to the start by the amortized posterior (build-posterior's ``OUT/posterior.npz``),
re-planning at every step against the current states of the vehicles ahead and, changing
lane, the target lane's (``--attend``: others). Reports per episode the collisions of
the replay and of the log itself (pairs and times; new: a pair the log never has) and each vehicle's
replayed speed range against its recorded one (within: inside it ± ``--tolerance``).
Writes ``OUT/replay.json`` (every episode, the summary, the command) and ``OUT/replay.md``.

Example:
    drivestyle replay-recorded --split validation --workers 1 --out runs/replay
    drivestyle replay-recorded --others style --posterior runs/posterior/posterior.npz \
        --out runs/replay_style
    python scripts/replay_recorded.py --episodes runs/episodes --out runs/replay_mine
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, for_option, positive_float, run_cli, workers
from drivestyle.common.io import (
    atomic_output_dir,
    check_output_dir,
    command_line,
    write_json,
    write_text,
)
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.prediction.physics_calibration import PHYSICS_FILE, load_params
from drivestyle.prediction.scene_drivers import ATTEND
from drivestyle.recorded.benchmark import DEFAULT_DATA_DIR, SPLIT_FILE, SPLITS, read_split
from drivestyle.recorded.real_data import DATASETS, check_data_dir
from drivestyle.studies.replay import (
    IDM_CHOICES,
    OTHERS_CHOICES,
    SPEED_TOLERANCE_MPS,
    folder_episodes,
    replay_markdown,
    replay_recorded,
    split_episodes,
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--split",
        choices=SPLITS,
        default=None,
        help="the shipped benchmark split to replay (default: validation; the test split is "
        "run once, by the issue it judges); not with --episodes",
    )
    p.add_argument(
        "--split-file",
        type=Path,
        default=None,
        help=f"the benchmark split (CSV; default: {SPLIT_FILE.name} shipped with the package); "
        "not with --episodes",
    )
    p.add_argument(
        "--episodes",
        type=Path,
        default=None,
        help="a folder written by drivestyle extract-episodes: replay its usable episodes "
        "instead of the shipped samples",
    )
    p.add_argument(
        "--data-dir",
        type=Path,
        default=None,
        help=f"folder holding {' and '.join(f'{v}/' for v in DATASETS.values())} (default: "
        f"{DEFAULT_DATA_DIR}; not with --episodes)",
    )
    p.add_argument(
        "--others",
        choices=OTHERS_CHOICES,
        default="idm",
        help="how every vehicle drives: the IDM along its log's lateral path, or its own "
        "style identified from the samples up to the start (needs --posterior)",
    )
    p.add_argument(
        "--posterior",
        type=Path,
        default=None,
        help="the amortized posterior (build-posterior's OUT/posterior.npz) of --others style",
    )
    p.add_argument(
        "--attend",
        choices=ATTEND,
        default=None,
        help="whom each style driver of --others style plans around: the vehicles ahead and, "
        "changing lane, the target lane's (default: ahead, the joint prediction's rule), those "
        "ahead in its lane and of the lane it heads for (lanes), or every other vehicle (all)",
    )
    p.add_argument(
        "--idm",
        choices=IDM_CHOICES,
        default=None,
        help="the IDM's parameters of --others idm: the physics baseline's calibration "
        "(default: calibrated), or the traffic env's (highway-env's IDMVehicle)",
    )
    p.add_argument(
        "--physics",
        type=Path,
        default=None,
        help=f"the calibrated physics baseline (default: {PHYSICS_FILE.name} shipped with the "
        "package); with --idm calibrated",
    )
    p.add_argument(
        "--tolerance",
        type=positive_float,
        default=SPEED_TOLERANCE_MPS,
        help="a replayed speed within the recorded range ± this [m/s] counts as within",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/replay"), help="output folder (replaced whole)"
    )
    p.add_argument("--workers", type=workers, default=1, help="worker processes")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Replay; returns replay.json's payload."""
    args = parse_args(argv)
    argv_used = [sys.argv[0], *(argv if argv is not None else sys.argv[1:])]
    own = args.episodes is not None
    chosen = {"--split": args.split, "--split-file": args.split_file, "--data-dir": args.data_dir}
    given = [option for option, value in chosen.items() if value is not None]
    if own and given:
        raise ValueError(
            f"--episodes and {given[0]} contradict: --episodes replays its folder instead of the "
            f"shipped samples; drop one or the other"
        )
    style = args.others == "style"
    if style and args.posterior is None:
        raise ValueError("--others style drives every vehicle by its identified style: give "
                         "--posterior FILE (build-posterior's OUT/posterior.npz)")  # fmt: skip
    if not style and args.posterior is not None:
        raise ValueError("--posterior identifies the styles of --others style; add --others style")
    if not style and args.attend is not None:
        raise ValueError("--attend chooses whom the style drivers plan around; add --others style")
    if style and (args.idm is not None or args.physics is not None):
        option = "--idm" if args.idm is not None else "--physics"
        raise ValueError(f"{option} sets the IDM of --others idm, got --others style")
    idm_choice = args.idm or "calibrated"
    if args.physics is not None and idm_choice != "calibrated":
        raise ValueError(f"--physics sets --idm calibrated's parameters, got --idm {args.idm}")
    split = args.split or "validation"
    data_dir = DEFAULT_DATA_DIR if args.data_dir is None else args.data_dir
    inputs = [args.episodes] if own else [data_dir, args.split_file]
    check_output_dir(args.out, inputs=[*inputs, args.physics, args.posterior])
    with for_option("--physics"):
        physics = load_params(PHYSICS_FILE if args.physics is None else args.physics)
    if style:  # read and checked before any work
        open_posterior(args.posterior)
    if own:
        if not args.episodes.is_dir():
            raise FileNotFoundError(f"--episodes {args.episodes}: no such folder")
        with for_option("--episodes"):
            episodes = folder_episodes(args.episodes)
        source = f"every usable episode of {args.episodes}"
    else:
        check_data_dir(data_dir, default=DEFAULT_DATA_DIR)
        rows = None
        if args.split_file is not None:
            with for_option("--split-file"):
                rows = read_split(args.split_file)
        episodes = split_episodes(data_dir, split, rows)
        source = f"the {split} split of the shipped samples in {data_dir}"
    with tqdm(total=len(episodes), desc="replay", unit="episode") as bar:
        study = replay_recorded(
            episodes, source, idm_choice, physics, args.workers, args.tolerance, bar.update,
            posterior=args.posterior, attend=args.attend or "ahead",
        )  # fmt: skip
    markdown = replay_markdown(study, command_line(argv_used))
    payload = study.to_json()
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "replay.json", payload, argv_used)
        write_text(tmp / "replay.md", markdown)
    print(markdown)
    print(f"wrote {args.out}")
    return payload


if __name__ == "__main__":
    run_cli(main)
