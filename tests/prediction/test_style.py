"""The style predictors' styles (prediction/style.py): the oracle's."""

from drivestyle.irl.driver.driver_style import expert_style
from drivestyle.planning.description import SMPCConfig
from drivestyle.prediction.style import oracle_style


def test_oracle_style_is_the_experts(paper_demo):
    assert oracle_style(paper_demo.meta) == expert_style(SMPCConfig(risk=0.7))
    assert oracle_style({"episode_id": "x"}) is None
