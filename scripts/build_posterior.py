r"""Build the amortized posterior over a stochastic driver's parameters and calibrate it.

Draws ``--simulations`` + ``--held-out`` episodes from the prior over stochastic drivers
and scenes (:class:`~drivestyle.irl.driver.stochastic_prior.StochasticPrior`, DESIGN §21)
with ``--seed`` (episode i simulated with seed ``--seed`` + i) on ``--workers`` worker
processes, with a progress bar. The first ``--simulations`` train the neural posterior
(DESIGN §22) over the nine parameters the prior varies
(:data:`~drivestyle.irl.amortized.simulations.PARAMETERS`): each episode whole and
``--prefixes`` random prefixes of it (at least ``--min-samples`` samples), so it reads an
episode observed for any time; a progress bar per epoch. The last ``--held-out``, never
trained on, are the calibration: per parameter the posterior mean's MAE (absolute and
relative to the prior's width) beside the prior mean's, the 90 % intervals' coverage and
the SBC χ² p-value, from ``--samples`` posterior draws each; and the time to identify
one episode (``--samples`` draws on one core).

Writes OUT/posterior.npz (the verified estimator file), OUT/build.json (command, counts,
seeds, simulations/s/core, training time and validation loss, versions),
OUT/calibration.json and OUT/simulations.npz (the simulated set, so that another network
is trained on it without simulating again: ``--reuse-simulations OUT/simulations.npz``,
read only if made with the same prior, seed and features). An existing OUT written by
drivestyle is replaced as a whole.

Example:
    python scripts/build_posterior.py --simulations 3000 --held-out 200 --workers 2 \
        --out runs/posterior
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from drivestyle import __version__
from drivestyle.common.cli import HelpFormatter, count, positive_int, run_cli, seed, workers
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.irl.amortized.encoder import EncoderConfig
from drivestyle.irl.amortized.estimator import EstimatorConfig
from drivestyle.irl.amortized.evaluation import evaluate_posterior
from drivestyle.irl.amortized.simulations import (
    EPISODE_FEATURES,
    PARAMETERS,
    SimulationsFileError,
    load_simulated,
    parameter_box,
    save_simulated,
    series_width,
    simulate_set,
    with_prefixes,
)
from drivestyle.irl.amortized.training import TrainingConfig, train
from drivestyle.irl.driver.stochastic_prior import StochasticPrior


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("--out", type=Path, default=Path("runs/posterior"), help="output folder")
    p.add_argument("--simulations", type=count(1_000_000, 0.1, "simulations", least=8),
                   default=3000, help="training simulations N (10 %% validate)")  # fmt: skip
    p.add_argument("--held-out", type=count(100_000, 0.1, "held-out simulations", least=2),
                   default=200, help="held-out simulations M (calibration)")  # fmt: skip
    p.add_argument("--prefixes", type=count(100, 0.0, "prefixes", least=0), default=1,
                   help="random prefixes per training episode, beside the whole")  # fmt: skip
    p.add_argument("--min-samples", type=positive_int, default=6,
                   help="shortest prefix [samples]")  # fmt: skip
    p.add_argument("--workers", type=workers, default=1, help="worker processes (simulation)")
    p.add_argument("--seed", type=seed, default=0, help="seed of the prior's draws")
    p.add_argument("--training-seed", type=seed, default=0,
                   help="seed of the weights, the split, the batches and the prefixes")  # fmt: skip
    p.add_argument("--epochs", type=count(100_000, 1.0, "epochs"), default=200,
                   help="most training epochs")  # fmt: skip
    p.add_argument("--patience", type=positive_int, default=15,
                   help="epochs without a better validation loss before stopping")  # fmt: skip
    p.add_argument("--batch-size", type=positive_int, default=128, help="simulations per step")
    p.add_argument("--hidden", type=positive_int, default=64, help="GRU hidden units")
    p.add_argument("--embedding", type=positive_int, default=32, help="encoder summary width")
    p.add_argument("--transforms", type=positive_int, default=4, help="flow transforms")
    p.add_argument("--flow-hidden", type=positive_int, default=128,
                   help="width of the flow's two hidden layers")  # fmt: skip
    p.add_argument("--passes", type=int, choices=(2,), default=None,
                   help="2: coupling transforms (faster draws); else autoregressive")  # fmt: skip
    p.add_argument("--reuse-simulations", type=Path, default=None, metavar="FILE",
                   help="train on a kept OUT/simulations.npz of the same prior and seed "
                   "instead of simulating")  # fmt: skip
    p.add_argument("--samples", type=count(100_000, 0.001, "samples", least=2), default=200,
                   help="posterior draws per held-out episode (SBC, timing)")  # fmt: skip
    return p.parse_args(argv)


def _versions() -> dict[str, str]:
    import torch
    import zuko

    return {"drivestyle": __version__, "torch": torch.__version__, "zuko": zuko.__version__,
            "numpy": np.__version__, "python": platform.python_version()}  # fmt: skip


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Simulate, train, calibrate, write; returns the calibration's JSON payload."""
    args = parse_args(argv)
    out = check_output_dir(args.out)
    command = [sys.argv[0], *(argv if argv is not None else sys.argv[1:])]
    prior = StochasticPrior()
    low, high = parameter_box(prior)
    total = args.simulations + args.held_out
    load_before = [round(x, 2) for x in os.getloadavg()]
    if args.reuse_simulations is not None:
        try:
            kept = load_simulated(args.reuse_simulations, prior, args.seed)
        except SimulationsFileError as exc:
            raise SystemExit(f"--reuse-simulations: {exc}") from None
        if kept.n < total:
            raise SystemExit(
                f"--reuse-simulations {args.reuse_simulations}: holds {kept.n} episodes, "
                f"--simulations + --held-out need {total}"
            )
        sims = kept.subset(range(total))
    else:
        with tqdm(total=total, desc="simulating drivers", unit="ep") as bar:
            kept = sims = simulate_set(prior, total, args.seed, args.workers,
                                       lambda _i, _r: bar.update(1))  # fmt: skip
    fit = sims.subset(range(args.simulations))
    held = sims.subset(range(args.simulations, total))
    rows = with_prefixes(fit, args.prefixes, args.min_samples, args.training_seed, low, high)
    config = EstimatorConfig(
        names=PARAMETERS, low=tuple(low), high=tuple(high),
        encoder=EncoderConfig(series_width(), hidden=args.hidden, embedding=args.embedding),
        transforms=args.transforms, flow_hidden=(args.flow_hidden, args.flow_hidden),
        passes=args.passes, features=EPISODE_FEATURES,
    )  # fmt: skip
    training = TrainingConfig(epochs=args.epochs, batch_size=args.batch_size,
                              patience=args.patience, seed=args.training_seed)  # fmt: skip
    posterior, result = train(rows, config, training)
    held_theta = np.clip(held.theta, low, high)
    prior_mean = np.clip(fit.theta, low, high).mean(axis=0)
    calibration = evaluate_posterior(posterior, held_theta, held.series, prior_mean,
                                     samples=args.samples, seed=args.training_seed)  # fmt: skip
    build = {
        "simulations": args.simulations,
        "held_out": args.held_out,
        "training_rows": rows.n,
        "prefixes": args.prefixes,
        "min_samples": args.min_samples,
        "seed": args.seed,
        "training_seed": args.training_seed,
        "workers": args.workers,
        "simulations_from": None if args.reuse_simulations is None else str(args.reuse_simulations),
        "simulation_wall_s": sims.wall_s,
        # a reused set's wall time is another run's, on workers this one does not know
        "simulations_per_s_per_core": (
            total / sims.wall_s / args.workers if args.reuse_simulations is None else None
        ),
        "simulations_per_s_per_core_episodes_only": float(1.0 / sims.seconds.mean()),
        "failed_solves": int(sims.failures.sum()),
        "parameters": list(PARAMETERS),
        "box": {"low": low.tolist(), "high": high.tolist()},
        "estimator": config.to_dict(),
        "training": {
            "epochs": training.epochs,
            "batch_size": training.batch_size,
            "patience": training.patience,
            "learning_rate": training.learning_rate,
            "validation_fraction": training.validation_fraction,
            "seconds": result.seconds,
            "epochs_run": len(result.validation_loss),
            "best_epoch": result.best_epoch,
            "stopped_early": result.stopped_early,
            "validation_loss": result.validation_loss[result.best_epoch],
            "train_loss": result.train_loss[result.best_epoch],
            "validation_loss_per_epoch": list(result.validation_loss),
        },
        "versions": _versions(),
        "load_average_before": load_before,
        "load_average_after": [round(x, 2) for x in os.getloadavg()],
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
    }
    calibration["prior_mean"] = dict(zip(PARAMETERS, prior_mean.tolist(), strict=True))
    calibration["seed"] = args.seed
    with atomic_output_dir(out) as tmp:
        posterior.save(tmp / "posterior.npz")
        save_simulated(kept, prior, args.seed, tmp / "simulations.npz")
        write_json(tmp / "build.json", build, command)
        write_json(tmp / "calibration.json", calibration, command)
    risk = calibration["parameters"]["risk"]
    ident = calibration["identification_ms"]
    print(
        (
            f"{total} simulations on {args.workers} worker(s) in {sims.wall_s:.0f} s "
            if args.reuse_simulations is None
            else f"{total} simulations reused from {args.reuse_simulations} "
        )
        + f"({1.0 / sims.seconds.mean():.2f}/s/core, episodes only); trained on {rows.n} rows in "
        f"{result.seconds:.0f} s (validation loss {build['training']['validation_loss']:.3f}); "
        f"held out {args.held_out}: risk MAE {risk['mae']:.3f} (prior mean "
        f"{risk['prior_mean_mae']:.3f}), 90 % coverage "
        + ", ".join(f"{n} {v['coverage']:.2f}" for n, v in calibration["parameters"].items())
        + f"; one episode identified in {ident['median']:.1f} ms (median); wrote {out}"
    )
    return calibration


if __name__ == "__main__":
    run_cli(main)
