"""Readers of published trajectory formats into a :class:`~drivestyle.envs.tracks.Recording`.

Every reader keeps its source's conventions here, at the edge, and returns tracks in the
one road frame of :mod:`drivestyle.envs.tracks` (x along travel, y to the left, lane 0
rightmost, vehicle centres, SI units). :data:`READERS` maps a format name to its reader.
"""

from __future__ import annotations

from collections.abc import Callable

from drivestyle.envs.tracks import Recording

__all__ = ["READERS"]

READERS: dict[str, Callable[..., Recording]] = {}
"""Format name → reader (``READERS[name](path, ...)`` returns a :class:`Recording`)."""
