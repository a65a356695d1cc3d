r"""The automated car against human drivers in the CATS field test.

Every lane change the extraction finds in ``--data-dir``'s CATS sample is described by the
risk the style model identifies for it (read from a ``drivestyle mine-styles --dataset
cats`` output folder, ``--mined``; omitted: observed quantities only) and by what caution
shows on the trajectory itself (least time gap to the vehicle ahead, closest approach,
speed, peak lateral speed, lane-change duration). The computer-driven car
(``cats:AV:3``) is compared with the same car driven by a human (``cats:HV:3``) and with
the other, human-driven vehicles: medians with bootstrap 95 % intervals over lane changes
and the differences of medians (studies/av_vs_human/study.py). Writes
``OUT/av_vs_human.json`` (with the command), ``OUT/av_vs_human.md`` and
``OUT/av_vs_human.png``.

``--posterior FILE`` (an estimator ``drivestyle build-posterior`` wrote, its
``posterior.npz``) also identifies every lane change with the amortized posterior over the
stochastic driver's parameters (studies/av_vs_human/amortized.py): per lane change every
parameter's posterior mean and 90 % interval, the AUROC of the AV against the humans on each
parameter's posterior mean beside the descriptors' AUROCs (bootstrap 95 % intervals), and the
intra-class correlation of each parameter across the AV's runs (F interval), in
``av_vs_human.json``'s ``amortized`` and a section of ``av_vs_human.md``.

Example:
    drivestyle mine-styles --dataset cats --data ../shared/data/cats-av-lanechange \
        --library runs/library --out runs/mined_cats
    drivestyle compare-av-human --mined runs/mined_cats --out runs/av_vs_human
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drivestyle.common.cli import HelpFormatter, count, run_cli
from drivestyle.common.io import (
    atomic_output_dir,
    check_output_dir,
    command_line,
    write_json,
    write_text,
)
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.recorded.benchmark import DEFAULT_DATA_DIR, recorded_episodes
from drivestyle.recorded.real_data import check_data_dir
from drivestyle.studies.av_vs_human import (
    amortized_markdown,
    av_human_markdown,
    compare_av_human,
    read_mined,
    unmined,
)
from drivestyle.studies.av_vs_human.amortized import amortized_comparison
from drivestyle.studies.av_vs_human.figures import plot_av_human

SAMPLES = count(100_000, 2e-5, "bootstrap replicates", bytes_each=1.5e3)
"""``--samples``: a replicate holds the resampled indices of a group's lane changes for every
quantity and group at once (≈ 1.5 kB, ≈ 20 µs on the CATS sample: 10⁵ took 1.4 s and
125 MB); 10⁵ already pin the 95 % intervals' ends far below their width (default 2000)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--data-dir", type=Path, default=DEFAULT_DATA_DIR,
                   help="folder holding cats-av-lanechange/")  # fmt: skip
    p.add_argument(
        "--mined", type=Path, default=None,
        help="a mine-styles --dataset cats output folder (the identified risks)",
    )  # fmt: skip
    p.add_argument("--samples", type=SAMPLES, default=2000, help="bootstrap replicates")
    p.add_argument("--out", type=Path, default=Path("runs/av_vs_human"), help="output folder")
    p.add_argument(
        "--posterior", type=Path, default=None,
        help="an amortized posterior (build-posterior's posterior.npz): also compare the "
        "lane changes' amortized driver parameters (AUROC, consistency across runs)",
    )  # fmt: skip
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Compare; returns av_vs_human.json's payload."""
    args = parse_args(argv)
    argv_used = [sys.argv[0], *(argv if argv is not None else sys.argv[1:])]
    given = [f for f in (args.mined, args.posterior) if f is not None]
    check_output_dir(args.out, inputs=[args.data_dir, *given])
    mined = read_mined(args.mined) if args.mined is not None else None
    posterior = open_posterior(args.posterior) if args.posterior is not None else None
    check_data_dir(args.data_dir, ("cats",), DEFAULT_DATA_DIR)
    episodes = recorded_episodes(str(args.data_dir), "cats")
    if mined is not None:
        try:
            missing = unmined(episodes, mined)
        except ValueError as exc:
            raise ValueError(f"--mined {args.mined}: {exc}") from None
        table = args.mined / "styles.csv"
        if missing:  # legal (a run still going, failed rows), but it shapes every number
            print(
                f"note: {len(missing)} of the {len(episodes)} CATS lane changes have no ok row "
                f"in {table} (failed, or not mined yet): they are reported as not mined",
                file=sys.stderr,
            )
        ids = {eid for eid, _, _ in episodes}
        foreign = [i for i in mined if i not in ids]
        if foreign:  # rows of another input (unmined refuses a table of nothing but these)
            print(
                f"note: {len(foreign)} of the {len(mined)} ok rows of {table} match no CATS "
                f"lane change (e.g. {', '.join(foreign[:3])}): they are ignored",
                file=sys.stderr,
            )
    comparison = compare_av_human(episodes, mined, samples=args.samples)
    payload = comparison.to_json()
    markdown = av_human_markdown(comparison, command_line(argv_used))
    if posterior is not None:
        amortized = amortized_comparison(episodes, comparison, posterior, str(args.posterior),
                                         samples=args.samples)  # fmt: skip
        payload["amortized"] = amortized.to_json()
        markdown += amortized_markdown(amortized)
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "av_vs_human.json", payload, argv_used)
        write_text(tmp / "av_vs_human.md", markdown)
        plot_av_human(comparison, tmp / "av_vs_human.png")
    print(markdown)
    print(f"wrote {args.out}")
    return payload


if __name__ == "__main__":
    run_cli(main)
