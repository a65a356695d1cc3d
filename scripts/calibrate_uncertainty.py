"""Scan the TV-uncertainty scale and the risk p on the paper scenario (DESIGN §3).

For each scale s (multiplying :data:`agents.prediction.PAPER_TV_UNCERTAINTY`) and each
risk p, runs the SMPC closed loop and records t_trg, min s_e (and where), when the EV
enters the centre lane and where it ends. Writes ``OUT/calibration.json`` and, with
``--plot``, ``OUT/risk_sweep.png``: the EV paths and s_e for each p at scale 1.

Example:
    python scripts/calibrate_uncertainty.py --scales 1.0,0.8,1.2 --out runs/calibration --plot
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import asdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from tqdm import tqdm

from agents import PAPER_TV_UNCERTAINTY, SMPCConfig, generate_demonstration
from envs import PAPER
from envs.io import write_json
from envs.plotting import draw_lanes, save_figure
from envs.safety import elliptical_index


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--scales", type=_floats, default=[0.8, 0.9, 1.0, 1.1, 1.2])
    p.add_argument("--risks", type=_floats, default=[0.5, 0.6, 0.7, 0.8, 0.9, 0.95])
    p.add_argument("--out", type=Path, default=Path("runs/calibration"))
    p.add_argument("--plot", action="store_true", help="write risk_sweep.png (scale 1)")
    p.add_argument("--seed", type=int, default=0)
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Run the scan; returns the JSON payload."""
    args = parse_args(argv)
    rows, demos = [], {}
    jobs = [(s, p) for s in args.scales for p in args.risks]
    for s, p in tqdm(jobs, desc="scale x risk"):
        cfg = SMPCConfig(risk=p, uncertainty=PAPER_TV_UNCERTAINTY.scaled(s))
        demo, summ = generate_demonstration(p, PAPER, cfg, seed=args.seed)
        rows.append(
            {
                "scale": s,
                "risk": p,
                **{
                    k: summ[k]
                    for k in (
                        "t_trg_s",
                        "min_s_e",
                        "x_at_min_s_e",
                        "min_d_k",
                        "t_enter_target_lane_s",
                        "final_lane",
                        "collision",
                        "n_solver_failures",
                    )
                },
                "final_y": float(demo.ev[-1, 1]),
            }
        )
        if s == 1.0:
            demos[p] = demo
    payload = {
        "base_uncertainty": asdict(PAPER_TV_UNCERTAINTY),
        "rows": rows,
        "paper": {"risk": 0.7, "t_trg_s": 3.0, "x_at_min_s_e_approx": 170.0},
    }
    write_json(args.out / "calibration.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"{'scale':>5s} {'p':>5s} {'t_trg':>6s} {'min s_e':>8s} {'at x':>6s} "
        f"{'enter':>6s} {'final y':>8s}"
    )
    for r in rows:
        trg = "never" if r["t_trg_s"] is None else f"{r['t_trg_s']:.1f}"
        ent = "never" if r["t_enter_target_lane_s"] is None else f"{r['t_enter_target_lane_s']:.1f}"
        print(
            f"{r['scale']:5.2f} {r['risk']:5.2f} {trg:>6s} {r['min_s_e']:8.2f} "
            f"{r['x_at_min_s_e']:6.0f} {ent:>6s} {r['final_y']:8.2f}"
        )
    if args.plot and demos:
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        cmap = plt.get_cmap("viridis")
        for i, (p, demo) in enumerate(sorted(demos.items())):
            c = cmap(i / max(len(demos) - 1, 1))
            s_e = elliptical_index(
                demo.ev[:, 0] - demo.tv[:, 0], demo.ev[:, 1] - demo.tv[:, 1], PAPER.l_a, PAPER.l_b
            )
            ax1.plot(demo.ev[:, 0], s_e, color=c, label=f"p = {p:g}")
            ax2.plot(demo.ev[:, 0], demo.ev[:, 1], color=c)
        ax1.axhline(PAPER.trigger_lambda, color="k", ls="--", lw=0.8, label="$\\lambda$")
        ax1.set_ylabel("$s_e$")
        ax1.set_ylim(0, 6)
        ax1.legend(fontsize=8, ncol=4)
        draw_lanes(ax2, PAPER)
        ax2.set_xlabel("EV x [m]")
        ax2.set_ylabel("EV y [m]")
        save_figure(
            fig,
            args.out / "risk_sweep.png",
            "SMPC demonstrations on the paper scenario by risk p",
            dpi=120,
        )
    return payload


if __name__ == "__main__":
    main()
