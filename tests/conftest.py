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
