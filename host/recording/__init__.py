"""Run folders: everything the host received and sent, and what it computed.

A run folder holds

- ``log.jrec``: every frame received from the MCU (with the host's receive time), every frame
  sent, and every external velocity command, in order, so ``jackson replay RUN`` can feed the
  run back through the host offline;
- ``odometry.csv`` (one row per telemetry frame) and ``ekf.csv`` (30 Hz of MCU time): the
  outputs, floats written with ``repr`` so a replay can be compared bit for bit;
- ``health.csv`` (one row per telemetry frame): the sensor health monitor's yaw-rate NIS,
  windowed test, learned wheel yaw model (scale, yaw per metre), each sensor's state, the
  standstill flag and the last LiDAR scan's estimated range noise;
- ``meta.json``: mission, configuration file, start time, versions; for a folder of a split
  recording (a long-running daemon, :mod:`jackson.host.recording.split`), ``previous``,
  ``next``, ``split`` (why and where it began) and ``snapshot``;
- ``core.snapshot`` (a split's folder): the daemon's core pickled between the two frames of
  the split, which the folder's replay starts from (:mod:`jackson.host.recording.snapshot`).

docs/recording.md says when folders split, what the snapshot holds and how the recording folder
is kept under its disk budget (:mod:`jackson.host.recording.budget`).

``log.jrec`` is a little-endian binary file: the 8-byte magic ``b"JREC0001"``, then records of
``u8 kind, u64 host_time_ns, u16 length, payload``. Kinds: 1 frame received (payload: TYPE, SEQ,
then the frame's payload), 2 frame sent (the whole frame as written), 3 velocity command
(payload: two f64, v [m/s] and w [rad/s]), 4 link event (payload: UTF-8 text), 5 end of run
(empty payload; written by a clean close, so a log without it was cut by a kill or power loss),
6 LiDAR bytes (payload: bytes as read from the RPLIDAR's port, at most 65535 per record; they
precede the telemetry frame whose MCU time stamps the scans they complete), 7 a navigation
service's request (payload: UTF-8 JSON ``{"kind", "id", "x", "y", "yaw", "source"}``, kind
``goal``, ``cancel`` or ``pose``; it precedes the telemetry frame that applies it), 8 live
settings (payload: UTF-8 JSON ``{"limits": {...}, "cmd_vel_timeout_s"}``, older logs ``watchdog_s``,
:class:`~jackson.host.core.settings.LiveSettings`; it precedes the telemetry frame that applies
them).
"""

from __future__ import annotations

import csv
import fcntl
import json
import os
import struct
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from jackson.common.errors import JacksonError

MAGIC = b"JREC0001"
KIND_RX = 1
KIND_TX = 2
KIND_CMD = 3
KIND_LINK = 4
KIND_END = 5
KIND_LIDAR = 6
KIND_REQUEST = 7
KIND_SETTINGS = 8
KINDS = (KIND_RX, KIND_TX, KIND_CMD, KIND_LINK, KIND_END, KIND_LIDAR, KIND_REQUEST, KIND_SETTINGS)
MAX_PAYLOAD = 0xFFFF
_HEADER = struct.Struct("<BQH")
_CMD = struct.Struct("<dd")

ODOMETRY_COLUMNS = ("t_s", "x_m", "y_m", "yaw_rad", "v_m_s", "w_rad_s", "enc_left", "enc_right")
EKF_COLUMNS = (
    "t_s",
    "x_m",
    "y_m",
    "yaw_rad",
    "vx_m_s",
    "vy_m_s",
    "vyaw_rad_s",
    "ax_m_s2",
    "p_xx",
    "p_yy",
    "p_yawyaw",
    "p_xy",
    "p_xyaw",
    "p_yyaw",
)
FLUSH_PERIOD_S = 1.0  # [s] of MCU time between flushes of the whole run folder (and its bag)
BUFFER_BYTES = 4 << 20  # [B] per file: never filled between two flushes, so never auto-flushed
COMMAND_COLUMNS = ("t_s", "v_cmd", "w_cmd", "duty_left", "duty_right", "braked")
HEALTH_COLUMNS = (
    "t_s",
    "nis_yaw_rate",
    "window_z2",
    "wheel_yaw_scale",
    "wheel_yaw_per_m",
    "imu",
    "encoder_left",
    "encoder_right",
    "link",
    "lidar",
    "stationary",
    "lidar_roughness_m",
)


RECORDED = frozenset(
    {
        "log.jrec",
        "meta.json",
        "health.json",
        "odometry.csv",
        "ekf.csv",
        "commands.csv",
        "health.csv",
    }
)
"""The files of a run folder its recording writes (and the daemon's health.json); the others
(config.yaml, the map) are the caller's."""


class RecordingError(JacksonError, ValueError):
    """A run folder is missing or damaged."""


@dataclass(frozen=True)
class LogRecord:
    kind: int
    host_time_ns: int
    payload: bytes


def _fmt(row: tuple[Any, ...]) -> list[str]:
    return [repr(v) if isinstance(v, float) else str(v) for v in row]


class RunRecorder:
    """Writes one run folder. All files are flushed together at a telemetry frame's end, once
    per :data:`FLUSH_PERIOD_S` of MCU time (:meth:`frame_done`), with whatever else holds the
    run (:attr:`flush_with`: the daemon's bag): a killed daemon leaves files that agree with
    each other up to the last flushed frame (the bag up to the frame before it), at most a
    second of MCU time before the kill, whatever the pace (lockstep or real time)."""

    def __init__(self, folder: Path, meta: dict[str, Any]) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        self.meta = dict(meta)  # meta.json (a split adds ``next`` to it: write_meta())
        self.write_meta()
        self._log: IO[bytes] = open(folder / "log.jrec", "wb", buffering=BUFFER_BYTES)  # noqa: SIM115 - closed in close()
        # held while recording, released by the kernel when the process ends however it ends:
        # what tells a live run from a killed one (run_in_progress)
        fcntl.flock(self._log.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        self._log.write(MAGIC)
        self._files: list[IO[str]] = []
        self.odometry = self._csv("odometry.csv", ODOMETRY_COLUMNS)
        self.ekf = self._csv("ekf.csv", EKF_COLUMNS)
        self.commands = self._csv("commands.csv", COMMAND_COLUMNS)
        self.health = self._csv("health.csv", HEALTH_COLUMNS)
        self._flushed_s: float | None = None  # MCU time of the last flush
        self.flush_with: list[Any] = []  # flushed together with the files (the bag)

    def write_meta(self) -> None:
        """Write :attr:`meta` to ``meta.json``, whole or not at all."""
        write_json(self.folder / "meta.json", self.meta)

    def _csv(self, name: str, columns: tuple[str, ...]) -> Any:
        f = open(self.folder / name, "w", newline="", encoding="utf-8", buffering=BUFFER_BYTES)  # noqa: SIM115
        self._files.append(f)
        w = csv.writer(f)
        w.writerow(columns)
        return w

    def record(self, kind: int, host_time_ns: int, payload: bytes) -> None:
        self._log.write(_HEADER.pack(kind, host_time_ns, len(payload)) + payload)

    def rx(self, host_time_ns: int, ftype: int, seq: int, payload: bytes) -> None:
        self.record(KIND_RX, host_time_ns, bytes((ftype, seq)) + payload)

    def tx(self, host_time_ns: int, frame: bytes) -> None:
        self.record(KIND_TX, host_time_ns, frame)

    def command(self, host_time_ns: int, v: float, w: float) -> None:
        self.record(KIND_CMD, host_time_ns, _CMD.pack(v, w))

    def link(self, host_time_ns: int, text: str) -> None:
        self.record(KIND_LINK, host_time_ns, text.encode())

    def request(self, host_time_ns: int, data: bytes) -> None:
        self.record(KIND_REQUEST, host_time_ns, data)

    def settings(self, host_time_ns: int, data: bytes) -> None:
        self.record(KIND_SETTINGS, host_time_ns, data)

    def lidar(self, host_time_ns: int, data: bytes) -> None:
        for pos in range(0, len(data), MAX_PAYLOAD):
            self.record(KIND_LIDAR, host_time_ns, data[pos : pos + MAX_PAYLOAD])

    def row(self, writer: Any, values: tuple[Any, ...]) -> None:
        # the csv module writes a float as its repr and anything else but None as its str:
        # _fmt's text without a list made per row (a numpy float64 as a plain number, where
        # _fmt's repr would name its type); None is written "None", as before
        writer.writerow(values if None not in values else _fmt(values))

    def frame_done(self, t_s: float) -> None:
        """Every row of the telemetry frame of MCU time ``t_s`` is written: flush all files
        together once per :data:`FLUSH_PERIOD_S` of MCU time, so a killed run's files end at
        the same frame."""
        if self._flushed_s is None or not 0.0 <= t_s - self._flushed_s < FLUSH_PERIOD_S:
            self._flushed_s = t_s  # (a clock that went back, an MCU reset: flush and restart)
            self.flush()

    def flush(self) -> None:
        self._log.flush()
        for f in self._files:
            f.flush()
        for other in self.flush_with:
            other.flush()

    def close(self) -> None:
        self.record(KIND_END, time.monotonic_ns(), b"")
        self.flush()
        self._log.close()
        for f in self._files:
            f.close()


def write_json(path: Path, doc: Any) -> None:
    """``doc`` as indented JSON in ``path``, replacing it whole (a kill leaves the old one)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def run_in_progress(folder: Path) -> bool:
    """True while a recorder (of any process) is writing ``folder``: it holds the lock on its
    ``log.jrec``. A killed run's lock is gone, so its folder can be repaired."""
    try:
        fd = os.open(folder / "log.jrec", os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # and with it the shared lock just taken
    return False


def read_log(folder: Path) -> Iterator[LogRecord]:
    """The records of ``folder/log.jrec``; a truncated last record (a killed run) is ignored."""
    path = folder / "log.jrec"
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read it ({exc.strerror})") from exc
    if not data.startswith(MAGIC):
        raise RecordingError(f"{path}: not a jackson run log (bad magic)")
    pos = len(MAGIC)
    while pos + _HEADER.size <= len(data):
        kind, t_ns, n = _HEADER.unpack_from(data, pos)
        pos += _HEADER.size
        if pos + n > len(data):
            break
        yield LogRecord(kind, t_ns, data[pos : pos + n])
        pos += n


def unpack_command(payload: bytes) -> tuple[float, float]:
    v, w = _CMD.unpack(payload)
    return float(v), float(w)
