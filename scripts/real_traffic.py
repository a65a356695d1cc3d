"""Learn and compare driving styles on recorded lane changes (NGSIM or CATS).

For every used episode: a personal style (reactive and base features), a general style
learned from the other episodes (leave-one-out) and constant-velocity extrapolation are
compared with the recording (rmse_y, rmse_xy, final displacement error). Writes
``OUT/real_traffic.json``, ``OUT/real_traffic.md`` and one figure per episode under
``OUT/episodes/``. On CATS it also compares the computer-driven (AV) and human-driven (HV)
lane changes and runs a leave-one-out classifier on the learned styles.

The data are read from ``--data``; they are not part of this repository.

Example:
    python scripts/real_traffic.py --dataset ngsim --data ../shared/data/ngsim --out runs/ngsim
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from tqdm import tqdm

from envs.real_data import load_cats, load_ngsim
from envs.results import fmt, write_json
from irl.plotting import plot_episode
from irl.real_traffic import (
    METHODS,
    classify_loo,
    constant_velocity,
    learn_general,
    learn_personal,
    reproduce_with,
    trajectory_errors,
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--dataset", required=True, choices=("ngsim", "cats"))
    p.add_argument("--data", type=Path, required=True, help="the dataset's folder")
    p.add_argument("--out", type=Path, default=Path("runs/real_traffic"))
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--limit", type=int, help="only the first N used episodes (quick runs)")
    p.add_argument("--seed", type=int, default=0, help="unused: everything is deterministic")
    return p.parse_args(argv)


def _episode_task(i: int, demos: list, out: str) -> dict:
    """All four methods on episode i (the general style leaves episode i out)."""
    demo = demos[i]
    res = {}
    paths = {}
    for fs in ("reactive", "base"):
        r = learn_personal(demo, fs)
        res[f"personal_{fs}"] = {
            k: r[k] for k in ("rmse_y_m", "rmse_xy_m", "fde_m", "iterations", "converged")
        }
        res[f"personal_{fs}"]["theta_normalised"] = r["theta_normalised"]
        res[f"personal_{fs}"]["trigger_fired"] = r["trigger_fired"]
        paths[f"personal {fs}"] = r["control_points"][:, [0, 3]]
    others = [d for j, d in enumerate(demos) if j != i]
    if others:
        theta = learn_general(others)
        C = reproduce_with(theta, demo)
        res["general"] = trajectory_errors(C[:, [0, 3]], demo)
        paths["general (leave-one-out)"] = C[:, [0, 3]]
    cv = constant_velocity(demo)
    res["constant_velocity"] = trajectory_errors(cv, demo)
    paths["constant velocity"] = cv
    plot_episode(
        demo,
        paths,
        Path(out) / "episodes" / f"{demo.meta['episode_id']}.png",
        title=demo.meta["episode_id"],
    )
    return res


def _lane_change_stats(demo) -> dict:
    """Peak lateral acceleration and 10–90 % lane-change duration of a recording."""
    y = demo.ev[:, 1]
    vy = np.gradient(y, demo.t)
    ay = np.gradient(vy, demo.t)
    y0, y1 = y[:5].mean(), y[-5:].mean()
    frac = (y - y0) / (y1 - y0)
    t10 = demo.t[np.argmax(frac >= 0.1)]
    t90 = demo.t[np.argmax(frac >= 0.9)]
    return {
        "peak_lateral_accel_mps2": float(np.abs(ay).max()),
        "peak_lateral_speed_mps": float(np.abs(vy).max()),
        "duration_10_90_s": float(t90 - t10),
    }


def main(argv: list[str] | None = None) -> dict:
    """Run the study; returns real_traffic.json's payload."""
    args = parse_args(argv)
    loader = load_ngsim if args.dataset == "ngsim" else load_cats
    try:
        episodes = loader(args.data)
    except (FileNotFoundError, ValueError, KeyError) as exc:
        sys.exit(f"error: cannot read the {args.dataset} data in {args.data}: {exc}")
    used = [e for e in episodes if e.used]
    if args.limit:
        used = used[: args.limit]
    if len(used) < 2:
        sys.exit(f"error: {len(used)} usable episodes in {args.data}; need at least 2")
    demos = [e.demo for e in used]
    results: dict[int, dict] = {}
    bar = tqdm(total=len(demos), desc=f"{args.dataset} episodes")
    if args.workers > 1:
        with ProcessPoolExecutor(max_workers=args.workers) as pool:
            futs = {
                pool.submit(_episode_task, i, demos, str(args.out)): i for i in range(len(demos))
            }
            for fut, i in futs.items():
                results[i] = fut.result()
                bar.update(1)
    else:
        for i in range(len(demos)):
            results[i] = _episode_task(i, demos, str(args.out))
            bar.update(1)
    bar.close()
    records = []
    for e in episodes:
        rec = {
            "episode_id": e.episode_id,
            "used": e in used,
            "reasons": list(e.reasons),
            "flags": e.flags,
        }
        if e in used:
            i = used.index(e)
            rec["methods"] = results[i]
            rec["stats"] = _lane_change_stats(e.demo)
        records.append(rec)
    medians = {}
    for m in METHODS:
        vals = [r["methods"][m] for r in records if "methods" in r and m in r["methods"]]
        medians[m] = {
            k: float(np.median([v[k] for v in vals])) if vals else None
            for k in ("rmse_y_m", "rmse_xy_m", "fde_m")
        }
    payload = {
        "dataset": args.dataset,
        "n_episodes": len(episodes),
        "n_used": len(used),
        "median_rmse_y_m": {m: medians[m]["rmse_y_m"] for m in METHODS},
        "medians": medians,
        "episodes": records,
    }
    lines = [
        f"# Real traffic: {args.dataset}",
        "",
        f"{len(used)} of {len(episodes)} episodes used (selection in envs/real_data.py).",
        "",
        "| method | median rmse_y [m] | median rmse_xy [m] | median fde [m] |",
        "|---|---|---|---|",
    ]
    for m in METHODS:
        lines.append(
            f"| {m} | {fmt(medians[m]['rmse_y_m'])} | {fmt(medians[m]['rmse_xy_m'])} "
            f"| {fmt(medians[m]['fde_m'])} |"
        )
    if args.dataset == "cats":
        payload["av_vs_hv"] = av_vs_hv(records)
        lines += ["", "## AV vs human", "", _av_hv_markdown(payload["av_vs_hv"])]
    lines += [
        "",
        "| episode | " + " | ".join(f"{m} rmse_y" for m in METHODS) + " |",
        "|---|" + "---|" * len(METHODS),
    ]
    for r in records:
        if "methods" in r:
            lines.append(
                f"| {r['episode_id']} | "
                + " | ".join(fmt(r["methods"].get(m, {}).get("rmse_y_m")) for m in METHODS)
                + " |"
            )
    write_json(args.out / "real_traffic.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    (args.out / "real_traffic.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[: 4 + 2 + len(METHODS)]))
    return payload


def av_vs_hv(records: list[dict]) -> dict:
    """Compare the computer-driven and human-driven CATS lane changes."""
    rows = [r for r in records if "methods" in r]
    labels = [r["flags"]["set"] for r in rows]
    out: dict = {"n": {c: labels.count(c) for c in sorted(set(labels))}}
    for c in sorted(set(labels)):
        sel = [r for r in rows if r["flags"]["set"] == c]
        out[c] = {
            "rmse_y_personal_reactive_median_m": float(
                np.median([r["methods"]["personal_reactive"]["rmse_y_m"] for r in sel])
            ),
            **{k: float(np.median([r["stats"][k] for r in sel])) for k in sel[0]["stats"]},
            "theta_base_normalised_mean": np.mean(
                [r["methods"]["personal_base"]["theta_normalised"] for r in sel], axis=0
            ).tolist(),
        }
    names = ("ax", "ay", "v", "l", "il", "el")
    out["classifier_base_features"] = classify_loo(
        np.array([r["methods"]["personal_base"]["theta_normalised"] for r in rows]), labels, names
    )
    return out


def _av_hv_markdown(d: dict) -> str:
    c = d["classifier_base_features"]
    rows = [
        "| set | n | median rmse_y (personal reactive) | median peak lateral accel | "
        "median 10–90 % duration |",
        "|---|---|---|---|---|",
    ]
    for s in ("AV", "HV"):
        if s in d:
            rows.append(
                f"| {s} | {d['n'][s]} | {d[s]['rmse_y_personal_reactive_median_m']:.3f} m "
                f"| {d[s]['peak_lateral_accel_mps2']:.2f} m/s² | "
                f"{d[s]['duration_10_90_s']:.1f} s |"
            )
    rows += [
        "",
        f"Leave-one-out nearest-centroid classifier on the base-feature styles: "
        f"{c['accuracy']:.0%} of {c['n']} (majority rate {c['majority_rate']:.0%}, "
        f"one-sided binomial p = {c['p_value_vs_majority']:.2f}).",
    ]
    return "\n".join(rows)


if __name__ == "__main__":
    main()
