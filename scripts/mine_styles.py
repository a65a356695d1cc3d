r"""Mine the styles of many vehicles: per demonstration a personal style and its risk.

INPUT is a folder of demonstrations (``*.npz``, searched recursively, e.g. a
``simulate_population.py`` output) or, with ``--dataset ngsim|cats --data DIR``, a recorded
dataset. Writes ``OUT/styles.csv`` (one row per demonstration: id, source, status, error,
true risk where known, risk estimate, 90 % interval, posterior mean, θ normalised, fit
errors, timings), ``OUT/summary.json`` (n, n_ok, n_failed, wall_s, demos_per_s, engine,
workers, …) and ``OUT/population.png`` (estimated vs true risk; the risk distribution).

Rows are appended to ``styles.csv`` as they finish, so the job is resumable: a rerun with
the same OUT skips the rows already there, and an interruption loses at most the rows in
flight. ``--engine ray`` runs the same work on Ray actors (``--address`` of a cluster, else
Ray on this machine); install the extra with ``pip install -e '.[ray]'``.

Examples:
    python scripts/mine_styles.py runs/population --library runs/library_reactive --out runs/mined
    python scripts/mine_styles.py runs/population --library runs/library_reactive \\
        --engine ray --workers 2 --out runs/mined_ray
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

from drivestyle.agents.studies.figures import plot_population
from drivestyle.envs.real_data import load_cats, load_ngsim
from drivestyle.irl.identification import load_library
from drivestyle.irl.mining import COLUMNS, ENGINES, finished_ids, mine, read_rows, summary_numbers
from tqdm import tqdm

from drivestyle.common.cli import positive_int, run_cli
from drivestyle.common.io import check_output_dir, write_json


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("input", nargs="?", type=Path, help="folder of demonstrations (*.npz)")
    p.add_argument("--dataset", choices=("ngsim", "cats"), help="mine a recorded dataset instead")
    p.add_argument("--data", type=Path, help="the recorded dataset's folder (with --dataset)")
    p.add_argument("--library", type=Path, required=True, help="style library folder or json")
    p.add_argument(
        "--out", type=Path, default=Path("runs/mined"), help="output folder (resumed if present)"
    )
    p.add_argument("--engine", default="local", choices=ENGINES, help="where the work runs")
    p.add_argument("--address", help="Ray cluster address (--engine ray; default: start locally)")
    p.add_argument("--workers", type=positive_int, default=2, help="processes or Ray actors")
    p.add_argument("--seed", type=int, default=0, help="unused: mining is deterministic")
    return p.parse_args(argv)


def _tasks(args: argparse.Namespace) -> list[tuple]:
    if args.dataset:
        if args.data is None or args.input is not None:
            raise ValueError("--dataset needs --data DIR and no INPUT folder")
        loader = load_ngsim if args.dataset == "ngsim" else load_cats
        return [
            (e.episode_id, args.dataset, e.demo)
            for e in loader(args.data)
            if e.used and e.demo is not None
        ]
    if args.input is None:
        raise ValueError("give an INPUT folder of demonstrations or --dataset with --data")
    if not args.input.is_dir():
        raise FileNotFoundError(f"INPUT {args.input} is not a folder")
    files = sorted(args.input.rglob("*.npz"))
    if not files:
        raise ValueError(f"no demonstrations (*.npz) under {args.input}")
    root = str(args.input)
    ids = [f.stem for f in files]
    if len(set(ids)) < len(ids):  # same names in different folders: keep the path
        ids = [str(f.relative_to(args.input).with_suffix("")) for f in files]
    return [(i, root, str(f)) for i, f in zip(ids, files, strict=True)]


def main(argv: list[str] | None = None) -> dict:
    """Mine; returns summary.json's payload."""
    args = parse_args(argv)
    if args.address and args.engine != "ray":
        raise ValueError("--address needs --engine ray")
    check_output_dir(args.out, replace=False)  # resumable: rows of an earlier run are kept
    library = load_library(args.library)
    tasks = _tasks(args)
    args.out.mkdir(parents=True, exist_ok=True)
    table = args.out / "styles.csv"
    previous = read_rows(table)
    done = finished_ids(previous)
    todo = [t for t in tasks if t[0] not in done]
    new_file = not table.exists()
    t0 = time.perf_counter()
    with table.open("a", newline="") as fh, tqdm(total=len(todo), desc="demonstrations") as bar:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS)
        if new_file:
            writer.writeheader()

        failed = 0

        def on_row(row: dict) -> None:
            nonlocal failed
            writer.writerow(row)
            fh.flush()  # a row on disk is a row a rerun skips
            failed += row["status"] == "failed"
            bar.update(1)
            bar.set_postfix(failed=failed)

        mine(todo, library, args.engine, args.workers, on_row, args.address)
    wall = time.perf_counter() - t0
    rows = read_rows(table)
    payload = {
        "n": len(rows),
        "n_ok": sum(r["status"] == "ok" for r in rows),
        "n_failed": sum(r["status"] == "failed" for r in rows),
        "n_this_run": len(todo),
        "n_skipped_finished": len(tasks) - len(todo),
        "wall_s": wall,
        "demos_per_s": len(todo) / wall if todo else None,
        "engine": args.engine,
        "workers": args.workers,
        "library": str(args.library),
        "input": str(args.data if args.dataset else args.input),
        **summary_numbers(rows),
    }
    write_json(args.out / "summary.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    plot_population(rows, args.out / "population.png", f"{payload['n_ok']} mined styles")
    print(
        f"wrote {table}: {payload['n']} rows ({payload['n_ok']} ok, {payload['n_failed']} "
        f"failed; {payload['n_skipped_finished']} already there), {len(todo)} in {wall:.1f} s "
        f"on {args.engine} x{args.workers}"
    )
    return payload


if __name__ == "__main__":
    run_cli(main)
