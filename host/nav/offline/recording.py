"""A run folder's recording: its bags checked, their messages streamed, the LiDAR's mount and
the navigation's start pose found."""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jackson.host.nav.offline.errors import (
    DamagedBagError,
    NoBagError,
    NoOdometryError,
    NoScanError,
    RecordingMapError,
)
from jackson.host.nav.types import Pose2D
from jackson.host.ros.builder import Point, Pose, planar_pose

SCAN_TOPIC = "/scan"
EKF_TOPIC = "/odometry/filtered"
ODOMETRY_TOPICS = (EKF_TOPIC, "/wheel/odom")  # preferred first
TF_STATIC_TOPIC = "/tf_static"


@dataclass(frozen=True)
class RecordingPlan:
    """What a run folder's bags hold, checked before anything is read.

    Attributes
    ----------
    bags : tuple of Path
        The bag folders, in order.
    odometry_topic : str
        The odometry topic to map with.
    scan_count : int
        /scan messages in all bags (the progress bar's total).
    """

    bags: tuple[Path, ...]
    odometry_topic: str
    scan_count: int


def plan_recording(run: Path) -> RecordingPlan:
    """Check a run folder before mapping it: a bag, /scan in it, an odometry topic. A bag
    folder itself (its MCAP files inside) is taken as a run of that one bag.

    Raises
    ------
    NoBagError, NoScanError, NoOdometryError, DamagedBagError
        One line each, naming the folder and what to do.
    """
    from jackson.host.ros.bag import BagError, bag_folders, bag_info, needs_repair

    if not run.is_dir():
        raise NoBagError(f"{run}: no such run folder")
    bags = tuple(bag_folders(run)) or ((run,) if any(run.glob("*.mcap")) else ())
    if not bags:
        raise NoBagError(f"{run}: no bag (a run folder holds one in bag/ when it was recorded)")
    counts: dict[str, int] = {}
    for bag in bags:
        if needs_repair(bag):
            raise DamagedBagError(f"{bag}: never closed: run `jackson bag repair {run}` first")
        try:
            info = bag_info(bag)
        except BagError as exc:
            raise DamagedBagError(f"{exc}: try `jackson bag repair {run}`") from exc
        for topic, n in info.counts.items():
            counts[topic] = counts.get(topic, 0) + n
    if counts.get(SCAN_TOPIC, 0) == 0:
        raise NoScanError(
            f"{run}: the bag has no {SCAN_TOPIC}: record with the LiDAR on (jackson daemon "
            "--lidar ...)"
        )
    odometry = next((t for t in ODOMETRY_TOPICS if counts.get(t, 0) > 0), None)
    if odometry is None:
        raise NoOdometryError(
            f"{run}: the bag has no odometry ({' or '.join(ODOMETRY_TOPICS)}): record a run of "
            "the daemon"
        )
    return RecordingPlan(bags, odometry, counts[SCAN_TOPIC])


def messages(bags: Sequence[Path], topics: Sequence[str]) -> Iterator[tuple[str, Any]]:
    """(topic, message) of ``topics`` over the bags in order, each bag in time order, one at a
    time (rosbags' reader decompresses a chunk at a time)."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag2 import ReaderError
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    for bag in bags:
        try:
            with AnyReader([bag], default_typestore=store) as reader:
                conns = [c for c in reader.connections if c.topic in topics]
                for conn, _, raw in reader.messages(connections=conns):
                    yield conn.topic, reader.deserialize(raw, conn.msgtype)
        except (AnyReaderError, ReaderError, OSError, ValueError, KeyError) as exc:
            raise DamagedBagError(
                f"{bag}: not a readable bag: {exc}: try `jackson bag repair {bag.parent}`"
            ) from exc


def tf_chain(transforms: Sequence[Any], parent: str, child: str) -> Pose2D | None:
    """The planar pose of frame ``child`` in frame ``parent`` from a /tf_static message's
    transforms (walking up from ``child``); None if they do not connect the two."""
    up = {t.child_frame_id.lstrip("/"): t for t in transforms}
    pose = Pose2D()
    frame = child.lstrip("/")
    target = parent.lstrip("/")
    for _ in range(len(up) + 1):
        if frame == target:
            return pose
        t = up.get(frame)
        if t is None:
            return None
        v = t.transform.translation
        step = Pose(position=Point(x=v.x, y=v.y, z=v.z), orientation=t.transform.rotation)
        pose = planar_pose(step).compose(pose)
        frame = t.header.frame_id.lstrip("/")
    return None


def _frames(bags: Sequence[Path], odometry: str) -> tuple[str, str]:
    """(base frame, laser frame): the first odometry message's child and the first scan's."""
    base = laser = ""
    for topic, msg in messages(bags, (odometry, SCAN_TOPIC)):
        if topic == odometry and not base:
            base = str(msg.child_frame_id)
        if topic == SCAN_TOPIC and not laser:
            laser = str(msg.header.frame_id)
        if base and laser:
            break
    return base, laser


def find_mount(run: Path, bags: Sequence[Path], odometry: str) -> tuple[Pose2D, str]:
    """The LiDAR's pose on the base and where it came from (module docstring)."""
    base, laser = _frames(bags, odometry)
    for _, msg in messages(bags, (TF_STATIC_TOPIC,)):
        mount = tf_chain(msg.transforms, base, laser)
        if mount is not None:
            return mount, TF_STATIC_TOPIC
    nav = navigate_meta(run)
    if "lidar_mount" in nav:
        return pose_of(nav["lidar_mount"], run, "lidar_mount"), "meta.json"
    return Pose2D(), "default"


def navigate_meta(run: Path) -> dict[str, Any]:
    """The ``navigate`` entry of the run's meta.json ({} when there is none)."""
    path = run / "meta.json"
    if not path.exists():
        return {}
    try:
        meta = json.loads(path.read_text(encoding="utf8"))
    except (OSError, ValueError) as exc:
        raise RecordingMapError(f"{path}: not readable JSON: {exc}") from exc
    nav = meta.get("navigate") if isinstance(meta, dict) else None
    return nav if isinstance(nav, dict) else {}


def pose_of(value: Any, run: Path, name: str) -> Pose2D:
    try:
        return Pose2D(*(float(v) for v in value))
    except (TypeError, ValueError) as exc:
        raise RecordingMapError(f"{run / 'meta.json'}: navigate.{name}: {exc}") from exc
