"""The kinds of recorded episodes: a lane change, or a window without one (DESIGN §23).

One place for the names the extraction writes (``meta["kind"]``, ``episodes.csv``'s ``kind``)
and the tables group by. A demonstration written before kinds existed is a lane change.
"""

from __future__ import annotations

from drivestyle.envs.demonstration import Demonstration

__all__ = ["EPISODE_KINDS", "WINDOW_ID_SUFFIX", "episode_kind", "is_stop_and_go", "is_window_id"]

EPISODE_KINDS = ("lane_change", "lane_keeping", "car_following", "approaching")
"""Every kind, in report order (:mod:`drivestyle.recorded.windows` defines the last three)."""


WINDOW_ID_SUFFIX = "_w"
"""The end of a window's episode id (``<carriageway>_<vehicle>_<mid time in ms>_w``): a lane
change's id ends in its crossing time, so the two never meet in one folder or split."""


def is_window_id(episode_id: str) -> bool:
    """Whether an episode id is a window's, not a lane change's.

    A split naming one asks for the extraction with every vehicle's windows.
    """
    return episode_id.endswith(WINDOW_ID_SUFFIX)


def episode_kind(demo: Demonstration) -> str:
    """A demonstration's kind (``meta["kind"]``; absent: ``"lane_change"``).

    Raises:
        ValueError: a kind not in :data:`EPISODE_KINDS`.
    """
    kind = str(demo.meta.get("kind", "lane_change"))
    if kind not in EPISODE_KINDS:
        raise ValueError(f"episode kind {kind!r} (meta 'kind') is not one of {EPISODE_KINDS}")
    return kind


def is_stop_and_go(demo: Demonstration) -> bool:
    """Whether a demonstration's window is stop-and-go traffic (``meta["stop_and_go"]``)."""
    return bool(demo.meta.get("stop_and_go", False))
