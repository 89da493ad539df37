"""Reading a finished bag back: its messages (:func:`read_bag`), its topics, counts, span and
size (:func:`bag_info`), and which folders of a run hold bags."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePath
from typing import Any

import yaml
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag2 import Reader, ReaderError
from rosbags.typesys import Stores, get_typestore

from jackson.host.ros.bag.errors import BagError


def read_bag(path: Path | str) -> dict[str, list[tuple[int, Any]]]:
    """Read a rosbag2 folder back: the deserialised messages per topic, in time order.

    Parameters
    ----------
    path : Path or str
        The bag folder (with ``metadata.yaml``).

    Returns
    -------
    dict of str to list of (int, object)
        ``{topic: [(timestamp_ns, message), ...]}`` for every topic the bag declares (a topic
        without messages maps to an empty list).

    Raises
    ------
    BagError
        The folder is not a readable bag (e.g. never closed: see
        :func:`~jackson.host.ros.bag.repair_bag`).
    """
    out: dict[str, list[tuple[int, Any]]] = {}
    try:
        with AnyReader([Path(path)], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
            for conn in reader.connections:
                out.setdefault(conn.topic, [])
            for conn, ns, raw in reader.messages():
                out[conn.topic].append((ns, reader.deserialize(raw, conn.msgtype)))
    except (AnyReaderError, ReaderError, FileNotFoundError) as exc:
        raise BagError(f"{path}: not a readable bag: {exc}") from exc
    return out


@dataclass(frozen=True)
class BagInfo:
    """What ``jackson bag info`` shows of a finished bag (read from its metadata and indexes).

    Attributes
    ----------
    path : Path
        The bag folder.
    counts : mapping of str to int
        Messages per topic, every declared topic.
    start_ns : int or None
        Earliest timestamp [ns] (None: no messages).
    end_ns : int or None
        Latest timestamp [ns] (None: no messages).
    files : tuple of Path
        The MCAP files, in order.
    size_bytes : int
        Their total size [bytes].
    """

    path: Path
    counts: Mapping[str, int]
    start_ns: int | None
    end_ns: int | None
    files: tuple[Path, ...]
    size_bytes: int

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())


def bag_info(path: Path | str) -> BagInfo:
    """Topics, counts, time span and size of a finished bag, without reading its messages.

    Raises
    ------
    BagError
        The folder is not a readable bag.
    """
    path = Path(path)
    try:
        with Reader(path) as reader:
            counts: dict[str, int] = {}
            for conn in reader.connections:
                counts[conn.topic] = counts.get(conn.topic, 0) + conn.msgcount
            n = reader.message_count
            span = (reader.start_time, reader.end_time - 1) if n else (None, None)
        meta = yaml.safe_load((path / "metadata.yaml").read_text(encoding="utf8"))
        names = meta["rosbag2_bagfile_information"]["relative_file_paths"]
        files = tuple(path / PurePath(name).name for name in names)
    except (ReaderError, OSError, KeyError, TypeError, yaml.YAMLError) as exc:
        raise BagError(f"{path}: not a readable bag: {exc}") from exc
    size = sum(f.stat().st_size for f in files if f.exists())
    return BagInfo(path, counts, span[0], span[1], files, size)


def bag_folders(run: Path | str) -> list[Path]:
    """The bag folders of a run folder (``bag``; any subfolder holding an MCAP file), by name."""
    run = Path(run)
    return sorted(p for p in run.iterdir() if p.is_dir() and any(p.glob("*.mcap")))


def needs_repair(path: Path | str) -> bool:
    """A bag folder whose writer never finished it: an MCAP file but no ``metadata.yaml``."""
    path = Path(path)
    return not (path / "metadata.yaml").exists() and any(path.glob("*.mcap"))
