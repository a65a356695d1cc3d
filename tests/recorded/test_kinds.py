"""The episode kinds: one tuple of names, read from a demonstration's metadata."""

from types import SimpleNamespace

import pytest

from drivestyle.recorded.kinds import (
    DEFAULT_KIND,
    EPISODE_KINDS,
    episode_kind,
    is_stop_and_go,
)


def test_the_names_and_the_default():
    assert EPISODE_KINDS == ("lane_change", "lane_keeping", "car_following", "approaching")
    assert DEFAULT_KIND == "lane_change"


@pytest.mark.parametrize("kind", EPISODE_KINDS)
def test_a_kind_is_read_back(kind):
    demo = SimpleNamespace(meta={"kind": kind, "stop_and_go": True})
    assert episode_kind(demo) == kind
    assert is_stop_and_go(demo) is True


def test_an_older_file_is_a_lane_change_not_stop_and_go():
    demo = SimpleNamespace(meta={"episode_id": "x"})
    assert episode_kind(demo) == "lane_change"
    assert is_stop_and_go(demo) is False


def test_an_unknown_kind_names_the_known_ones():
    with pytest.raises(ValueError, match="lane_keeping"):
        episode_kind(SimpleNamespace(meta={"kind": "merging"}))
