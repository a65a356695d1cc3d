"""A developer's measurement of the posterior-predictive check: its false-outside rate and power.

N episodes are drawn from the stochastic driver's prior (seed ``--seed``, episode i
simulated with seed ``--seed + i``, noise included). Each is checked with its driver's
TRUE θ repeated K times as the draws (the check's calibration: the share called outside
should stay at or under α), and so are three counterfeits of it with the same draws
(:mod:`drivestyle.irl.amortized.counterfeits`: played backwards, driven through the TV,
the next episode's path pasted in; the share called outside is the power). The p-values
do not depend on α, so one run gives the rates at every α whose Bonferroni threshold K
resolves (K ≥ 2·5/α − 1). Writes a JSON summary (rates with Wilson 95 % intervals, per
statistic failure rates, time per check; and every check's verdict, p-values, observed
values and predictive intervals) to ``--out`` and prints the summary.

    python tools/predictive_check_power.py --episodes 100 --k 199 --workers 2 --out /tmp/ppc.json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from drivestyle.irl.amortized.behaviour import STATISTICS
from drivestyle.irl.amortized.counterfeits import driven_through, pasted, played_backwards
from drivestyle.irl.amortized.predictive_check import min_draws, predictive_checks
from drivestyle.irl.amortized.simulations import parameters_of
from drivestyle.irl.driver.stochastic_prior import StochasticPrior, simulate_params

KINDS = ("original", "played_backwards", "driven_through", "pasted")
ALPHAS = (0.05, 0.1, 0.2)


def wilson(hits: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion."""
    if n == 0:
        return (math.nan, math.nan)
    p = hits / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(centre - half, 0.0), min(centre + half, 1.0))


def main(argv: list[str] | None = None) -> int:
    """Run the measurement (module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=40)
    ap.add_argument("--k", type=int, default=min_draws(0.05))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    resolved = [a for a in ALPHAS if args.k >= min_draws(a)]
    if not resolved:
        ap.error(f"--k {args.k} resolves none of the levels {ALPHAS} (at least {min_draws(0.2)})")
    prior = StochasticPrior()
    params = prior.draw(args.episodes, args.seed)
    demos = [simulate_params(p, args.seed + i) for i, p in enumerate(params)]
    theta = [np.tile(parameters_of(p), (args.k, 1)) for p in params]
    make = {
        "original": lambda i: demos[i],
        "played_backwards": lambda i: played_backwards(demos[i]),
        "driven_through": lambda i: driven_through(demos[i]),
        "pasted": lambda i: pasted(demos[i], demos[(i + 1) % len(demos)]),
    }
    cases = [(kind, i) for kind in args.kinds for i in range(len(demos))]
    done = [0]
    t0 = time.perf_counter()

    def progress(_: int, check) -> None:
        done[0] += 1
        print(f"\r{done[0]}/{len(cases)} checks, {time.perf_counter() - t0:.0f} s", end="",
              file=sys.stderr, flush=True)  # fmt: skip

    checks = predictive_checks([make[k](i) for k, i in cases], [theta[i] for _, i in cases],
                               seed=args.seed, alpha=resolved[0], workers=args.workers,
                               on_result=progress)  # fmt: skip
    print(file=sys.stderr)
    summary: dict = {
        "episodes": args.episodes, "k": args.k, "seed": args.seed, "workers": args.workers,
        "wall_s": time.perf_counter() - t0, "kinds": {},
    }  # fmt: skip
    for kind in args.kinds:
        mine = [c for (k, _), c in zip(cases, checks, strict=True) if k == kind]
        p = np.array([[s.p_value for s in c.statistics] for c in mine])  # (N, S)
        row: dict = {"n": len(mine)}
        for alpha in ALPHAS:
            if args.k < min_draws(alpha):
                continue
            fails = p <= alpha / len(STATISTICS)
            hits = int(fails.any(axis=1).sum())
            row[f"outside@{alpha:g}"] = {
                "count": hits, "rate": hits / len(mine), "wilson95": wilson(hits, len(mine)),
                "per_statistic": {s: float(fails[:, j].mean()) for j, s in enumerate(STATISTICS)},
            }  # fmt: skip
        seconds = np.array([c.seconds for c in mine])
        row["seconds_per_check_median"] = float(np.median(seconds))
        row["seconds_per_replicate_median"] = float(np.median(seconds) / args.k)
        row["failed_solves"] = int(sum(c.failed_solves for c in mine))
        summary["kinds"][kind] = row
    summary["checks"] = [
        {"kind": k, "episode": i, "noise": params[i].noise,
         "theta": parameters_of(params[i]).tolist(), **c.to_json()}
        for (k, i), c in zip(cases, checks, strict=True)
    ]  # fmt: skip
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(summary, indent=1))
    print(json.dumps({k: v for k, v in summary.items() if k != "checks"}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
