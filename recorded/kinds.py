"""The kinds of recorded episodes: a lane change, or a window without one (DESIGN §23).

One place for the names the extraction writes (``meta["kind"]``, ``episodes.csv``'s ``kind``)
and the tables group by: every recorded :class:`~drivestyle.envs.demonstration.Demonstration`
carries its kind in ``meta["kind"]``, one of :data:`EPISODE_KINDS`, and whether its window is
stop-and-go traffic in ``meta["stop_and_go"]`` (a flag across kinds). The extraction writes
them (:mod:`drivestyle.recorded.episodes`, :mod:`drivestyle.recorded.windows`); the prediction
study summarises by them (:mod:`drivestyle.studies.prediction.summaries`), a record copying
both into its row. A demonstration (or a row) written before kinds existed is a lane change
(:data:`DEFAULT_KIND`) of no stop-and-go window. The groups across kinds a study reports are
named here too (:data:`ALL_KINDS`, :data:`STOP_AND_GO`); they are not kinds.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Protocol

__all__ = [
    "ALL_KINDS",
    "DEFAULT_KIND",
    "EPISODE_KINDS",
    "STOP_AND_GO",
    "WINDOW_ID_SUFFIX",
    "check_kind",
    "episode_kind",
    "is_stop_and_go",
    "is_window_id",
    "kind_in",
    "stop_and_go_in",
]

EPISODE_KINDS = ("lane_change", "lane_keeping", "car_following", "approaching")
"""Every kind, in report order (:mod:`drivestyle.recorded.windows` defines the last three):
the vehicle changes lane; keeps its lane with no leader near; follows its own-lane leader;
approaches a slower own-lane leader."""
DEFAULT_KIND = "lane_change"
"""The kind of an episode whose metadata has none (written before the kinds were: the
extraction then wrote lane changes only)."""
ALL_KINDS = "all"
"""The group of every kind together (what a study reports as pooled); not a kind."""
STOP_AND_GO = "stop_and_go"
"""The metadata key of the stop-and-go flag, and the group of the stop-and-go windows
whatever their kind (a study's subset across kinds); not a kind."""


WINDOW_ID_SUFFIX = "_w"
"""The end of a window's episode id (``<carriageway>_<vehicle>_<mid time in ms>_w``): a lane
change's id ends in its crossing time, so the two never meet in one folder or split."""


def is_window_id(episode_id: str) -> bool:
    """Whether an episode id is a window's, not a lane change's.

    A split naming one asks for the extraction with every vehicle's windows.
    """
    return episode_id.endswith(WINDOW_ID_SUFFIX)


class _HasMeta(Protocol):
    """A demonstration (anything with a ``meta`` dict)."""

    @property
    def meta(self) -> Mapping[str, Any]: ...


def check_kind(kind: Any) -> str:
    """``kind`` if it is a name of :data:`EPISODE_KINDS`.

    Raises:
        ValueError: any other value (the message lists the kinds).
    """
    if kind not in EPISODE_KINDS:
        raise ValueError(f"episode kind {kind!r} (meta 'kind') is not one of {EPISODE_KINDS}")
    return str(kind)


def kind_in(meta: Mapping[str, Any]) -> str:
    """The kind a mapping says under ``"kind"`` (:data:`DEFAULT_KIND` where it says none).

    The mapping is a demonstration's metadata or a record that copied it (a
    ``prediction_eval.json`` row).

    Raises:
        ValueError: a kind not in :data:`EPISODE_KINDS` (the message lists them).
    """
    return check_kind(meta.get("kind", DEFAULT_KIND))


def stop_and_go_in(meta: Mapping[str, Any]) -> bool:
    """Whether a mapping (metadata, a record's row) flags its window stop-and-go (absent: False)."""
    return bool(meta.get(STOP_AND_GO, False))


def episode_kind(demo: _HasMeta) -> str:
    """A demonstration's kind (``meta["kind"]``; absent: ``"lane_change"``; :func:`kind_in`).

    Raises:
        ValueError: a kind not in :data:`EPISODE_KINDS`.
    """
    return kind_in(demo.meta)


def is_stop_and_go(demo: _HasMeta) -> bool:
    """Whether a demonstration's window is stop-and-go traffic (``meta["stop_and_go"]``).

    Its own-lane leader slows below ~5 m/s or its speed swings strongly (absent: False).
    """
    return stop_and_go_in(demo.meta)
