"""A simulated population returns a typed result that keeps population.json's keys."""

from drivestyle.studies.identification.population import Population, simulate_population


def test_population_is_typed_and_keeps_the_population_keys(tmp_path):
    pop = simulate_population(2, seed=1, out=tmp_path, workers=1)
    assert isinstance(pop, Population) and pop.n_ok == 2 and pop.n_failed == 0
    js = pop.to_json()
    assert list(js) == [
        "seed",
        "n",
        "risk_distribution",
        "traffic_share",
        "n_ok",
        "n_failed",
        "vehicles",
        "wall_s",
    ]
    assert js["wall_s"] > 0 and js["vehicles"][1]["id"] == "v000001"
