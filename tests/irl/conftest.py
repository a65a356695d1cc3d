import pytest

from agents import generate_demonstration


@pytest.fixture(scope="session")
def paper_demo():
    return generate_demonstration(0.7, "paper")[0]
