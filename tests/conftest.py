import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # headless pygame for every test
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def paper_demo():
    """The paper scenario's p = 0.7 SMPC demonstration (generated once per session)."""
    from drivestyle.agents import generate_demonstration

    return generate_demonstration(0.7, "paper")[0]


@pytest.fixture(scope="session")
def style_library():
    """A small style library: p = 0.5 and 0.95 learned in 5 interactive scenarios (seed 0),
    the fewest training scenarios identification answers from (built once per session)."""
    from drivestyle.agents.demo_generation import (
        draw_interactive_scenarios,
        generate_demonstrations,
    )
    from drivestyle.irl.identification import MIN_MEMBERS
    from drivestyle.irl.library import learn_library

    scenarios = draw_interactive_scenarios(MIN_MEMBERS, seed=0)
    demos = generate_demonstrations([0.5, 0.95], scenarios, workers=2)
    meta = {"seed": 0, "training_scenarios": [sc.to_dict() for sc in scenarios]}
    return learn_library(demos, "reactive", workers=2, meta=meta)
