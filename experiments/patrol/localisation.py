"""The daemon's localisation error over a patrol: its map-frame pose against the twin's truth.

The daemon publishes what it believes on ``/tf`` and records it in its run folders' bags: the
odometry ``odom -> base_footprint`` (the EKF, every telemetry frame) and the localiser's
correction ``map -> odom`` (every control tick, updated when a scan lands). Its pose in the map
frame at MCU time t is the last correction at or before t composed with the odometry at t,

    p_map(t) = T_map_odom(t_k) ⊕ p_odom(t),    t_k = max{t_k <= t},

as ``NavigateMission.pose_map`` computes it for the navigator. The error is the distance from
that position to the truth's at the same MCU time (linearly interpolated between the truth's
rows, which the twin writes every telemetry period):

    e(t) = || p_map(t)[x, y] - p_true(t)[x, y] ||.

Only samples while the robot drives count (:func:`driving`): a robot at rest keeps the error
of its last motion, and long rests between goals would otherwise weigh the median.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

DRIVING_WINDOW_S = 0.5  # [s] the truth's motion is judged over this window around a sample
DRIVING_MOVE_M = 0.01  # [m] moved this far within the window: driving
DRIVING_TURN_RAD = 0.02  # [rad] or turned this far: driving (a turn on the spot)


@dataclass(frozen=True)
class PoseTrack:
    """Poses in time order: MCU time [s], x, y [m], yaw [rad]."""

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray

    def __len__(self) -> int:
        return int(self.t_s.shape[0])

    @classmethod
    def of(cls, rows: npt.ArrayLike) -> PoseTrack:
        """From rows of (t, x, y, yaw), sorted by time."""
        raw = np.asarray(rows, dtype=np.float64).reshape(-1, 4)
        a = raw[np.argsort(raw[:, 0], kind="stable")]
        return cls(a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy(), a[:, 3].copy())

    def xy_at(self, t_s: npt.ArrayLike) -> FloatArray:
        """Positions at times ``t_s``, linearly interpolated, shape (N, 2)."""
        t = np.asarray(t_s, dtype=np.float64)
        return np.column_stack((np.interp(t, self.t_s, self.x_m), np.interp(t, self.t_s, self.y_m)))

    def yaw_at(self, t_s: npt.ArrayLike) -> FloatArray:
        """Headings at times ``t_s``, interpolated on the unwrapped heading."""
        t = np.asarray(t_s, dtype=np.float64)
        return np.asarray(np.interp(t, self.t_s, np.unwrap(self.yaw_rad)), dtype=np.float64)


@dataclass(frozen=True)
class LocalisationErrors:
    """The error of every driving sample: MCU time [s], the truth there [m], the error [m].

    Attributes
    ----------
    covered_s : float
        MCU time from the first to the last pose the bags hold [s].
    patrol_s : float
        MCU time the truth spans [s].
    """

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    error_m: FloatArray
    covered_s: float
    patrol_s: float

    def figures(self) -> dict[str, float | int | list[float] | None]:
        """Median, 99th percentile and maximum [m], with where and when the maximum was."""
        e = self.error_m
        if not e.size:
            return {"median_m": None, "p99_m": None, "max_m": None, "samples": 0}
        k = int(np.argmax(e))
        return {
            "median_m": float(np.median(e)),
            "p99_m": float(np.percentile(e, 99)),
            "max_m": float(e[k]),
            "max_at_t_s": float(self.t_s[k]),
            "max_at_xy_m": [round(float(self.x_m[k]), 2), round(float(self.y_m[k]), 2)],
            "samples": int(e.size),
            "covered_s": self.covered_s,
            "patrol_s": self.patrol_s,
        }


def read_truth(path: Path) -> PoseTrack:
    """The twin's ground truth (``truth.csv``: comment lines, a header with ``t_s, x_m, y_m,
    yaw_rad``); a last line cut short is left out.

    Raises
    ------
    ValueError
        No header or no row.
    """
    lines = [ln for ln in path.read_text(encoding="ascii").splitlines() if ln and ln[0] != "#"]
    if not lines:
        raise ValueError(f"{path}: no header")
    header = lines[0].split(",")
    cols = [header.index(k) for k in ("t_s", "x_m", "y_m", "yaw_rad")]
    rows = [ln.split(",") for ln in lines[1:]]
    rows = [r for r in rows if len(r) == len(header)]
    if not rows:
        raise ValueError(f"{path}: no rows")
    data = np.array(rows, dtype=np.float64)
    return PoseTrack.of(data[:, cols])


def compose_map_poses(odometry: PoseTrack, correction: PoseTrack) -> PoseTrack:
    """p_map(t) = T_map_odom(t_k) ⊕ p_odom(t) at every odometry sample after the first
    correction, with the last correction at or before t (module docstring)."""
    k = np.searchsorted(correction.t_s, odometry.t_s, side="right") - 1
    ok = k >= 0
    k = k[ok]
    cx, cy, cyaw = correction.x_m[k], correction.y_m[k], correction.yaw_rad[k]
    ox, oy, oyaw = odometry.x_m[ok], odometry.y_m[ok], odometry.yaw_rad[ok]
    c, s = np.cos(cyaw), np.sin(cyaw)
    return PoseTrack(odometry.t_s[ok], cx + c * ox - s * oy, cy + s * ox + c * oy, cyaw + oyaw)


def driving(truth: PoseTrack, t_s: FloatArray) -> BoolArray:
    """Samples at which the truth moved :data:`DRIVING_MOVE_M` or turned
    :data:`DRIVING_TURN_RAD` within :data:`DRIVING_WINDOW_S` around them."""
    half = DRIVING_WINDOW_S / 2.0
    a, b = truth.xy_at(t_s - half), truth.xy_at(t_s + half)
    turned = np.abs(truth.yaw_at(t_s + half) - truth.yaw_at(t_s - half))
    moved: BoolArray = (np.hypot(*(b - a).T) >= DRIVING_MOVE_M) | (turned >= DRIVING_TURN_RAD)
    return moved


def localisation_errors(estimate: PoseTrack, truth: PoseTrack) -> LocalisationErrors:
    """The error of the estimate against the truth at the estimate's driving samples within
    the truth's span (module docstring)."""
    inside = (estimate.t_s >= truth.t_s[0]) & (estimate.t_s <= truth.t_s[-1])
    t = estimate.t_s[inside]
    keep = driving(truth, t)
    t = t[keep]
    est = np.column_stack((estimate.x_m[inside][keep], estimate.y_m[inside][keep]))
    true = truth.xy_at(t)
    covered = float(estimate.t_s[-1] - estimate.t_s[0]) if len(estimate) else 0.0
    return LocalisationErrors(
        t,
        true[:, 0],
        true[:, 1],
        np.hypot(*(est - true).T),
        covered,
        float(truth.t_s[-1] - truth.t_s[0]),
    )


def _yaw(z: float, w: float) -> float:
    """The heading of a rotation about z given as a quaternion's (z, w)."""
    return 2.0 * math.atan2(z, w)


def read_tf(bag: Path) -> tuple[list[tuple[float, ...]], list[tuple[float, ...]]]:
    """The ``map -> odom`` and ``odom -> base`` transforms of one bag's ``/tf``: two lists of
    (MCU time [s], x, y, yaw); a transform's child frame under ``map`` names the odometry
    frame.

    Raises
    ------
    jackson.host.ros.bag.BagError
        Not a readable bag.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag2 import ReaderError
    from rosbags.typesys import Stores, get_typestore

    from jackson.host.ros.bag.errors import BagError

    corrections: list[tuple[float, ...]] = []
    frames: list[tuple[str, str, float, float, float, float]] = []
    try:
        with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
            conns = [c for c in reader.connections if c.topic == "/tf"]
            for conn, _, raw in reader.messages(connections=conns):
                msg: Any = reader.deserialize(raw, conn.msgtype)
                for tf in msg.transforms:
                    st, tr, q = tf.header.stamp, tf.transform.translation, tf.transform.rotation
                    row = (st.sec + st.nanosec * 1e-9, tr.x, tr.y, _yaw(q.z, q.w))
                    if tf.header.frame_id == "map":
                        corrections.append(row)
                        frames.append(("map", tf.child_frame_id, *row))
                    else:
                        frames.append((tf.header.frame_id, tf.child_frame_id, *row))
    except (AnyReaderError, ReaderError, FileNotFoundError) as exc:
        raise BagError(f"{bag}: not a readable bag: {exc}") from exc
    odom_frames = {child for parent, child, *_ in frames if parent == "map"}
    odometry = [tuple(r[2:]) for r in frames if r[0] in odom_frames]
    return corrections, odometry


def daemon_map_poses(runs: Path) -> tuple[PoseTrack, int]:
    """The daemon's map-frame poses over every bag of its run folders (``runs/*/bag``), and
    how many bags could not be read (left out)."""
    from jackson.host.ros.bag.errors import BagError

    corrections: list[tuple[float, ...]] = []
    odometry: list[tuple[float, ...]] = []
    unread = 0
    for bag in sorted(runs.glob("*/bag")):
        try:
            c, o = read_tf(bag)
        except BagError:
            unread += 1
            continue
        corrections += c
        odometry += o
    if not corrections or not odometry:
        return PoseTrack.of(np.empty((0, 4))), unread
    return compose_map_poses(PoseTrack.of(odometry), PoseTrack.of(corrections)), unread
