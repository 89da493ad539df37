"""``metadata.yaml``: what rosbag2 (version 9, Jazzy) says of a bag's files and topics."""

from __future__ import annotations

import copy
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import yaml
from rosbags.rosbag2.metadata import dump_qos_v9, parse_qos

from jackson.host.ros.bag.topics import BagTopic

BAG_VERSION: Literal[9] = 9  # rosbag2 metadata version of ROS 2 Jazzy


@dataclass(frozen=True)
class BagFile:
    """One finished MCAP file of a bag: what ``metadata.yaml`` says of it.

    Attributes
    ----------
    name : str
        File name inside the bag folder.
    counts : mapping of str to int
        Messages per topic.
    start_ns : int
        Earliest message timestamp [ns] (0 without messages).
    end_ns : int
        Latest message timestamp [ns] (0 without messages).
    """

    name: str
    counts: Mapping[str, int]
    start_ns: int
    end_ns: int

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())


_QOS_PROFILES: dict[str, list[Any]] = {}  # a topic's QoS text -> its metadata.yaml entries


def _qos_profiles(text: str) -> list[Any]:
    """``offered_qos_profiles`` of ``metadata.yaml`` from a topic's QoS text (parsed once per
    text: ruamel takes milliseconds per topic, and every close writes them all)."""
    if not text:
        return []
    if text not in _QOS_PROFILES:
        _QOS_PROFILES[text] = dump_qos_v9(parse_qos(text))
    return copy.deepcopy(_QOS_PROFILES[text])


def fsync_replace(tmp: Path, dst: Path) -> None:
    """``os.replace`` a written, fsynced ``tmp`` onto ``dst`` and make the rename durable."""
    os.replace(tmp, dst)
    fd = os.open(dst.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_metadata(folder: Path, topics: Sequence[BagTopic], files: Sequence[BagFile]) -> None:
    """Write ``metadata.yaml`` (rosbag2 version 9, as ``ros2 bag record`` does for split bags):
    every file in order with its span and count, every topic with its count over all files."""
    spans = [(f.start_ns, f.end_ns) for f in files if f.message_count]
    start = min((a for a, _ in spans), default=0)
    end = max((b for _, b in spans), default=0)
    info = {
        "version": BAG_VERSION,
        "storage_identifier": "mcap",
        "relative_file_paths": [f.name for f in files],
        "duration": {"nanoseconds": end - start},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": sum(f.message_count for f in files),
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": t.name,
                    "type": t.msgtype,
                    "serialization_format": "cdr",
                    "offered_qos_profiles": _qos_profiles(t.qos),
                    "type_description_hash": t.type_hash,
                },
                "message_count": sum(f.counts.get(t.name, 0) for f in files),
            }
            for t in topics
        ],
        "compression_format": "",
        "compression_mode": "",
        "files": [
            {
                "path": f.name,
                "starting_time": {"nanoseconds_since_epoch": f.start_ns},
                "duration": {"nanoseconds": f.end_ns - f.start_ns},
                "message_count": f.message_count,
            }
            for f in files
        ],
        "custom_data": None,
        "ros_distro": "jazzy",
    }
    tmp = folder / "metadata.yaml.tmp"
    with tmp.open("w", encoding="utf8") as f:
        # libyaml's emitter where PyYAML has it: the pure-Python one takes ~80 ms per close
        dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
        yaml.dump({"rosbag2_bagfile_information": info}, f, Dumper=dumper, sort_keys=False)
        f.flush()
        os.fsync(f.fileno())
    fsync_replace(tmp, folder / "metadata.yaml")
