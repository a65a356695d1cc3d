"""The prediction study's simulated held-out vehicles (known risk).

Half in scenarios of the random family in which SMPC(0.5) interacts
(:func:`~drivestyle.agents.demo_generation.draw_interactive_scenarios`), half in random
traffic scenes (:func:`~drivestyle.agents.demo_generation.generate_traffic_demonstration` with
``randomize=True``); each drives SMPC(p) with p drawn from U(:data:`RISK_RANGE`) by the seed
(:func:`draw_simulated`). Their oracle is the SMPC as a style
(:func:`~drivestyle.prediction.style.oracle_style`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drivestyle.agents.demo_generation import (
    draw_interactive_scenarios,
    generate_demonstration,
    generate_traffic_demonstration,
)
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.planning.description import SMPCConfig

__all__ = [
    "RISK_RANGE",
    "SimulatedVehicle",
    "draw_simulated",
]

RISK_RANGE = (0.5, 0.95)
"""Simulated vehicles' risks are drawn from U[0.5, 0.95] (the library grid's span)."""


@dataclass(frozen=True)
class SimulatedVehicle:
    """One simulated held-out vehicle (:func:`draw_simulated`)."""

    vehicle_id: str
    """``random-<i>`` or ``traffic-<i>``."""
    risk: float
    """Its true risk p."""
    scenario: ScenarioConfig | None = None
    """The random family's scenario (None: a traffic scene)."""
    traffic_seed: int | None = None
    """The traffic scene's seed (``randomize=True``)."""

    def demonstration(self) -> Demonstration:
        """SMPC(p)'s demonstration (``meta["risk"]`` and ``meta["smpc"]`` set)."""
        if self.scenario is not None:
            return generate_demonstration(self.risk, self.scenario, SMPCConfig(risk=self.risk))[0]
        return generate_traffic_demonstration(self.risk, seed=self.traffic_seed, randomize=True)[0]


def draw_simulated(n: int, seed: int) -> list[SimulatedVehicle]:
    """``n`` held-out vehicles: ⌈n/2⌉ of the random family, the rest in traffic.

    The risks come from their own stream (``[seed, 1]``), the traffic seeds from another
    (``[seed, 2]``); the random family's scenarios are the interactive draws of ``seed``.

    Raises:
        ValueError: n < 1.
    """
    if n < 1:
        raise ValueError(f"the number of simulated vehicles must be >= 1, got {n}")
    n_random = (n + 1) // 2
    lo, hi = RISK_RANGE
    risks = np.round(np.random.default_rng([seed, 1]).uniform(lo, hi, n), 4)
    traffic_seeds = np.random.default_rng([seed, 2]).integers(0, 2**31 - 1, n - n_random)
    scenarios = draw_interactive_scenarios(n_random, seed)
    out = [
        SimulatedVehicle(f"random-{i}", float(risks[i]), scenario=sc)
        for i, sc in enumerate(scenarios)
    ]
    out += [
        SimulatedVehicle(f"traffic-{j}", float(risks[n_random + j]), traffic_seed=int(s))
        for j, s in enumerate(traffic_seeds)
    ]
    return out
