"""An extraction's output folder: each usable episode's ``.npz`` and ``episodes.csv``.

:func:`write_episodes` writes the folder ``drivestyle extract-episodes`` makes (file names
from episode ids made safe, :func:`episode_file_name`); :func:`read_episodes` reads its
usable episodes back, validating the index.
"""

from __future__ import annotations

import csv
import hashlib
import re
from pathlib import Path
from typing import TYPE_CHECKING

from drivestyle.envs.demonstration import Demonstration, save_demonstration

if TYPE_CHECKING:
    from drivestyle.recorded.episodes import Episode

__all__ = [
    "EPISODE_COLUMNS",
    "FILE_NAME_HASH",
    "FILE_NAME_MAX",
    "FILE_NAME_UNSAFE",
    "episode_file_name",
    "episode_file_names",
    "read_episodes",
    "write_episodes",
]


EPISODE_COLUMNS = (
    "episode_id",
    "file",
    "source",
    "carriageway",
    "vehicle_id",
    "direction",
    "mirrored",
    "from_lane",
    "to_lane",
    "t_cross_s",
    "first_frame",
    "last_frame",
    "lane_width_m",
    "lateral_move_m",
    "tv_id",
    "tv_role",
    "interacting",
    "no_interaction",
    "observed_until_s",
    "usable",
    "reason",
    "kind",
    "stop_and_go",
)
"""Columns of ``episodes.csv`` (``interacting``: ``role:id`` joined by ``;``)."""


def _cell(value: float | None) -> str:
    if value is None:
        return ""
    return str(int(value)) if float(value).is_integer() else f"{value:g}"


FILE_NAME_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]")
"""Characters a file name built from data may not hold: everything outside
``[A-Za-z0-9._+-]`` (a path separator, ``..`` as a name, NUL, spaces, non-ASCII letters a
file system may normalise or refuse) is replaced by ``_``."""
FILE_NAME_MAX = 120
"""Most characters of a file name built from data, before ``.npz``: file systems take 255
bytes, and an id is data (a 300-character id must not end the run with ``File name too
long``)."""
FILE_NAME_HASH = 12
"""Hex digits of the id's SHA-256 appended to a name that had to change (two ids that
differ only in replaced or cut characters keep distinct names)."""


def episode_file_name(episode_id: str, taken: set[str] | None = None) -> str:
    """The demonstration file's name of an episode: ``<episode_id>.npz`` where that is safe.

    An episode id holds data (the carriageway's and the vehicle's ids), so it may hold a
    path separator, ``..``, NUL or hundreds of characters. The name keeps the id where it
    is made of ``[A-Za-z0-9._+-]``, does not start with ``.``, has at most
    :data:`FILE_NAME_MAX` characters and is not in ``taken`` (ignoring case); otherwise
    every other character becomes ``_``, a leading ``.`` too, the result is cut to leave
    room for ``-`` and the first :data:`FILE_NAME_HASH` hex digits of the id's SHA-256,
    which are appended. The name is always one path component, so a file stays inside its
    folder; two ids get two names (unless their hashes agree, which
    :func:`write_episodes` refuses).

    Args:
        episode_id: the episode's id (``episodes.csv`` keeps it as it is).
        taken: names already given in the folder, casefolded (ids that differ only in case
            would share one file on macOS and Windows file systems).

    Returns:
        The file name, e.g. ``+x_car_3973.npz`` or ``+x_.._.._etc_3973-1f0c25e1a2b9.npz``.
    """
    name = FILE_NAME_UNSAFE.sub("_", episode_id)
    if name.startswith("."):
        name = "_" + name[1:]  # never a hidden file, "." or ".."
    changed = name != episode_id or len(name) > FILE_NAME_MAX
    if changed or (taken is not None and f"{name}.npz".casefold() in taken):
        digest = hashlib.sha256(episode_id.encode("utf-8", "surrogatepass")).hexdigest()
        name = f"{name[: FILE_NAME_MAX - FILE_NAME_HASH - 1]}-{digest[:FILE_NAME_HASH]}"
    return f"{name}.npz"


def episode_file_names(episodes: list[Episode], out_dir: str | Path) -> dict[str, str]:
    """The demonstration file's name of every usable episode (:func:`episode_file_name`).

    Call it with the folder the user named before writing into a temporary one (as
    ``extract-episodes`` does): its error then names the final path, never the temporary.

    Args:
        episodes: from :func:`extract_episodes`.
        out_dir: the output folder, for the message.

    Returns:
        Episode id → file name, for the usable episodes.

    Raises:
        ValueError: two usable episodes of one id (their files would be one); the message
            names the id and the file.
    """
    names: dict[str, str] = {}  # episode id → file name
    taken: set[str] = set()
    for ep in episodes:
        if ep.usable and ep.demo is not None:
            name = names.get(ep.episode_id) or episode_file_name(ep.episode_id, taken)
            if ep.episode_id in names or name.casefold() in taken:
                raise ValueError(
                    f"two episodes would be written to {Path(out_dir) / name} (episode "
                    f"{ep.episode_id!r} twice): an episode id is unique in a folder"
                )
            names[ep.episode_id] = name
            taken.add(name.casefold())
    return names


def write_episodes(episodes: list[Episode], out_dir: str | Path) -> Path:
    """Each usable episode's demonstration in ``out_dir`` and every episode in ``episodes.csv``.

    A demonstration's file is named by :func:`episode_file_name` (``<episode_id>.npz``
    where the id is a safe file name, else a safe name with the id's hash;
    ``episodes.csv``'s ``file`` column says which): no id places a file outside
    ``out_dir``, and ids that differ only in case get different names.

    Args:
        episodes: from :func:`extract_episodes` (unusable ones appear only in the index).
        out_dir: the folder (created).

    Returns:
        The path of ``episodes.csv``.

    Raises:
        ValueError: two usable episodes of one id (their files would be one); the message
            names the id.
    """
    out_dir = Path(out_dir)
    names = episode_file_names(episodes, out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "episodes.csv"
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(EPISODE_COLUMNS)
        for ep in episodes:
            name = ""
            if ep.usable and ep.demo is not None:
                name = names[ep.episode_id]
                save_demonstration(ep.demo, out_dir / name)
            tv_role, tv_id = ep.interacting[0] if ep.interacting else ("phantom", "")
            writer.writerow(
                [
                    ep.episode_id,
                    name,
                    ep.source,
                    ep.carriageway,
                    ep.vehicle_id,
                    ep.direction,
                    ep.mirrored,
                    ep.from_lane,
                    ep.to_lane,
                    f"{ep.t_cross:.3f}",
                    _cell(ep.first_frame),
                    _cell(ep.last_frame),
                    f"{ep.lane_width:.3f}",
                    f"{ep.lateral_move:.3f}",
                    tv_id,
                    tv_role,
                    ";".join(f"{role}:{vid}" for role, vid in ep.interacting),
                    ep.no_interaction,
                    f"{ep.observed_until_s:g}",
                    ep.usable,
                    "; ".join(ep.reasons),
                    ep.kind,
                    bool(ep.demo is not None and ep.demo.meta.get("stop_and_go", False)),
                ]
            )
    return path


def read_episodes(folder: str | Path) -> list[tuple[str, str, Demonstration]]:
    """The usable episodes of a folder :func:`write_episodes` wrote, in ``episodes.csv`` order.

    Args:
        folder: the folder (``drivestyle extract-episodes --out``).

    Returns:
        (episode id, vehicle, demonstration) per usable episode; the vehicle is
        ``<carriageway>:<vehicle id>`` (a vehicle id is unique within its carriageway).

    Raises:
        FileNotFoundError: no such folder, or no ``episodes.csv`` in it.
        ValueError: a malformed ``episodes.csv`` (missing columns, an id twice), a usable
            row whose file is missing or not a demonstration; the message names the file
            and the row.
    """
    from drivestyle.envs.demonstration import DemonstrationError, load_demonstration

    folder = Path(folder)
    index = folder / "episodes.csv"
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: no such folder (an extract-episodes output folder)")
    if not index.is_file():
        raise FileNotFoundError(
            f"{folder} has no episodes.csv: pass a folder written by drivestyle extract-episodes"
        )
    with index.open(newline="", encoding="utf-8", errors="replace") as f:
        reader = csv.DictReader(f)
        need = {"episode_id", "file", "carriageway", "vehicle_id", "usable"}
        missing = sorted(need - set(reader.fieldnames or ()))
        if missing:
            raise ValueError(f"{index}: missing column(s) {', '.join(missing)}")
        rows = list(reader)
    out, seen = [], set()
    for n, row in enumerate(rows, start=2):
        eid = row["episode_id"] or ""
        if eid in seen:
            raise ValueError(f"{index}:{n}: episode {eid!r} appears twice")
        seen.add(eid)
        if row["usable"] != "True":
            continue
        path = folder / (row["file"] or "")
        if not row["file"] or Path(row["file"]).name != row["file"] or not path.is_file():
            raise ValueError(
                f"{index}:{n}: usable episode {eid!r} names the file {row['file']!r}, which is "
                f"not in {folder}"
            )
        try:
            demo = load_demonstration(path)
        except DemonstrationError as exc:
            raise ValueError(f"{index}:{n}: {exc}") from None
        out.append((eid, f"{row['carriageway']}:{row['vehicle_id']}", demo))
    return out
