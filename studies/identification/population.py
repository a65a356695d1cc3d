"""A simulated population of vehicles with known risks: the ground truth for mining at scale.

Vehicle i drives one SMPC demonstration with risk p_i ~ U(:data:`RISK_RANGE`) in a scene
drawn from the random family (single TV, ``drivestyle.envs.scenario.ScenarioRanges``) or, with
probability ``traffic_share``, from the traffic family (``drivestyle.envs.traffic.TrafficRanges``).
Every draw comes from ``numpy.random.default_rng([seed, i])``, so a vehicle's
demonstration does not depend on how many vehicles are simulated or on the workers.
Each worker process builds one SMPC solver per family and reuses it for every vehicle
(the risk is a solver parameter, :meth:`drivestyle.agents.smpc.SMPCExpert.set_risk`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import TRAFFIC_VEHICLES, demo_summary, rollout_expert
from drivestyle.agents.smpc import SMPCConfig, SMPCExpert
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import save_demonstration
from drivestyle.envs.lane_change import LaneChangeEnv
from drivestyle.envs.scenario import ScenarioConfig, ScenarioRanges
from drivestyle.envs.traffic import TrafficEnv, TrafficRanges, TrafficScene

__all__ = ["RISK_RANGE", "Population", "draw_vehicle", "simulate_population"]

RISK_RANGE = (0.5, 0.95)
"""Risks are drawn uniformly from this interval."""


@dataclass(frozen=True)
class Population:
    """A simulated population (``population.json``).

    Attributes:
        seed: the population seed.
        n: vehicles simulated.
        traffic_share: probability of a traffic scene.
        vehicles: per vehicle, in id order: ``id``, ``risk`` (the true risk), ``traffic``,
            ``status`` ('ok' or 'failed') and either ``file``, ``t_trg_s``, ``collision``,
            ``final_lane``, ``n_solver_failures`` or ``error``.
        wall_s: wall time of the simulation [s].
    """

    seed: int
    n: int
    traffic_share: float
    vehicles: list[dict[str, Any]]
    wall_s: float

    @property
    def n_ok(self) -> int:
        """Vehicles whose demonstration was simulated and saved."""
        return sum(v["status"] == "ok" for v in self.vehicles)

    @property
    def n_failed(self) -> int:
        """Vehicles whose simulation failed (kept as rows with the error)."""
        return self.n - self.n_ok

    def to_json(self) -> dict[str, Any]:
        """``population.json``'s keys (without ``command``)."""
        return {
            "seed": self.seed,
            "n": self.n,
            "risk_distribution": f"uniform on [{RISK_RANGE[0]}, {RISK_RANGE[1]}]",
            "traffic_share": self.traffic_share,
            "n_ok": self.n_ok,
            "n_failed": self.n_failed,
            "vehicles": self.vehicles,
            "wall_s": self.wall_s,
        }


def draw_vehicle(seed: int, i: int, traffic_share: float = 0.0) -> dict[str, Any]:
    """Vehicle i's risk and scene (JSON-ready), from ``default_rng([seed, i])``."""
    rng = np.random.default_rng([seed, i])
    risk = float(rng.uniform(*RISK_RANGE))
    traffic = bool(rng.uniform() < traffic_share)
    scene = (TrafficRanges() if traffic else ScenarioRanges()).sample(rng).to_dict()
    return {"id": f"v{i:06d}", "risk": risk, "traffic": traffic, "scene": scene}


def _simulate_chunk(vehicles: list[dict[str, Any]], folder: str, jit: bool) -> list[dict]:
    """Worker: simulate and save a chunk of vehicles with one solver per family."""
    experts: dict[bool, SMPCExpert] = {}
    envs = {False: LaneChangeEnv(), True: TrafficEnv()}
    rows = []
    for v in vehicles:
        traffic = v["traffic"]
        if traffic not in experts:
            m = TRAFFIC_VEHICLES if traffic else 1
            experts[traffic] = SMPCExpert(SMPCConfig(risk=v["risk"], jit=jit, max_vehicles=m))
        expert = experts[traffic]
        expert.set_risk(v["risk"])
        options = (
            {"scene": TrafficScene.from_dict(v["scene"])}
            if traffic
            else {"scenario": ScenarioConfig(**v["scene"])}
        )
        row = {k: v[k] for k in ("id", "risk", "traffic")}
        try:
            demo, steps = rollout_expert(envs[traffic], expert, seed=0, options=options)
            summary = demo_summary(demo, steps)
            save_demonstration(demo, Path(folder) / f"{v['id']}.npz")
            row |= {
                "file": f"demos/{v['id']}.npz",
                "t_trg_s": summary["t_trg_s"],
                "collision": summary["collision"],
                "final_lane": summary["final_lane"],
                "n_solver_failures": summary["n_solver_failures"],
                "status": "ok",
            }
        except (ValueError, RuntimeError) as exc:
            row |= {"status": "failed", "error": str(exc)}
        rows.append(row)
    for env in envs.values():
        env.close()
    return rows


def simulate_population(
    n: int,
    seed: int,
    out: str | Path,
    workers: int = 2,
    traffic_share: float = 0.0,
    jit: bool = False,
    chunk: int = 25,
    progress: Callable[[int], None] | None = None,
) -> Population:
    """Simulate n vehicles into ``out/demos/``.

    Args:
        n: vehicles (≥ 1).
        seed: population seed.
        out: output folder (``demos/`` is created in it).
        workers: processes.
        traffic_share: probability of a traffic scene, in [0, 1].
        jit: compile the SMPC (faster per step, a few seconds per worker to compile).
        chunk: vehicles per task.
        progress: called with the number of vehicles finished by each chunk.

    Returns:
        The population (its ``to_json()`` is ``population.json``).

    Raises:
        ValueError: a bad n, traffic_share or chunk.
    """
    if not (isinstance(n, int) and n >= 1):
        raise ValueError(f"the population needs at least 1 vehicle, got {n!r}")
    if not 0.0 <= traffic_share <= 1.0:
        raise ValueError(f"traffic_share must lie in [0, 1], got {traffic_share}")
    if chunk < 1:
        raise ValueError(f"chunk must be >= 1, got {chunk}")
    t0 = time.perf_counter()
    folder = Path(out) / "demos"
    folder.mkdir(parents=True, exist_ok=True)
    drawn = [draw_vehicle(seed, i, traffic_share) for i in range(n)]
    chunks: Sequence[list[dict]] = [drawn[k : k + chunk] for k in range(0, n, chunk)]
    done = parallel_map(
        _simulate_chunk,
        [(c, str(folder), jit) for c in chunks],
        workers,
        None if progress is None else lambda _, rows: progress(len(rows)),
    )
    rows = [r for part in done for r in part]
    return Population(seed, n, traffic_share, rows, time.perf_counter() - t0)
