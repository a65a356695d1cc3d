"""The identification references and the SMPC robustness count."""

import pytest

from drivestyle.agents import generate_demonstration
from drivestyle.agents.demo_generation import (
    draw_interactive_scenarios,
    generate_demonstrations,
    smpc_robustness,
)
from drivestyle.studies.identification.references import ceiling_identify, knn_baseline


def test_the_ceiling_recovers_the_expert_risk():
    scenario = draw_interactive_scenarios(1, seed=11)[0]
    demo, _ = generate_demonstration(0.8, scenario)
    res = ceiling_identify(demo, [0.5, 0.8, 0.95])
    assert res.risk_estimate == 0.8 and 0.8 in res.tied
    assert res.distances[0.8] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_knn_with_one_neighbour_returns_a_training_demo_label():
    scenarios = draw_interactive_scenarios(2, seed=12)
    demos = generate_demonstrations([0.5, 0.95], scenarios, workers=1)
    train = [d for p in (0.5, 0.95) for d in demos[p]]
    assert knn_baseline(train, train, k=1) == [float(d.meta["risk"]) for d in train]


def test_robustness_counts_every_demonstration():
    res = smpc_robustness(2, seed=3, risks=(0.6, 0.9), workers=1)
    assert res["n_demos"] == 4 and res["n_steps"] == 4 * 30
    assert res["n_solver_failures"] == 0 and res["n_fallbacks"] == 0
    assert set(res["by_risk"]) == {"0.6", "0.9"}
    with pytest.raises(ValueError, match="n_scenarios"):
        smpc_robustness(0, seed=3)
