r"""Extract the lane changes of your own trajectories as demonstrations (``.npz``).

Reads DATA with a reader of ``--format`` (``csv``: the generic long table with columns
``id, t, x, y`` and optionally ``recording, v, heading, length, width, lane, frame``;
``ngsim``, ``highd``, ``interaction``: those datasets' published files), finds every lane
change (recorded/episodes.py: a lane line crossed and the new lane held, enough track before
and after, a lateral move of at least ``--min-lateral-move`` lanes), mirrors rightward
changes to +y, keeps the interacting vehicles (target-lane
follower and leader, own-lane leader), resamples to ``--dt``, recovers the inputs and sets
each scenario from the episode's observed part only. Writes ``OUT/<episode>.npz`` for every
usable episode, ``OUT/episodes.csv`` (every episode found, usable or not and why) and
``OUT/extract.json`` (counts and settings).

``--all-vehicles`` also writes every vehicle's windows of the same length without a lane
change (recorded/windows.py: lane keeping, car following, approaching a slower leader, and a
stop-and-go flag), each labelled in episodes.csv's ``kind`` column: a benchmark then scores
every vehicle (``drivestyle evaluate-prediction --episodes OUT``, tables by kind).

Lane lines are given with the road edges: the outermost lines are the edges, a vehicle
outside them is in no lane (a warning names such vehicles). A table of several recordings
(a ``recording`` column) takes ``--lanes lanes.json``, each recording's lines.

The tracks are checked by their physics (recorded/track_checks.py): a file in another unit
(speeds beyond 70 m/s, a time step of 100, headings in degrees) is refused naming the
likely unit; a vehicle beyond a bound alone, two vehicles in one place, a gap longer than
``--max-gap`` across a lane change keep the lane change in episodes.csv, unusable, with
the reason. A demonstration's file name is its episode id made safe
(recorded.episodes.episode_file_name), always inside OUT.

Example:
    python scripts/extract_episodes.py tracks.csv --format csv --lane-width 3.75 \\
        --out runs/episodes
    python scripts/extract_episodes.py freeway.csv --lanes lanes.json --out runs/freeway
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.cli import (
    HelpFormatter,
    float_list,
    for_option,
    fraction,
    positive_float,
    run_cli,
)
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.recorded.episodes import (
    ExtractionConfig,
    episode_file_names,
    extract_episodes,
    write_episodes,
)
from drivestyle.recorded.kinds import EPISODE_KINDS
from drivestyle.recorded.readers import READERS, check_lane_lines, load_lanes

FORMATS = ("csv", "ngsim", "highd", "interaction", "sample")
"""``--format`` choices (each a key of :data:`drivestyle.recorded.readers.READERS`)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    d = ExtractionConfig()
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "data", type=Path, help="the trajectory file (sample: the shipped sample's folder)"
    )
    p.add_argument("--format", default="csv", choices=FORMATS, help="how DATA is written")
    p.add_argument(
        "--out", type=Path, default=Path("runs/episodes"), help="output folder (replaced whole)"
    )
    p.add_argument(
        "--lane-width",
        type=positive_float,
        help="csv: lane width [m], lane lines at its multiples (y = 0 a line) over each "
        "recording's y; default: --lanes or --lane-markings, else the table's lane column",
    )
    p.add_argument(
        "--lane-markings",
        type=float_list,
        help="csv, interaction: every lane line's y in the file's frame [m], road edges "
        "included (the outermost lines are the road edges), e.g. 0,3.75,7.5,11.25 for three "
        "lanes; csv: the same lines for every recording",
    )
    p.add_argument(
        "--lanes",
        type=Path,
        help="csv: a JSON file of each recording's lane lines' y [m] in the file's frame, "
        'road edges included: {"<recording>": [0, 3.75, 7.5, 11.25], ...} (every recording '
        "of the table's recording column), or one list for every recording",
    )
    p.add_argument(
        "--direction",
        help="interaction: the direction of travel in the map frame (its reader's direction=)",
    )
    p.add_argument("--dt", type=positive_float, default=d.dt, help="T_s of the demonstrations [s]")
    p.add_argument(
        "--before", type=positive_float, default=d.before_s, help="window before the crossing [s]"
    )
    p.add_argument(
        "--after", type=positive_float, default=d.after_s, help="window after the crossing [s]"
    )
    p.add_argument(
        "--min-before",
        type=positive_float,
        default=d.min_before_s,
        help="track needed before the crossing [s]",
    )
    p.add_argument(
        "--min-after",
        type=positive_float,
        default=d.min_after_s,
        help="track needed after the crossing [s]",
    )
    p.add_argument(
        "--min-stay",
        type=positive_float,
        default=d.min_stay_s,
        help="time in the old lane before and the new lane after a crossing [s]",
    )
    p.add_argument(
        "--min-lateral-move",
        type=fraction,
        default=d.min_lateral_move,
        help="the least lateral move towards the new lane across the window, as a fraction "
        "of the lane width (the mean of the two lanes'); less is a drift along a line, kept "
        "unusable in episodes.csv; 0: no minimum",
    )
    p.add_argument(
        "--max-gap",
        type=positive_float,
        default=d.max_gap_s,
        help="the longest time between two samples a window may hold [s]: a window is cut at "
        "a longer gap, and a lane change across one (or with an interacting vehicle that has "
        "one in the window) is kept unusable in episodes.csv",
    )
    p.add_argument(
        "--observe",
        type=positive_float,
        default=d.observe_s,
        help="the observed part: the window's first seconds, the only data the scenario "
        "constants (v_ref, ellipse) come from [s]; at most --min-before",
    )
    p.add_argument(
        "--all-vehicles",
        action="store_true",
        help="also every vehicle's windows of the same length without a lane change (lane "
        "keeping, car following, approaching), each labelled with its kind in episodes.csv",
    )
    p.add_argument(
        "--v-ref",
        type=positive_float,
        help="the drivers' desired speed when known (e.g. the speed limit) [m/s]; default: "
        "each episode's observed speed level",
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Extract; returns extract.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[args.data, args.lanes])
    config = ExtractionConfig(
        dt=args.dt,
        before_s=args.before,
        after_s=args.after,
        min_before_s=args.min_before,
        min_after_s=args.min_after,
        min_stay_s=args.min_stay,
        min_lateral_move=args.min_lateral_move,
        max_gap_s=args.max_gap,
        observe_s=args.observe,
        v_ref=args.v_ref,
    )
    if args.format in ("ngsim", "highd", "sample") and (
        args.lane_width is not None or args.lane_markings is not None or args.lanes is not None
    ):
        raise ValueError(
            f"--lane-width, --lane-markings and --lanes are for --format csv (--lane-markings "
            f"also interaction); {args.format} files carry their own lane geometry"
        )
    if args.lanes is not None:
        if args.format != "csv":
            raise ValueError("--lanes is for --format csv (interaction: --lane-markings)")
        pairs = (("--lane-width", args.lane_width), ("--lane-markings", args.lane_markings))
        given = [option for option, value in pairs if value is not None]
        if given:
            raise ValueError(
                f"--lanes {args.lanes} and {' and '.join(given)} contradict: give the lane "
                "lines once (--lanes holds every recording's lines)"
            )
    if args.lane_width is not None and args.lane_markings is not None:
        markings = ",".join(f"{m:g}" for m in args.lane_markings)
        raise ValueError(
            f"--lane-width {args.lane_width:g} and --lane-markings {markings} contradict: give "
            "the lane lines once (--lane-width W puts them at multiples of W, --lane-markings "
            "at the given y)"
        )
    if args.lane_markings is not None and args.format == "csv":  # the option's, not the table's
        check_lane_lines(np.asarray(args.lane_markings, float), "--lane-markings", "as given")
    if args.format == "interaction" and args.lane_width is not None:
        raise ValueError(
            "--lane-width is for --format csv; --format interaction takes the lane lines as "
            "--lane-markings"
        )
    if args.direction is not None and args.format != "interaction":
        raise ValueError(
            f"--direction is for --format interaction; --format {args.format} files say their "
            "own direction of travel"
        )
    if args.format == "interaction" and (args.lane_markings is None or args.direction is None):
        raise ValueError("--format interaction needs --lane-markings and --direction")
    if args.lanes is not None:
        with for_option("--lanes"):
            load_lanes(args.lanes)  # the lanes file checked before the table is read
    t0 = time.perf_counter()
    if args.format == "csv":
        recording = READERS["csv"](
            args.data,
            lane_width=args.lane_width,
            lane_markings=args.lane_markings,
            lanes=args.lanes,
            progress=True,
        )
    elif args.format == "interaction":
        direction = args.direction
        try:
            direction = float(direction)
        except ValueError:
            pass  # a named direction
        recording = READERS["interaction"](args.data, args.lane_markings, direction=direction)
    else:
        recording = READERS[args.format](args.data)
    episodes = extract_episodes(recording, config, progress=True, all_vehicles=args.all_vehicles)
    usable = [e for e in episodes if e.usable]
    kinds = {
        kind: {
            "episodes": sum(e.kind == kind for e in episodes),
            "usable": sum(e.kind == kind for e in usable),
        }
        for kind in EPISODE_KINDS
    }
    payload = {
        "data": str(args.data),
        "format": args.format,
        "config": {k: getattr(config, k) for k in config.__dataclass_fields__},
        "vehicles": sum(len(c.tracks) for c in recording.carriageways),
        "carriageways": [c.name for c in recording.carriageways],
        "n_episodes": len(episodes),
        "n_usable": len(usable),
        "n_mirrored": sum(e.mirrored for e in usable),
        "n_no_interaction": sum(e.no_interaction for e in usable),
        "by_kind": kinds,
        "wall_s": time.perf_counter() - t0,
    }
    episode_file_names(episodes, args.out)  # two files of one name: said with the final path
    with atomic_output_dir(args.out) as tmp:
        write_episodes(episodes, tmp)
        write_json(tmp / "extract.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    changes = [e for e in episodes if e.kind == "lane_change"]
    used = [e for e in changes if e.usable]
    print(
        f"{len(changes)} lane change(s) in {payload['vehicles']} vehicles, {len(used)} usable "
        f"({sum(e.mirrored for e in used)} mirrored, "
        f"{sum(e.no_interaction for e in used)} without an interacting vehicle)"
        + (
            "; windows without one: "
            + ", ".join(
                f"{kind} {n['usable']} usable of {n['episodes']}"
                for kind, n in kinds.items()
                if kind != "lane_change"
            )
            if args.all_vehicles
            else ""
        )
        + f"; wrote {args.out}/episodes.csv"
    )
    return payload


if __name__ == "__main__":
    run_cli(main)
