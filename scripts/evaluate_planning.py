r"""Plan around a cut-in: an SMPC ego predicting the lane changer by CV, its style or the truth.

Drives ``--scenes`` scenes of ``drivestyle/CutIn-v0`` (the study's family,
``studies/cut_in/study.py``; the lane changer is SMPC(p) with p drawn per scene) with
the ego's three predictors — constant velocity (today's SMPC), the style identified
online with ``--library``, the cutter's true model — and writes ``OUT/planning.json``
(every run and the summaries, with the command), ``OUT/planning.md``,
``OUT/planning.png`` (hardest braking and least margin per scene and predictor) and, with
``--videos``, one scene per predictor as ``OUT/videos/<predictor>.mp4``.

Example:
    python scripts/evaluate_planning.py --library runs/library --scenes 120 --seed 20000 \
        --videos --out runs/planning
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

from drivestyle.agents.aware_planner import PREDICTORS, AwareSMPC
from drivestyle.common.cli import SEED_MAX, HelpFormatter, count, run_cli, seed, workers
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json, write_text
from drivestyle.envs.cut_in import CutInEnv
from drivestyle.envs.video import write_video
from drivestyle.irl.identification.library import load_driver_library
from drivestyle.studies.cut_in import (
    CUT_IN_RANGES,
    PlanningStudy,
    cut_in_study,
    planning_markdown,
    predictor_for,
    run_scene,
)
from drivestyle.studies.cut_in.figures import plot_planning


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument(
        "--library", type=Path, required=True, help="driver library folder or library.json"
    )
    p.add_argument(
        "--scenes", type=count(100_000, 6.0, "scenes"), default=120, help="scenes (each predictor)"
    )
    p.add_argument("--seed", type=seed, default=20000, help="first scene's seed")
    p.add_argument("--workers", type=workers, default=2, help="worker processes")
    p.add_argument("--videos", action="store_true", help="render one scene per predictor (mp4)")
    p.add_argument(
        "--video-scene",
        type=seed,
        help="seed of the rendered scene (default: the scene where CV brakes hardest "
        "relative to the style-aware ego)",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/planning"), help="output folder (replaced whole)"
    )
    args = p.parse_args(argv)
    last = args.seed + args.scenes - 1
    if last > SEED_MAX:
        p.error(
            f"--seed {args.seed} with --scenes {args.scenes} reaches seed {last}, beyond {SEED_MAX}"
        )
    return args


def _video_seed(study: PlanningStudy) -> int:
    """The scene whose CV braking exceeds the style-aware ego's most (the clip's scene)."""
    by = {(r.seed, r.method): r for r in study.runs}
    return max(
        study.seeds,
        key=lambda s: (by[s, "cv"].hardest_braking - by[s, "style"].hardest_braking, -s),
    )


def main(argv: list[str] | None = None) -> dict:
    """Run the study; returns planning.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[args.library])
    library = load_driver_library(args.library, "the style-aware ego")
    with tqdm(total=args.scenes, desc="cut-in scenes", unit="scene") as bar:
        study = cut_in_study(
            library, args.scenes, args.seed, args.workers,
            on_result=lambda _i, _r: bar.update(),
        )  # fmt: skip
    payload = study.to_json()
    payload["ranges"] = {
        "cutter_speed": list(CUT_IN_RANGES.ev_speed),
        "ego_speed": list(CUT_IN_RANGES.tv_speed),
        "gap": list(CUT_IN_RANGES.tv_gap),
    }
    payload["library"] = str(args.library)
    markdown = planning_markdown(study)
    with atomic_output_dir(args.out) as tmp:
        plot_planning(study, tmp / "planning.png")
        if args.videos:
            seed = args.video_scene if args.video_scene is not None else _video_seed(study)
            env = CutInEnv(randomize=CUT_IN_RANGES, render_mode="rgb_array")
            try:
                for method in PREDICTORS:
                    frames: list = []
                    ego = AwareSMPC(predictor_for(method, library))
                    run_scene(env, ego, seed, method, frame=frames.append)
                    write_video(frames, tmp / "videos" / f"{method}.mp4")
            finally:
                env.close()
            payload["video_scene"] = seed
        write_json(tmp / "planning.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        write_text(tmp / "planning.md", markdown)
    print(markdown)
    return payload


if __name__ == "__main__":
    run_cli(main)
