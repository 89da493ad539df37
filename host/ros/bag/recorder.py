"""The run's bag writer: :class:`BagRecorder` files each built message under its topic at
its MCU time, flushes the open chunk every ``flush_interval_s`` of message time and finishes
the bag on :meth:`~BagRecorder.close`, even when a signal handler calls it mid-write (the
package docstring, :mod:`jackson.host.ros.bag`, tells the time base and the crash safety)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from jackson.host.estimation.odometry import OdometryCovariance
from jackson.host.ros import cdr
from jackson.host.ros.bag.errors import BagError
from jackson.host.ros.bag.files import McapFiles
from jackson.host.ros.bag.metadata import write_metadata
from jackson.host.ros.bag.topics import bag_topics, jazzy_store, topic_specs
from jackson.host.ros.builder import DiagnosticArray, MessageBuilder, planar_covariance
from jackson.host.ros.settings import RosSettings
from jackson.host.ros.stamp_clock import NS_PER_S, StampClock

DEFAULT_FLUSH_INTERVAL_S = 1.0  # [s] of message time between chunk flushes

_LEVEL_TEXT = ("OK", "WARN", "ERROR", "STALE")


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


class BagRecorder:
    """Writes a run's ROS 2 topics into a rosbag2 folder with MCAP storage.

    Messages come built (:class:`~jackson.host.ros.messages.MessageBuilder`, the live node's
    builder): :meth:`write` files one under its topic's key. The plain-value methods
    (:meth:`wheel_odom`, :meth:`imu`...) build through the same builder, for tools and tests
    without a core. /tf_static is written once, with the first message, unless it came
    already. See the package docstring for the time base and the crash safety. Usable as a
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
        topic_hz: Mapping[str, float] | None = None,
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
        topic_hz : mapping or None
            At most this many messages per second of MCU time of each topic key named
            (``recording.bag_topic_hz``): :meth:`write` files a message of such a topic only once
            ``1 / rate`` has passed since the last one filed. None or absent keys: every one.

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
        self._periods_s = {key: 1.0 / hz for key, hz in (topic_hz or {}).items() if hz > 0.0}
        self._filed_s: dict[str, float] = {}  # a thinned topic's last filed message [s]
        self._store = jazzy_store()
        self._state = _State()
        specs = topic_specs(self.settings)
        self._names = {key: name for key, (name, _) in specs.items()}
        topics = bag_topics({name: spec for name, spec in specs.values()}, self._store)
        self._files = McapFiles(self.path, topics, compression, max_bytes)
        try:
            self.path.mkdir(parents=True)
        except OSError as exc:
            self._state.closed = True
            what = "exists already" if isinstance(exc, FileExistsError) else str(exc)
            raise BagError(f"{self.path}: cannot create the bag: {what}") from exc
        try:
            self._files.open()
        except BagError:
            self._state.closed = True
            raise

    @property
    def files(self) -> list[Path]:
        """Every MCAP file written, in order (the last one open until :meth:`close`)."""
        return self._files.paths

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
            The topic's key (:data:`~jackson.host.ros.settings.TOPIC_TYPES`).
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

    def wants(self, key: str, t_s: float) -> bool:
        """Whether :meth:`write` would file a message of the topic with key ``key`` at MCU time
        ``t_s`` (not a thinned topic's within its period of the last one filed, nor after
        :meth:`close`)."""
        if self.closed:
            return False
        period_s = self._periods_s.get(key)
        last_s = self._filed_s.get(key)
        return period_s is None or last_s is None or t_s >= last_s + period_s - 1e-9

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
            self._files.flush()
            self._files.rotate_if_full()  # split here as the interval's own flush would
        finally:
            self._release()

    def close(self) -> None:
        """Finish the bag: the last chunk, the MCAP summary and ``metadata.yaml``.

        Idempotent. Called while a write is in progress (from a signal handler), it only
        marks the bag and the write in progress closes it when done. If finishing fails the
        file is closed anyway and the error is raised once;
        :func:`~jackson.host.ros.bag.repair_bag` recovers it.

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
            self._files.finish()
            write_metadata(self.path, self._files.topics, self._files.done)
        except Exception as exc:
            self._files.abandon()
            raise BagError(f"{self.path}: cannot finish the bag: {exc}") from exc
        finally:
            st.busy = False

    def __enter__(self) -> BagRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- internals ------------------------------------------------------------------------

    def _write(self, key: str, t_s: float, msg: Any) -> None:
        """Serialise ``msg`` and file it under the topic with key ``key`` at ``t_s`` (a thinned
        topic's only once its period has passed since the last one filed)."""
        st = self._state
        ns = stamp_ns(t_s)  # refuses a negative or infinite time before anything is written
        if key in self._periods_s:
            if not self.wants(key, t_s):
                return
            self._filed_s[key] = t_s
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
                    self._files.flush()
                    st.flushed_ns = ns
                    self._files.rotate_if_full()
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
        self._files.add(topic, ns, data)

    def _write_static(self, t_s: float, ns: int) -> None:
        self._state.static_written = True
        self._put(self._names["tf_static"], ns, self.builder.static_tf(t_s))
