"""Recorded trajectories in one road frame, whatever file format they came from.

Every reader (generic CSV/Parquet, raw NGSIM, the levelX format of highD/exiD,
INTERACTION; :mod:`drivestyle.recorded.readers`) turns its file into a :class:`Recording`, and
the extraction (:mod:`drivestyle.recorded.episodes`) turns a recording into lane-change
episodes: nothing downstream knows where a track came from (the way trajdata and the
levelX tools keep a source's conventions at the edge).

The road frame of a :class:`Carriageway` (one driving direction of a straight road):

- x [m] along the direction of travel (every vehicle on the carriageway moves to +x);
- y [m] lateral, increasing to the **left** of the direction of travel;
- lane markings at the lateral positions ``markings`` (increasing), so lane k lies between
  ``markings[k]`` and ``markings[k + 1]``: lane 0 is the rightmost lane;
- positions are the vehicle's geometric centre; t in seconds; SI units throughout (a
  reader converts feet, image coordinates, bounding-box corners and driving directions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Carriageway", "Recording", "Track", "TrackError", "TrackProblem"]


class TrackError(ValueError):
    """A track or a road that cannot be meant (one line naming the source and the vehicle)."""


def _array(name: str, value: object, n: int | None, where: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim != 1 or (n is not None and a.shape[0] != n):
        raise TrackError(
            f"{where}: {name} must have shape ({n if n is not None else 'n'},), got {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        k = int(np.flatnonzero(~np.isfinite(a))[0])
        raise TrackError(f"{where}: {name} is not finite at sample {k}")
    return a


@dataclass(frozen=True)
class TrackProblem:
    """Why (part of) a track is not a road vehicle's motion.

    A finding of the readers' checks (:func:`drivestyle.recorded.track_checks.check_recording`).
    """

    text: str
    """One line without the vehicle, e.g. ``overlaps vehicle 7 from t = 3 to 5 s (…)``."""
    t_from: float = -math.inf
    """The first time it concerns [s] (−∞: the whole track)."""
    t_to: float = math.inf
    """The last time it concerns [s] (+∞: the whole track)."""

    def meets(self, start: float, stop: float) -> bool:
        """Whether it concerns a time in [start, stop] [s]."""
        return self.t_from <= stop and self.t_to >= start


@dataclass(frozen=True)
class Track:
    """One vehicle's recorded motion on a carriageway, in its road frame."""

    vehicle_id: str
    """The source's vehicle id (as text)."""
    t: np.ndarray
    """Sample times, strictly increasing, shape (n,) [s]."""
    x: np.ndarray
    """Centre along the direction of travel, shape (n,) [m]."""
    y: np.ndarray
    """Centre lateral, + to the left of travel, shape (n,) [m]."""
    frames: np.ndarray
    """The source's frame number (or sample index) of each sample, shape (n,)."""
    v: np.ndarray | None = None
    """Recorded speed, shape (n,) [m/s] (None: estimated from the positions)."""
    heading: np.ndarray | None = None
    """Recorded heading against +x, shape (n,) [rad] (None: estimated)."""
    lane: np.ndarray | None = None
    """Recorded lane index per sample in this frame's numbering (0 = rightmost), shape (n,)
    (None: found from y and the carriageway's markings)."""
    length: float = 5.0
    """Vehicle length [m]."""
    width: float = 2.0
    """Vehicle width [m]."""
    source: str = ""
    """The file it was read from (for messages and ``episodes.csv``)."""
    problems: tuple[TrackProblem, ...] = ()
    """Why the track (or a part of it) is not a road vehicle's motion (the readers' checks,
    :func:`drivestyle.recorded.track_checks.check_recording`): a lane change whose window meets
    one — its own or an interacting vehicle's — is kept unusable with it. Empty:
    plausible."""

    def __post_init__(self) -> None:
        where = f"{self.source or 'track'}, vehicle {self.vehicle_id}"
        t = _array("t", self.t, None, where)
        n = t.shape[0]
        if n < 2:
            raise TrackError(f"{where}: needs at least 2 samples, got {n}")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            raise TrackError(
                f"{where}: times must increase, but sample {k} (frame "
                f"{int(np.asarray(self.frames)[k])}) is at t = {t[k]:g} s after {t[k - 1]:g} s"
            )
        object.__setattr__(self, "t", t)
        for name in ("x", "y"):
            object.__setattr__(self, name, _array(name, getattr(self, name), n, where))
        frames = np.asarray(self.frames)
        if frames.shape != (n,):
            raise TrackError(f"{where}: frames must have shape ({n},), got {frames.shape}")
        for name in ("v", "heading", "lane"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _array(name, value, n, where))
        object.__setattr__(self, "problems", tuple(self.problems))
        if not (0 < self.length < 30 and 0 < self.width < 5):
            raise TrackError(
                f"{where}: a {self.length:g} m × {self.width:g} m vehicle is not a road "
                "vehicle (metres expected)"
            )

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])


@dataclass(frozen=True)
class Carriageway:
    """One driving direction of a straight road and the tracks on it."""

    name: str
    """E.g. 'upper' / 'lower' (levelX) or the recording's name."""
    markings: tuple[float, ...]
    """Lateral positions of the lane lines in the road frame, increasing [m]; lane k lies
    between ``markings[k]`` and ``markings[k + 1]`` (lane 0 rightmost)."""
    tracks: tuple[Track, ...]
    """The vehicles on it."""
    heading_offset: float = 0.0
    """A recorded heading in the source's frame is the road frame's plus this [rad]: π for
    a table's traffic to −x (turned by 180°), the direction's angle for INTERACTION; 0 where
    the frame is the source's. Messages quote the source's values
    (:mod:`drivestyle.recorded.track_checks`)."""

    def __post_init__(self) -> None:
        m = tuple(float(v) for v in self.markings)
        if len(m) < 3:
            raise TrackError(
                f"carriageway {self.name!r}: needs at least three lane lines (two lanes) to "
                f"change lane, got {len(m)}"
            )
        if not all(math.isfinite(v) for v in m) or bool(np.any(np.diff(m) <= 0)):
            raise TrackError(f"carriageway {self.name!r}: lane lines must increase, got {m}")
        object.__setattr__(self, "markings", m)
        object.__setattr__(self, "tracks", tuple(self.tracks))

    @property
    def lane_widths(self) -> np.ndarray:
        """Width of each lane, shape (lanes,) [m]."""
        return np.diff(np.asarray(self.markings))

    def lane_of(self, y: np.ndarray | float) -> np.ndarray:
        """Lane index of lateral positions (−1 right of the road, ``lanes`` left of it)."""
        return np.searchsorted(np.asarray(self.markings), np.asarray(y, dtype=float)) - 1


@dataclass(frozen=True)
class Recording:
    """A file's worth of tracks: one or more carriageways."""

    source: str
    """The file (or files) read."""
    carriageways: tuple[Carriageway, ...]
    """Its driving directions."""
    meta: dict[str, object] = field(default_factory=dict)
    """Reader facts (format, frame rate, units converted, …)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "carriageways", tuple(self.carriageways))
        names = [road.name for road in self.carriageways]
        twice = next((n for k, n in enumerate(names) if n in names[:k]), None)
        if twice is not None:
            raise TrackError(
                f"{self.source}: two carriageways named {twice!r}: a carriageway's name is "
                "unique in a recording (an episode id begins with it, and a vehicle id is "
                "unique only within its carriageway)"
            )
