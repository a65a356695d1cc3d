r"""Mine the styles of many vehicles: per demonstration a personal style and its risk.

INPUT is a folder of demonstrations (``*.npz``, searched recursively, e.g. a
``simulate_population.py`` output) or, with ``--dataset ngsim|cats --data DIR``, a recorded
sample's every usable lane change, extracted as anyone's own data is (``extract-episodes
--format sample``). Writes ``OUT/styles.csv`` (one row per demonstration: id, source, status, error,
true risk where known, risk estimate, 90 % interval, posterior mean, θ normalised, fit
errors, timings), ``OUT/summary.json`` (n, n_ok, n_failed, wall_s, demos_per_s, engine,
workers, the input and library, the failed rows with their errors, …) and
``OUT/population.png`` (estimated vs true risk; the risk distribution). A demonstration that
cannot be mined (an unreadable file, any error) is a failed row, never a crashed job.

A demonstration's id is its path under INPUT without ``.npz`` (``sub/v1``), whatever the
other files are. Rows are appended to ``styles.csv`` as they finish, so the job is
resumable: a rerun with the same INPUT, library and OUT skips the rows already there (a row
that failed for an infrastructure reason, a worker that died or was killed, is mined again;
rows of files no longer in INPUT are dropped), and an interruption loses at most the rows in
flight (a row torn by a kill is dropped and mined again; SIGTERM stops the workers as
Ctrl-C does). OUT remembers its
input and library (``OUT/fingerprint.json``): a run with another one is refused, ``--force``
starts over. A run locks OUT; a second run into the same OUT is refused while it lasts.
``--engine ray`` runs the same work on Ray actors (``--address`` of a cluster, reached
within ``--connect-timeout``, else Ray on this machine); install the extra with
``pip install -e '.[ray]'``.

``--posterior FILE`` (an estimator ``drivestyle build-posterior`` wrote, its
``posterior.npz``) also identifies every demonstration with the amortized posterior over the
stochastic driver's parameters (DESIGN §22), in this process after the mining: it writes
``OUT/amortized.csv`` (one row per demonstration: per parameter the posterior mean, median
and 90 % interval, the risk p first; a demonstration that cannot be read is a failed row),
whole on every such run, and ``summary.json``'s ``amortized`` (counts, the estimator's
checksum, each parameter's median posterior mean and, where the true risk is known, the
posterior mean's MAE and the intervals' coverage). ``--check`` adds the verdict on fit:
each demonstration's posterior-predictive check with its posterior draws (one replicate
of the episode per draw, on ``--workers`` processes; ≈ 10–40 s per episode per core),
its verdict, failing statistics and p-values in ``amortized.csv`` and the share inside the
class in the summary.

Examples:
    python scripts/mine_styles.py runs/population --library runs/library_reactive --out runs/mined
    python scripts/mine_styles.py runs/population --library runs/library_reactive \\
        --engine ray --workers 2 --out runs/mined_ray
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from drivestyle.common.cli import HelpFormatter, Interrupted, positive_float, run_cli, workers
from drivestyle.common.inputs import distinct_files
from drivestyle.common.io import check_output_dir, write_json, write_text
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.irl.amortized.mining import (
    amortized_rows,
    amortized_summary,
    amortized_table,
    checked_rows,
)
from drivestyle.irl.identification.library import load_any_library
from drivestyle.irl.identification.mined_row import MinedRow
from drivestyle.irl.identification.mining import (
    CONNECT_TIMEOUT_S,
    ENGINES,
    MiningTask,
    mine,
    summary_numbers,
)
from drivestyle.irl.identification.mining_output import (
    AMORTIZED_TABLE,
    MiningOutput,
    RunFingerprint,
)
from drivestyle.recorded.episodes import ExtractionConfig, extract_episodes
from drivestyle.recorded.readers import read_sample
from drivestyle.studies.plotting import plot_population


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("input", nargs="?", type=Path, help="folder of demonstrations (*.npz)")
    p.add_argument("--dataset", choices=("ngsim", "cats"), help="mine a recorded dataset instead")
    p.add_argument("--data", type=Path, help="the recorded dataset's folder (with --dataset)")
    p.add_argument("--library", type=Path, required=True, help="style library folder or json")
    p.add_argument(
        "--out", type=Path, default=Path("runs/mined"), help="output folder (resumed if present)"
    )
    p.add_argument("--engine", default="local", choices=ENGINES, help="where the work runs")
    p.add_argument("--address", help="Ray cluster address (--engine ray; default: start locally)")
    p.add_argument("--workers", type=workers, default=2, help="processes or Ray actors")
    p.add_argument(
        "--connect-timeout",
        type=positive_float,
        default=CONNECT_TIMEOUT_S,
        help="seconds to reach the Ray head at --address before giving up",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="start over: delete the rows and results of an earlier run in OUT (needed when "
        "OUT was mined from another input or library)",
    )
    p.add_argument(
        "--posterior",
        type=Path,
        default=None,
        help="an amortized posterior (build-posterior's posterior.npz): also write "
        "amortized.csv, every demonstration's posterior over the driver's parameters",
    )
    p.add_argument(
        "--check",
        action="store_true",
        help="with --posterior: also check each demonstration's fit by the posterior-"
        "predictive check (one replicate per posterior draw, on --workers processes)",
    )
    return p.parse_args(argv)


def _tasks(args: argparse.Namespace) -> tuple[list[MiningTask], str]:
    """The tasks and the input's identity (for the output folder's fingerprint)."""
    if args.dataset:
        if args.data is None or args.input is not None:
            raise ValueError("--dataset needs --data DIR and no INPUT folder")
        # the same extraction as anyone's own data (recorded.episodes): every usable lane change
        recording = read_sample(args.data)
        if recording.meta.get("dataset") != args.dataset:
            raise ValueError(
                f"--data {args.data} holds the {recording.meta.get('dataset')} sample, not "
                f"--dataset {args.dataset}"
            )
        tasks: list[MiningTask] = [
            (e.episode_id, args.dataset, e.demo)
            for e in extract_episodes(recording, ExtractionConfig())
            if e.usable and e.demo is not None
        ]
        return tasks, f"{args.dataset}:{args.data.resolve()}"
    if args.input is None:
        raise ValueError("give an INPUT folder of demonstrations or --dataset with --data")
    if not args.input.is_dir():
        raise FileNotFoundError(f"INPUT {args.input} is not a folder")
    found = distinct_files(sorted(args.input.rglob("*.npz")))
    if found.note:  # a copy mined twice would count twice in the population's summary
        print(found.note, file=sys.stderr)
    files = list(found.kept)
    if not files:
        raise ValueError(f"no demonstrations (*.npz) under {args.input}")
    root = str(args.input)
    # the path, always: an id must not change when a file of the same name is added
    ids = [f.relative_to(args.input).with_suffix("").as_posix() for f in files]
    tasks = [(i, root, str(f)) for i, f in zip(ids, files, strict=True)]
    return tasks, str(args.input.resolve())


def _first(ids: list[str], n: int = 5) -> str:
    return ", ".join(ids[:n]) + (" …" if len(ids) > n else "")


def main(argv: list[str] | None = None) -> dict:
    """Mine; returns summary.json's payload."""
    args = parse_args(argv)
    if args.address and args.engine != "ray":
        raise ValueError("--address needs --engine ray")
    # rows are appended: the folder is resumed
    inputs = [args.input, args.data, args.library, args.posterior]
    check_output_dir(args.out, replace=False, inputs=inputs)
    library = load_any_library(args.library)
    if args.check and args.posterior is None:
        raise ValueError("--check needs --posterior (the draws it checks)")
    posterior = open_posterior(args.posterior) if args.posterior is not None else None
    tasks, input_id = _tasks(args)
    fingerprint = RunFingerprint.of(input_id, args.library, library)
    with MiningOutput(args.out, fingerprint, force=args.force, ids=[t[0] for t in tasks]) as store:
        if store.repaired:
            print(
                f"repaired {store.table}: dropped {store.repaired} torn, malformed or repeated "
                "row(s); their demonstrations are mined again"
            )
        if store.renamed:
            print(
                f"{store.table}: {store.renamed} row(s) of an earlier version renamed from the "
                "file's name to its path under INPUT"
            )
        if store.unmappable:
            print(
                f"{store.table}: dropped {len(store.unmappable)} row(s) of an earlier version "
                f"whose id names several demonstrations now ({_first(store.unmappable)}); "
                "they are mined again"
            )
        if store.removed:
            print(
                f"{store.table}: dropped {len(store.removed)} row(s) of demonstrations no longer "
                f"in the input ({_first(store.removed)})"
            )
        if store.retrying:
            print(
                f"retrying {len(store.retrying)} row(s) that failed for an infrastructure reason "
                f"(a worker died or was killed): {_first(store.retrying)}"
            )
        done = store.finished_ids()
        todo = [t for t in tasks if t[0] not in done]
        t0 = time.perf_counter()
        with tqdm(total=len(todo), desc="demonstrations") as bar:
            failed = 0

            def on_row(row: MinedRow) -> None:
                nonlocal failed
                store.append(row)
                failed += row.status == "failed"
                bar.update(1)
                bar.set_postfix(failed=failed)

            try:
                mine(todo, library, args.engine, args.workers, on_row, args.address,
                     args.connect_timeout)  # fmt: skip
            except KeyboardInterrupt:
                # the rows on disk are kept (the resume skips them): say so, not "discarded"
                kept = len(store.rows)
                raise Interrupted(
                    f"{kept} finished row(s) kept in {store.table} ({kept - len(done)} of this "
                    f"run); rerun the same command to resume: it mines the other "
                    f"{len(tasks) - kept} demonstration(s) (summary.json and population.png are "
                    "written when a run completes)"
                ) from None
        wall = time.perf_counter() - t0
        rows = store.rows
        payload = {
            "n": len(rows),
            "n_ok": sum(r.status == "ok" for r in rows),
            "n_failed": sum(r.status == "failed" for r in rows),
            "n_this_run": len(todo),
            "n_skipped_finished": len(tasks) - len(todo),
            "wall_s": wall,
            "demos_per_s": len(todo) / wall if todo else None,
            "engine": args.engine,
            "workers": args.workers,
            **fingerprint.to_json(),
            **summary_numbers(rows),
            "n_failed_infrastructure": sum(r.failure_kind == "infrastructure" for r in rows),
            "failed": [
                {"id": r.id, "error": r.error, "failure_kind": r.failure_kind}
                for r in rows
                if r.status == "failed"
            ],
        }
        amortized = None
        if posterior is not None:
            t0 = time.perf_counter()
            found = amortized_rows(tasks, posterior)
            if args.check:
                with tqdm(total=len(found), desc="predictive checks", unit="ep") as bar:
                    found = checked_rows(found, tasks, workers=args.workers,
                                         on_result=lambda _i, _r: bar.update(1))  # fmt: skip
            names = posterior.config.names
            write_text(args.out / AMORTIZED_TABLE, amortized_table(found, names))
            amortized = amortized_summary(found, names) | {
                "estimator": str(args.posterior),
                "seconds": time.perf_counter() - t0,
            }
            payload["amortized"] = amortized
        write_json(args.out / "summary.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        plot_population(
            [r.to_json() for r in rows],
            args.out / "population.png",
            f"{payload['n_ok']} mined styles",
        )
    print(
        f"wrote {store.table}: {payload['n']} rows ({payload['n_ok']} ok, {payload['n_failed']} "
        f"failed; {payload['n_skipped_finished']} already there), {len(todo)} in {wall:.1f} s "
        f"on {args.engine} x{args.workers}"
    )
    if payload["n_ok"]:
        counts = ", ".join(f"{label} {n}" for label, n in payload["verdicts"].items())
        print(f"verdicts of the {payload['n_ok']} ok rows: {counts} (summary.json: the ranges)")
    if amortized is not None:
        print(amortized_line(amortized))
    return payload


def amortized_line(summary: dict) -> str:
    """The printed line of the amortized identification (``summary.json``'s ``amortized``)."""
    medians = ", ".join(f"{n} {v:.3g}" for n, v in summary["median_posterior_mean"].items()
                        if v is not None)  # fmt: skip
    line = (
        f"amortized posterior: wrote {AMORTIZED_TABLE}: {summary['n_ok']} of {summary['n']} "
        f"demonstrations ({summary['n_failed']} failed) in {summary['seconds']:.1f} s"
        + (f"; median posterior mean {medians}" if medians else "")
    )
    if "risk_mae_posterior_mean" in summary:
        line += (
            f"; against the true risk of {summary['n_with_truth']}: MAE "
            f"{summary['risk_mae_posterior_mean']:.3f}, 90 % intervals cover "
            f"{summary['risk_interval_coverage']:.2f}"
        )
    if "check" in summary:
        c = summary["check"]
        failing = ", ".join(f"{n} {k}" for n, k in c["failing"].items() if k)
        line += (
            f"; predictive check ({c['draws']} replicates, α {c['alpha']:g}): {c['n_inside']} of "
            f"{c['n_checked']} inside the class" + (f" (failing: {failing})" if failing else "")
        )
    return line


if __name__ == "__main__":
    run_cli(main)
