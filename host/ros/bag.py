"""rosbag2 recording of a run in MCAP storage, without a ROS installation.

:class:`BagRecorder` writes the topics the ROS 2 bridge publishes (Appendix C) into a rosbag2
folder that ``ros2 bag play``, Foxglove and :func:`read_bag` open:

======================  =======================================  =============================
topic                   type                                     content
======================  =======================================  =============================
``/wheel/odom``         ``nav_msgs/msg/Odometry``                dead-reckoned pose, v, w
``/imu/data``           ``sensor_msgs/msg/Imu``                  gyro and accelerometer (SI)
``/odometry/filtered``  ``nav_msgs/msg/Odometry``                EKF estimate (30 Hz)
``/joint_states``       ``sensor_msgs/msg/JointState``           wheel angles and speeds
``/diagnostics``        ``diagnostic_msgs/msg/DiagnosticArray``  link and sensor health (1 Hz)
``/tf``                 ``tf2_msgs/msg/TFMessage``               odom -> base_footprint (EKF)
``/tf_static``          ``tf2_msgs/msg/TFMessage``               the mounting transforms
``/jackson/telemetry``  ``std_msgs/msg/UInt8MultiArray``         every received frame's bytes
======================  =======================================  =============================

The raw frames use ``std_msgs/msg/UInt8MultiArray`` (empty layout, the bytes in ``data``):
ROS 2 has no plain byte-string message, and a standard type keeps the bag readable by any
tool without a custom message package; the frame format itself is the protocol's
(``protocol/spec.md``).

Time. ``header.stamp`` and the bag's receive timestamp both come from the ``t_s`` the caller
passes: the MCU's unwrapped clock on the robot, the simulated clock on the twin (never the
host's wall clock, so a replayed run's bag carries the original's times). The bag
timestamp is ``round(t_s * 1e9)`` ns; it starts near zero, so tools that show absolute dates
show 1970. Within a topic the bag timestamp never decreases: a sample older than the previous
one of its topic keeps its true ``header.stamp`` but is filed at the previous timestamp.

Crash safety. The MCAP writer (the ``mcap`` library's) keeps the open chunk in memory and
writes the summary, the footer and ``metadata.yaml`` in :meth:`BagRecorder.close`; a bag
that was never closed has no ``metadata.yaml`` and its last file no summary. Three things
keep a run's bag:

* The daemon's SIGINT and SIGTERM handlers only stop its loop, and the loop's ``finally:``
  closes the recorders (the run folder's and this one): a stopped daemon leaves a complete
  bag. ``close()`` is idempotent; called from a signal handler while a message is being
  written, it waits for that write to finish; writes after ``close()`` are ignored.
* Every ``flush_interval_s`` of message time the open chunk is written out and the file
  flushed, so a process killed outright (SIGKILL) loses at most that much.
* :func:`repair_bag` turns such a folder into a complete bag holding every message of the
  chunks that reached the disk whole, read with the mcap library's stream reader (``jackson
  bag repair``; the daemon repairs earlier runs' bags when it starts).

Size. With ``max_bytes`` the bag is split as ``ros2 bag record --max-bag-size`` does: the
files ``<name>_0.mcap``, ``<name>_1.mcap``... of one folder, each finished (summary and
footer) when the next starts, one ``metadata.yaml`` listing them all with each file's span
and count. /tf_static is in the first file only.
"""

from __future__ import annotations

import copy
import math
import os
import struct
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any, BinaryIO, Literal

import yaml
from mcap.data_stream import RecordBuilder
from mcap.exceptions import InvalidMagic, McapError
from mcap.reader import SeekingReader
from mcap.records import Channel as McapChannel
from mcap.records import Chunk as McapChunk
from mcap.records import ChunkIndex as McapChunkIndex
from mcap.records import Message as McapMessage
from mcap.records import Schema as McapSchema
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.summary import Summary
from mcap.writer import CompressionType
from mcap.writer import Writer as McapFileWriter
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Reader, ReaderError
from rosbags.rosbag2.metadata import dump_qos_v9, parse_qos
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore
from rosbags.typesys.stores import ros2_jazzy as jazzy
from zstandard import ZstdError

from jackson.common.errors import JacksonError
from jackson.host.estimation.odometry import OdometryCovariance
from jackson.host.ros import cdr
from jackson.host.ros.messages import (
    NS_PER_S,
    TOPIC_TYPES,
    MessageBuilder,
    RosSettings,
    StampClock,
    planar_covariance,
)

DiagnosticArray = jazzy.diagnostic_msgs__msg__DiagnosticArray

BAG_VERSION: Literal[9] = 9  # rosbag2 metadata version of ROS 2 Jazzy
_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}
DEFAULT_FLUSH_INTERVAL_S = 1.0  # [s] of message time between chunk flushes

_LEVEL_TEXT = ("OK", "WARN", "ERROR", "STALE")


class BagError(JacksonError, RuntimeError):
    """A bag cannot be created, written or repaired (the message names the folder)."""


@dataclass(frozen=True)
class _TopicSpec:
    msgtype: str
    reliability: QosReliability
    durability: QosDurability
    depth: int


def _topic_specs(settings: RosSettings) -> dict[str, tuple[str, _TopicSpec]]:
    """Name, type and offered QoS (Appendix C) of each topic by its key, in registration order
    (every topic the live node publishes or receives, and the raw frames)."""
    rel, be = QosReliability.RELIABLE, QosReliability.BEST_EFFORT
    vol, latched = QosDurability.VOLATILE, QosDurability.TRANSIENT_LOCAL
    kinds = {"reliable": (rel, vol), "sensor": (be, vol), "latched": (rel, latched)}
    kinds["map"] = kinds["latched"]
    out = {}
    for key, (_, kind, depth) in TOPIC_TYPES.items():
        reliability, durability = kinds[kind]
        out[key] = (
            settings.topic(key),
            _TopicSpec(settings.topic_type(key), reliability, durability, depth),
        )
    return out


def _qos(spec: _TopicSpec) -> Qos:
    never = QosTime(0, 0)
    return Qos(
        QosHistory.KEEP_LAST,
        spec.depth,
        spec.reliability,
        spec.durability,
        never,
        never,
        QosLiveliness.AUTOMATIC,
        never,
        False,
    )


def stamp_ns(t_s: float) -> int:
    """The bag timestamp of a sample at ``t_s`` [s]: whole nanoseconds, rounded.

    Parameters
    ----------
    t_s : float
        MCU (or simulated) time [s], not negative.

    Returns
    -------
    int
        The timestamp [ns].

    Raises
    ------
    BagError
        ``t_s`` is negative or not finite.
    """
    if not math.isfinite(t_s) or t_s < 0.0:
        raise BagError(f"bag time must be a finite time >= 0 s, got {t_s!r}")
    return round(t_s * NS_PER_S)


@dataclass
class _State:
    last_ns: dict[str, int] = field(default_factory=dict)
    flushed_ns: int | None = None
    static_written: bool = False
    busy: bool = False
    close_requested: bool = False
    closed: bool = False


class _ChunkIndexFile:
    """The chunk indexes of one MCAP file kept on disk until its summary is written.

    mcap's writer keeps a ``ChunkIndex`` object (with a dict of the chunk's channels) for every
    chunk it has finished, to write them all in the summary at the end. The bag finishes a
    chunk every second of MCU time (each flush makes the bag readable up to it), so a
    navigating robot-hour left 3600 of them, about 2 MB, in the daemon's memory. This list
    takes their place in the writer: each index is serialized as it comes (the record the
    summary will hold) into an unnamed temporary file beside the bag, and read back once, when
    the summary is written. Memory stays flat however long the run.
    """

    def __init__(self, folder: Path) -> None:
        # closed once read back (__iter__), or with the process
        self._file = tempfile.TemporaryFile(dir=folder, prefix=".chunk-index-")  # noqa: SIM115
        self._count = 0

    @classmethod
    def attach(cls, writer: McapFileWriter, folder: Path) -> None:
        """Replace ``writer``'s in-memory list (mcap 1.6's ``Writer.__chunk_indices``); a writer
        without one (another mcap version) keeps its own."""
        name = "_Writer__chunk_indices"
        if isinstance(getattr(writer, name, None), list):
            setattr(writer, name, cls(folder))

    def append(self, index: McapChunkIndex) -> None:
        """Serialize one chunk index to the file."""
        rb = RecordBuilder()
        index.write(rb)
        data = rb.end()  # type: ignore[no-untyped-call]
        self._file.write(struct.pack("<I", len(data)) + data)
        self._count += 1

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[_RawRecord]:
        """The records in order (each written as it was serialized), then the file is closed."""
        self._file.seek(0)
        try:
            for _ in range(self._count):
                (n,) = struct.unpack("<I", self._file.read(4))
                yield _RawRecord(self._file.read(n))
        finally:
            self._file.close()


class _RawRecord:
    """A serialized MCAP record, written as it is."""

    def __init__(self, data: bytes) -> None:
        self.data = data

    def write(self, stream: RecordBuilder) -> None:
        stream.write(self.data)


class BagRecorder:
    """Writes a run's ROS 2 topics into a rosbag2 folder with MCAP storage.

    Messages come built (:class:`~jackson.host.ros.messages.MessageBuilder`, the live node's
    builder): :meth:`write` files one under its topic's key. The plain-value methods
    (:meth:`wheel_odom`, :meth:`imu`...) build through the same builder, for tools and tests
    without a core. /tf_static is written once, with the first message, unless it came
    already. See the module docstring for the time base and the crash safety. Usable as a
    context manager (``close()`` on exit).
    """

    def __init__(
        self,
        path: Path,
        settings: RosSettings | None = None,
        *,
        odometry: OdometryCovariance | None = None,
        clock: StampClock | None = None,
        flush_interval_s: float | None = DEFAULT_FLUSH_INTERVAL_S,
        hardware_id: str = "jackson",
        max_bytes: int | None = None,
        compression: str = "zstd",
    ) -> None:
        """Create the bag folder ``path`` and register every topic.

        Parameters
        ----------
        path : Path
            The rosbag2 folder to create (it must not exist; its parent may not either).
        settings : RosSettings or None
            Topic and frame names, mounting offsets, covariances: the live node's parameters
            (default: :class:`RosSettings`).
        odometry : OdometryCovariance or None
            The /wheel/odom covariances (the config's ``odometry`` section; defaults:
            ``OdometryCovariance()``).
        clock : StampClock or None
            MCU time to ROS time (default: MCU time itself, the bag's time base without a
            live node).
        flush_interval_s : float or None
            Message time [s] between writes of the open chunk to disk (None:
            only at close).
        hardware_id : str
            ``hardware_id`` of the /diagnostics statuses.
        max_bytes : int or None
            Start the next file once the open one exceeds this size [bytes]
            (checked at each chunk flush): ``<name>_0.mcap``, ``<name>_1.mcap``... in
            the same folder. None: one file.
        compression : str
            The MCAP chunk compression: ``"zstd"`` (the default, as rosbag2's MCAP storage
            writes; a navigating run's bag about a third the size), ``"lz4"`` or ``"none"``.
            Readers decompress chunks themselves (the mcap library, rosbags, ``ros2 bag``).

        Raises
        ------
        BagError
            The folder exists already or cannot be created.
        """
        self.path = Path(path)
        self.settings = settings or RosSettings()
        self.builder = MessageBuilder(
            self.settings,
            odometry or OdometryCovariance(),
            clock or StampClock(sim_time=True),
            hardware_id,
        )
        self.flush_interval_ns = (
            None if flush_interval_s is None else stamp_ns(max(flush_interval_s, 0.0))
        )
        self._store = _jazzy()
        self._state = _State()
        specs = _topic_specs(self.settings)
        self._names = {key: name for key, (name, _) in specs.items()}
        self._topics = _bag_topics({name: spec for name, spec in specs.values()}, self._store)
        self.max_bytes = max_bytes
        if compression not in _COMPRESSION:
            raise ValueError(f"bag compression {compression!r}: one of {', '.join(_COMPRESSION)}")
        self.compression = _COMPRESSION[compression]
        self.files: list[Path] = []  # every MCAP file written, in order
        self._file: BinaryIO | None = None
        self._done: list[BagFile] = []  # the finished files
        try:
            self.path.mkdir(parents=True)
        except OSError as exc:
            self._state.closed = True
            what = "exists already" if isinstance(exc, FileExistsError) else str(exc)
            raise BagError(f"{self.path}: cannot create the bag: {what}") from exc
        try:
            self._open_file()
        except BagError:
            self._state.closed = True
            raise

    def _open_file(self) -> None:
        self._open_mcap()
        _ChunkIndexFile.attach(self._writer, self.path)

    def _open_mcap(self) -> None:
        """Start the next MCAP file ``<name>_<k>.mcap`` with every schema and channel."""
        file = self.path / f"{self.path.name}_{len(self.files)}.mcap"
        try:
            self._file = file.open("xb")
            self._writer = McapFileWriter(self._file, compression=self.compression)
            self._writer.start(profile="ros2", library="jackson")
            schema_ids: dict[str, int] = {}
            self._channels: dict[str, int] = {}
            for t in self._topics:
                if t.msgtype not in schema_ids:
                    schema_ids[t.msgtype] = self._writer.register_schema(
                        t.msgtype, "ros2msg", t.msgdef.encode()
                    )
                self._channels[t.name] = self._writer.register_channel(
                    t.name, "cdr", schema_ids[t.msgtype], t.channel_metadata()
                )
        except OSError as exc:
            raise BagError(f"{file}: cannot create the bag file: {exc}") from exc
        self.files.append(file)
        self._counts: dict[str, int] = {}
        self._span_ns: tuple[int, int] | None = None

    def _finish_file(self) -> None:
        """Write the open file's summary and footer and close it."""
        file, self._file = self._file, None
        if file is None:
            return
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]
            file.flush()
        finally:
            file.close()
        start, end = self._span_ns or (0, 0)
        self._done.append(BagFile(self.files[-1].name, dict(self._counts), start, end))

    def _rotate_if_full(self) -> None:
        """Finish the file and go on in the next one once it exceeds ``max_bytes``."""
        if self.max_bytes is None or self._file is None or self._file.tell() < self.max_bytes:
            return
        try:
            self._finish_file()
        except OSError as exc:
            raise BagError(f"{self.files[-1]}: cannot finish the file: {exc}") from exc
        self._open_file()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has run (or been requested during a write)."""
        return self._state.closed or self._state.close_requested

    # ---- messages -------------------------------------------------------------------------

    def write(self, key: str, t_s: float, msg: Any) -> None:
        """File a built message under the topic with key ``key`` at MCU time ``t_s``.

        Parameters
        ----------
        key : str
            The topic's key (:data:`~jackson.host.ros.messages.TOPIC_TYPES`).
        t_s : float
            MCU time of the message [s] (its stamp is the builder's).
        msg : object
            The message (a ``rosbags`` Jazzy dataclass).
        """
        if key == "tf_static":
            if self._state.static_written:
                return
            self._state.static_written = True
        self._write(key, t_s, msg)

    def wheel_odom(self, t_s: float, x: float, y: float, yaw: float, v: float, w: float) -> None:
        """Wheel odometry on /wheel/odom (Eq. 2, 3, 9), odom -> base_footprint.

        Parameters
        ----------
        t_s : float
            MCU time of the frame [s].
        x, y : float
            Position [m].
        yaw : float
            Heading [rad].
        v : float
            Body velocity v_x [m/s] (v_y is 0: no lateral slip).
        w : float
            Yaw rate [rad/s].
        """
        b = self.builder
        self._write(
            "wheel_odom",
            t_s,
            b.odometry(t_s, x, y, yaw, (v, 0.0, w), b.odom_pose_cov, b.odom_twist_cov),
        )

    def imu(self, t_s: float, accel_xyz: Sequence[float], gyro_xyz: Sequence[float]) -> None:
        """An IMU sample on /imu/data in imu_link, without orientation.

        Parameters
        ----------
        t_s : float
            MCU time of the frame [s].
        accel_xyz : sequence of float
            Specific force [m/s^2], 3 values.
        gyro_xyz : sequence of float
            Angular velocity [rad/s], 3 values.
        """
        ax, ay, az = (float(a) for a in accel_xyz)
        gx, gy, gz = (float(g) for g in gyro_xyz)
        self._write("imu", t_s, self.builder.imu_si(t_s, (gx, gy, gz), (ax, ay, az)))

    def filtered(
        self,
        t_s: float,
        x: float,
        y: float,
        yaw: float,
        vx: float,
        vy: float,
        vyaw: float,
        p_diag: Sequence[float] | None,
    ) -> None:
        """An EKF output on /odometry/filtered and the matching odom -> base_footprint on /tf.

        Parameters
        ----------
        t_s : float
            MCU time the estimate refers to [s].
        x, y : float
            Position [m].
        yaw : float
            Heading [rad].
        vx, vy : float
            Body velocity [m/s].
        vyaw : float
            Yaw rate [rad/s].
        p_diag : sequence of float or None
            diag(P) in the EKF's state order (x, y, yaw[, vx, vy, vyaw[, ax]]): the
            first three fill the pose covariance, the next three the twist covariance;
            None leaves both 0 (unknown).

        Raises
        ------
        ValueError
            ``p_diag`` has fewer than 3 values, or 4 or 5.
        """
        p = [0.0] * 6
        if p_diag is not None:
            p = [float(v) for v in p_diag]
            if len(p) < 3 or 3 < len(p) < 6:
                raise ValueError(f"p_diag needs 3 or at least 6 values, got {len(p)}")
            p = [*p, 0.0, 0.0, 0.0][:6]
        b = self.builder
        pose_cov = planar_covariance(p[0], p[1], 0.0, 0.0, 0.0, p[2])
        twist_cov = planar_covariance(p[3], p[4], 0.0, 0.0, 0.0, p[5])
        self._write(
            "filtered", t_s, b.odometry(t_s, x, y, yaw, (vx, vy, vyaw), pose_cov, twist_cov)
        )
        self._write("tf", t_s, b.odom_tf(t_s, x, y, yaw))

    def joint_states(
        self, t_s: float, angle_l: float, angle_r: float, vel_l: float, vel_r: float
    ) -> None:
        """Wheel rotations on /joint_states (the settings' joint names).

        Parameters
        ----------
        t_s : float
            MCU time of the frame [s].
        angle_l, angle_r : float
            Wheel angles [rad].
        vel_l, vel_r : float
            Wheel speeds [rad/s].
        """
        self._write(
            "joint_states", t_s, self.builder.wheels(t_s, (angle_l, angle_r), (vel_l, vel_r))
        )

    def diagnostics(
        self,
        t_s: float,
        values: Mapping[str, str],
        level: int = 0,
        *,
        name: str = "jackson: host",
        message: str | None = None,
    ) -> None:
        """One status on /diagnostics.

        Parameters
        ----------
        t_s : float
            MCU time [s].
        values : mapping of str to str
            Key-value pairs.
        level : int
            ``DiagnosticStatus`` level: 0 OK, 1 WARN, 2 ERROR, 3 STALE.
        name : str
            The status name.
        message : str or None
            The status message (default: the level's name).

        Raises
        ------
        ValueError
            ``level`` is not 0 to 3.
        """
        if level not in range(len(_LEVEL_TEXT)):
            raise ValueError(f"diagnostic level must be 0 to 3, got {level}")
        b = self.builder
        status = b.status(name, level, _LEVEL_TEXT[level] if message is None else message, **values)
        self._write("diagnostics", t_s, DiagnosticArray(header=b.header(t_s, ""), status=[status]))

    def raw_frame(self, t_s: float, data: bytes) -> None:
        """A received frame's bytes on /jackson/telemetry as ``std_msgs/msg/UInt8MultiArray``.

        Parameters
        ----------
        t_s : float
            MCU time of the frame [s] (or the last known one for non-telemetry frames).
        data : bytes
            The frame, as received.
        """
        self._write("telemetry", t_s, self.builder.raw_frame(data))

    # ---- lifecycle ------------------------------------------------------------------------

    def flush(self) -> None:
        """Write the open chunk and flush the file, so the messages so far survive a kill."""
        if not self._claim():
            return
        try:
            self._flush_chunk()
            self._rotate_if_full()  # split here as the interval's own flush would
        finally:
            self._release()

    def close(self) -> None:
        """Finish the bag: the last chunk, the MCAP summary and ``metadata.yaml``.

        Idempotent. Called while a write is in progress (from a signal handler), it only
        marks the bag and the write in progress closes it when done. If finishing fails the
        file is closed anyway and the error is raised once; :func:`repair_bag` recovers it.

        Raises
        ------
        BagError
            The bag could not be finished (the disk is full, the folder vanished).
        """
        st = self._state
        if st.closed:
            return
        if st.busy:
            st.close_requested = True
            return
        # Claim first, then re-check: a handler that ran between the checks above and the
        # claim has already finished the bag.
        st.busy = True
        if st.closed:
            st.busy = False
            return
        st.closed = True
        st.close_requested = False
        try:
            if not st.static_written and self.settings.publish_tf:
                last = max(st.last_ns.values(), default=0)
                self._write_static(last / NS_PER_S, last)
            self._finish_file()
            _write_metadata(self.path, self._topics, self._done)
        except Exception as exc:
            if self._file is not None:
                self._file.close()
                self._file = None
            raise BagError(f"{self.path}: cannot finish the bag: {exc}") from exc
        finally:
            st.busy = False

    def __enter__(self) -> BagRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- internals ------------------------------------------------------------------------

    def _write(self, key: str, t_s: float, msg: Any) -> None:
        """Serialise ``msg`` and file it under the topic with key ``key`` at ``t_s``."""
        st = self._state
        ns = stamp_ns(t_s)  # refuses a negative or infinite time before anything is written
        if not self._claim():
            return
        try:
            ns = self.builder.clock.ns(t_s)
            if not st.static_written and key != "tf_static" and self.settings.publish_tf:
                self._write_static(t_s, ns)
            self._put(self._names[key], ns, msg)
            if self.flush_interval_ns is not None:
                if st.flushed_ns is None:
                    st.flushed_ns = ns
                elif ns - st.flushed_ns >= self.flush_interval_ns:
                    self._flush_chunk()
                    st.flushed_ns = ns
                    self._rotate_if_full()
        finally:
            self._release()

    def _claim(self) -> bool:
        """Mark a write in progress; False if the bag is closed (or another write is on).

        A signal handler may call :meth:`close` between any two bytecodes of the main thread.
        ``busy`` is set *before* ``closed`` is checked: a close that runs before the claim
        finishes the bag and the check below sees it; one that runs after it only sets
        ``close_requested``, which :meth:`_release` carries out.
        """
        st = self._state
        if st.busy:
            return False
        st.busy = True
        if st.closed or st.close_requested:
            self._release()
            return False
        return True

    def _release(self) -> None:
        """End a write and run a :meth:`close` that a signal handler asked for meanwhile."""
        st = self._state
        st.busy = False
        if st.close_requested and not st.closed:
            self.close()

    def _put(self, topic: str, ns: int, msg: Any) -> None:
        st = self._state
        ns = max(ns, st.last_ns.get(topic, 0))
        st.last_ns[topic] = ns
        data = cdr.serialize(self._store, msg)  # the frame's own types packed directly
        try:
            self._writer.add_message(self._channels[topic], ns, data, ns)
        except OSError as exc:
            raise BagError(f"{self.files[-1]}: cannot write {topic}: {exc}") from exc
        self._counts[topic] = self._counts.get(topic, 0) + 1
        span = self._span_ns
        self._span_ns = (ns, ns) if span is None else (min(span[0], ns), max(span[1], ns))

    def _write_static(self, t_s: float, ns: int) -> None:
        self._state.static_written = True
        self._put(self._names["tf_static"], ns, self.builder.static_tf(t_s))

    def _flush_chunk(self) -> None:
        try:
            self._writer.flush()  # type: ignore[no-untyped-call]  # the open chunk, then the file's buffer
        except OSError as exc:
            raise BagError(f"{self.files[-1]}: cannot write: {exc}") from exc


# ---- metadata, reading and repair -------------------------------------------------------


@dataclass(frozen=True)
class BagTopic:
    """A topic as ``metadata.yaml`` and the MCAP channel describe it.

    Attributes
    ----------
    name : str
        Topic name.
    msgtype : str
        ROS 2 message type, e.g. ``nav_msgs/msg/Odometry``.
    qos : str
        The offered QoS profiles as the channel's YAML text.
    type_hash : str
        RIHS01 hash of the type ('' if unknown).
    msgdef : str
        The ``ros2msg`` definition of the type.
    """

    name: str
    msgtype: str
    qos: str
    type_hash: str
    msgdef: str = ""

    def channel_metadata(self) -> dict[str, str]:
        """The MCAP channel metadata rosbag2 writes."""
        return {"offered_qos_profiles": self.qos, "topic_type_hash": self.type_hash}


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


def _qos_text(qos: Sequence[Qos]) -> str:
    return str(yaml.safe_dump(dump_qos_v9(list(qos)), default_flow_style=False)).strip()


_TYPE_INFO: dict[str, tuple[str, str]] = {}  # msgtype -> (msgdef, RIHS01 hash), Jazzy's


def _type_info(msgtype: str, store: Typestore) -> tuple[str, str]:
    """The message definition and type hash of ``msgtype`` (computed once per process: a bag
    registers every topic when it opens, and each takes milliseconds)."""
    info = _TYPE_INFO.get(msgtype)
    if info is None:
        msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
        info = _TYPE_INFO[msgtype] = (msgdef, store.hash_rihs01(msgtype))
    return info


_QOS_PROFILES: dict[str, list[Any]] = {}  # a topic's QoS text -> its metadata.yaml entries


def _qos_profiles(text: str) -> list[Any]:
    """``offered_qos_profiles`` of ``metadata.yaml`` from a topic's QoS text (parsed once per
    text: ruamel takes milliseconds per topic, and every close writes them all)."""
    if not text:
        return []
    if text not in _QOS_PROFILES:
        _QOS_PROFILES[text] = dump_qos_v9(parse_qos(text))
    return copy.deepcopy(_QOS_PROFILES[text])


_QOS_TEXTS: dict[_TopicSpec, str] = {}  # a topic's offered QoS -> its text
_JAZZY: list[Typestore] = []  # the process's one type store


def _jazzy() -> Typestore:
    """Jazzy's types, one store per process: rosbags builds a type's serializer once per
    store (7 ms for /map's), and a long-running daemon opens a bag at each split of its run
    folders (docs/recording.md)."""
    if not _JAZZY:
        _JAZZY.append(get_typestore(Stores.ROS2_JAZZY))
    return _JAZZY[0]


def _bag_topics(specs: Mapping[str, _TopicSpec], store: Typestore) -> list[BagTopic]:
    out = []
    for name, spec in specs.items():
        msgdef, type_hash = _type_info(spec.msgtype, store)
        # the QoS text once per process too: yaml takes 2 ms a topic, and a long-running
        # daemon opens a bag at each split of its run folders (docs/recording.md)
        qos = _QOS_TEXTS.get(spec)
        if qos is None:
            qos = _QOS_TEXTS[spec] = _qos_text([_qos(spec)])
        out.append(BagTopic(name, spec.msgtype, qos, type_hash, msgdef))
    return out


def _fsync_replace(tmp: Path, dst: Path) -> None:
    """``os.replace`` a written, fsynced ``tmp`` onto ``dst`` and make the rename durable."""
    os.replace(tmp, dst)
    fd = os.open(dst.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _write_metadata(folder: Path, topics: Sequence[BagTopic], files: Sequence[BagFile]) -> None:
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
    _fsync_replace(tmp, folder / "metadata.yaml")


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
        The folder is not a readable bag (e.g. never closed: see :func:`repair_bag`).
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


def _split_index(file: Path) -> tuple[int, str]:
    """Sort key of a bag's files: ``bag_2.mcap`` before ``bag_10.mcap``."""
    _, _, k = file.stem.rpartition("_")
    return (int(k) if k.isdigit() else -1, file.name)


# what the mcap readers raise where a file ends inside a record or holds garbage
_CUT = (McapError, EOFError, ValueError, struct.error, RuntimeError)
# and what a damaged compressed chunk raises when it is opened (lz4's errors are RuntimeErrors)
_DAMAGED_CHUNK = (*_CUT, ZstdError)


def whole_records(file: Path) -> Iterator[object]:
    """Every whole record of ``file`` in order, chunks opened, read with the mcap library's
    stream reader: it stops at the first record cut by the kill; a chunk that is whole but
    damaged (a power loss can leave zeros where data should be) fails its CRC, or its
    decompression, and is skipped.

    Raises
    ------
    BagError
        The file does not start with the MCAP magic.
    """
    with file.open("rb") as f:
        records = StreamReader(f, emit_chunks=True, record_size_limit=1 << 30).records
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            except InvalidMagic as exc:
                raise BagError(f"{file}: not an MCAP file") from exc
            except _CUT:
                return  # the end of what reached the disk (a cut magic: nothing)
            if isinstance(record, McapChunk):
                try:
                    yield from breakup_chunk(record, validate_crc=True)
                except _DAMAGED_CHUNK:
                    continue
            else:
                yield record


def _summary(file: Path) -> Summary | None:
    """The summary of a finished MCAP file (its footer points at one with statistics)."""
    try:
        with file.open("rb") as f:
            summary = SeekingReader(f, record_size_limit=1 << 30).get_summary()
    except (*_CUT, OSError):
        return None
    return summary if summary is not None and summary.statistics is not None else None


def _topic(channel: McapChannel, schema: McapSchema | None) -> BagTopic:
    return BagTopic(
        channel.topic,
        schema.name if schema is not None else "",
        channel.metadata.get("offered_qos_profiles", ""),
        channel.metadata.get("topic_type_hash", ""),
        schema.data.decode(errors="replace") if schema is not None else "",
    )


def _finished_file(file: Path, summary: Summary) -> tuple[BagFile, list[BagTopic]]:
    stats = summary.statistics
    assert stats is not None
    counts: dict[str, int] = {}
    topics = []
    for cid, channel in summary.channels.items():
        topics.append(_topic(channel, summary.schemas.get(channel.schema_id)))
        counts[channel.topic] = counts.get(channel.topic, 0) + stats.channel_message_counts.get(
            cid, 0
        )
    n = stats.message_count
    span = (stats.message_start_time, stats.message_end_time) if n else (0, 0)
    return BagFile(file.name, counts, *span), topics


def _repair_file(file: Path) -> tuple[BagFile, list[BagTopic]]:
    """Rewrite an unfinished MCAP file with the messages of its whole records and a summary,
    written beside it and moved over it (``os.replace``) only when complete."""
    tmp = file.with_name(f"{file.name}.repair")
    try:
        with tmp.open("wb") as f:
            found = _rewrite(whole_records(file), f)
            f.flush()
            os.fsync(f.fileno())
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_replace(tmp, file)
    counts, span, topics = found
    return BagFile(file.name, counts, *span), topics


def _rewrite(
    records: Iterable[object], out: BinaryIO
) -> tuple[dict[str, int], tuple[int, int], list[BagTopic]]:
    """Copy schemas, channels and messages to ``out`` as a finished MCAP file, one record at
    a time; the messages per topic, their span ((0, 0) without any) and the topics kept."""
    writer = McapFileWriter(out, compression=CompressionType.ZSTD)
    writer.start(profile="ros2", library="jackson")
    schemas: dict[int, tuple[int, McapSchema]] = {}  # old id -> new id, record
    channels: dict[int, tuple[int, str]] = {}  # old id -> new id, topic
    topics = []
    counts: dict[str, int] = {}
    start, end = 2**64, -1
    for r in records:
        if isinstance(r, McapSchema) and r.id not in schemas:
            schemas[r.id] = (writer.register_schema(r.name, r.encoding, r.data), r)
        elif isinstance(r, McapChannel) and r.id not in channels:
            if r.schema_id and r.schema_id not in schemas:
                continue  # its type was cut off: its messages cannot be decoded
            new_sid, schema = schemas[r.schema_id] if r.schema_id else (0, None)
            new_cid = writer.register_channel(r.topic, r.message_encoding, new_sid, r.metadata)
            channels[r.id] = (new_cid, r.topic)
            topics.append(_topic(r, schema))
        elif isinstance(r, McapMessage) and r.channel_id in channels:
            cid, topic = channels[r.channel_id]
            writer.add_message(cid, r.log_time, r.data, r.publish_time, r.sequence)
            counts[topic] = counts.get(topic, 0) + 1
            start, end = min(start, r.log_time), max(end, r.log_time)
    writer.finish()  # type: ignore[no-untyped-call]
    return counts, ((start, end) if counts else (0, 0)), topics


def repair_bag(path: Path | str) -> int:
    """Make a bag whose writer died before :meth:`BagRecorder.close` readable (like ``ros2 bag
    reindex``).

    Every file of the bag that has no summary (the one open when the writer died) is rewritten
    with the messages of its records that reached the disk whole (chunks are written every
    ``flush_interval_s`` of message time), same topics, types, offered QoS and timestamps; the
    rewrite goes beside the file and replaces it (``os.replace``) only when complete, so a
    failure leaves the original's bytes. Finished files are kept as they are. Then
    ``metadata.yaml`` lists them all. A bag that already has ``metadata.yaml`` is left alone.

    Parameters
    ----------
    path : Path or str
        The bag folder.

    Returns
    -------
    int
        The number of messages in the (repaired) bag.

    Raises
    ------
    BagError
        The folder holds no MCAP file, or one that is not MCAP.
    """
    path = Path(path)
    if (path / "metadata.yaml").exists():
        return bag_info(path).message_count
    files = sorted(path.glob("*.mcap"), key=_split_index)
    if not files:
        raise BagError(f"{path}: no .mcap file to repair")
    done: list[BagFile] = []
    topics: dict[tuple[str, str], BagTopic] = {}
    for file in files:
        summary = _summary(file)
        try:
            info, found = (
                _finished_file(file, summary) if summary is not None else _repair_file(file)
            )
        except OSError as exc:
            raise BagError(f"{file}: cannot repair: {exc}") from exc
        done.append(info)
        for t in found:
            topics.setdefault((t.name, t.msgtype), t)
    try:
        _write_metadata(path, list(topics.values()), done)
    except OSError as exc:
        raise BagError(f"{path}: cannot write metadata.yaml: {exc}") from exc
    return sum(f.message_count for f in done)


def repair_run(run: Path | str) -> list[tuple[Path, int]]:
    """Repair every unfinished bag folder of a run folder; ``(folder, messages)`` of each."""
    return [(p, repair_bag(p)) for p in bag_folders(run) if needs_repair(p)]
