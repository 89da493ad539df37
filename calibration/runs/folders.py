"""Recorded run folders read back for the procedures: telemetry, duties, notes, references."""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jackson.calibration.procedures import CalibrationError, Reference, RunData
from jackson.common.errors import JacksonError
from jackson.host.config import HostConfig
from jackson.host.core.frontend import FrontEnd
from jackson.host.recording import KIND_END, KIND_RX, KIND_TX, RecordingError, read_log
from jackson.protocol import (
    FrameDecoder,
    Info,
    SetImuCalibration,
    Telemetry,
    TelemetryFlags,
    decode_message,
)
from jackson.protocol.messages import (
    ACCEL_LSB_PER_G,
    GRAVITY_M_S2,
    GYRO_LSB_PER_DPS,
    accel_fs,
    gyro_fs,
)

NOTES_FILE = "calibration.json"
CALIBRATION_SETTLE_FRAMES = 2  # frames after a SET_IMU_CALIBRATION still in flight

_DeviceCalibration = tuple[tuple[float, ...], tuple[float, ...], float]
"""A calibration the device applies: rotation (row-major), gyro bias [rad/s], accel scale."""


class RunError(JacksonError, RuntimeError):
    """A calibration run could not be recorded (link, bus, a robot that does not move)."""


class _DeviceImu:
    """Which calibration the device applied to each frame, as the log tells it.

    INFO states the calibration the device holds at that point of the stream (protocol/spec.md
    §8.2: its fields are the ones applied to frames flagged ``IMU_CALIBRATED``); a
    SET_IMU_CALIBRATION the host sent takes over within :data:`CALIBRATION_SETTLE_FRAMES`
    frames, during which a calibrated frame that follows a calibrated frame may carry the old
    calibration or the new one: unknown, unless both are the same.
    """

    def __init__(self) -> None:
        self.active: _DeviceCalibration | None = None  # None: not known from the log
        self.previous: _DeviceCalibration | None = None
        self.since_set = CALIBRATION_SETTLE_FRAMES + 1
        self.last_calibrated = True  # before the first frame: the device may be calibrated

    def info(self, msg: Info) -> None:
        valid = msg.accel_scale > 0.0 and all(map(math.isfinite, msg.imu_rotation))
        cal = (tuple(msg.imu_rotation), tuple(msg.gyro_bias), msg.accel_scale)
        self.active = cal if valid else None
        self.since_set = CALIBRATION_SETTLE_FRAMES + 1

    def set(self, msg: SetImuCalibration) -> None:
        self.previous = self.active
        self.active = (tuple(msg.imu_rotation), tuple(msg.gyro_bias), msg.accel_scale)
        self.since_set = 0

    def frame(self, calibrated: bool) -> _DeviceCalibration | None:
        """The calibration of the next frame (flagged ``calibrated``): None if unknown."""
        self.since_set += 1
        settling = self.since_set <= CALIBRATION_SETTLE_FRAMES
        ambiguous = settling and self.last_calibrated and self.previous != self.active
        self.last_calibrated = calibrated
        return None if ambiguous else self.active


def _imu_si(t: Telemetry) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]:
    """Gyro [rad/s] and specific force [m/s^2] of a frame at the ranges its flags name."""
    gyro = np.radians(np.array(t.gyro, dtype=np.float64) / GYRO_LSB_PER_DPS[gyro_fs(t.flags)])
    accel = np.array(t.accel, dtype=np.float64) / ACCEL_LSB_PER_G[accel_fs(t.flags)] * GRAVITY_M_S2
    return gyro, accel


def _read_notes(folder: Path) -> dict[str, float]:
    path = folder / NOTES_FILE
    if not path.exists():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise CalibrationError(f"run {folder.name}: {NOTES_FILE} is not readable JSON") from exc
    if not isinstance(data, dict):
        raise CalibrationError(f"run {folder.name}: {NOTES_FILE} is not a JSON object")
    return {
        str(k): float(v)
        for k, v in data.items()
        if isinstance(v, (int, float)) and not isinstance(v, bool)
    }


def _read_duties(folder: Path, t_s: Sequence[float]) -> tuple[list[float], list[float]]:
    """commands.csv duties matched to the frames by their time (NaN where missing)."""
    left = [math.nan] * len(t_s)
    right = [math.nan] * len(t_s)
    path = folder / "commands.csv"
    if not path.exists():
        return left, right
    rows: dict[float, tuple[float, float]] = {}
    try:
        with path.open(newline="", encoding="utf-8") as f:
            for row in csv.DictReader(f):
                rows[float(row["t_s"])] = (float(row["duty_left"]), float(row["duty_right"]))
    except (OSError, KeyError, ValueError) as exc:
        raise CalibrationError(f"run {folder.name}: commands.csv is damaged ({exc})") from exc
    for i, t in enumerate(t_s):
        if t in rows:
            left[i], right[i] = rows[t]
    return left, right


def load_run(folder: str | Path) -> RunData:
    """Read a run folder: telemetry from ``log.jrec``, duties, and the user's measurements.

    Frames the device sent calibrated (``IMU_CALIBRATED``) are turned back into sensor-frame
    values (omega_s = R^T (omega + b), a_s = R^T a / s) with the calibration the device held:
    the one its INFO states (a calibration of an earlier session or from its flash) or the
    SET_IMU_CALIBRATION the host sent since. So a run reads the same whether the device had
    a calibration or not. Only a calibrated frame whose calibration the log cannot tell (the
    few frames while a different calibration takes over) has no IMU values (NaN).

    Parameters
    ----------
    folder : str or Path
        A run folder written by ``jackson daemon`` or by this module.

    Returns
    -------
    RunData
        The run's data.

    Raises
    ------
    CalibrationError
        The folder is missing, not a run, cut short (no end record: a killed recording), or
        holds no telemetry.
    """
    path = Path(folder)
    if not path.is_dir():
        raise CalibrationError(f"run folder {path} does not exist")
    if not (path / "log.jrec").exists():
        raise CalibrationError(f"{path} is not a run folder (no log.jrec)")
    front = FrontEnd(HostConfig())  # the daemon's: MCU time unwrapped, counts across resets
    t_s: list[float] = []
    enc: list[tuple[int, int]] = []
    gyro: list[np.ndarray[Any, Any]] = []
    accel: list[np.ndarray[Any, Any]] = []
    nan3 = np.full(3, np.nan)
    device = _DeviceImu()
    ended = False
    try:
        for rec in read_log(path):
            ended = rec.kind == KIND_END
            if rec.kind == KIND_TX:
                for frame in FrameDecoder().feed(rec.payload):
                    msg = decode_message(frame)
                    if isinstance(msg, SetImuCalibration):
                        device.set(msg)
                continue
            if rec.kind != KIND_RX or len(rec.payload) < 2:
                continue
            if rec.payload[0] == Info.TYPE:
                info = Info.unpack(rec.payload[2:])
                device.info(info)
                front.info(info)
                continue
            if rec.payload[0] != Telemetry.TYPE:
                continue
            t = Telemetry.unpack(rec.payload[2:])
            calibration = device.frame(bool(t.flags & TelemetryFlags.IMU_CALIBRATED))
            m = front.measure(t)
            t_s.append(m.t_s)
            enc.append(m.counts)
            if not t.flags & TelemetryFlags.IMU_OK:
                gyro.append(nan3)
                accel.append(nan3)
                continue
            g, a = _imu_si(t)
            if t.flags & TelemetryFlags.IMU_CALIBRATED:
                if calibration is None:
                    gyro.append(nan3)
                    accel.append(nan3)
                    continue
                rotation, bias, scale = calibration
                r = np.array(rotation, dtype=np.float64).reshape(3, 3)
                g = r.T @ (g + np.array(bias, dtype=np.float64))
                a = r.T @ a / scale
            gyro.append(g)
            accel.append(a)
    except RecordingError as exc:
        raise CalibrationError(str(exc)) from exc
    if not ended:
        # a killed recording (or a file cut short in a copy) holds part of the run: a fit on it
        # would be wrong, not an error (half the travel against the whole tape measurement)
        raise CalibrationError(
            f"run {path.name}: log.jrec ends without its end record (the recording was killed "
            f"or the file cut short, {len(t_s)} frames read): record the run again"
        )
    if not t_s:
        raise CalibrationError(f"run {path.name}: no telemetry frames in log.jrec")
    duty_left, duty_right = _read_duties(path, t_s)
    return RunData(
        name=path.name,
        t_s=np.array(t_s, dtype=np.float64),
        enc_left=np.array([e[0] for e in enc], dtype=np.int64),
        enc_right=np.array([e[1] for e in enc], dtype=np.int64),
        gyro_rad_s=np.array(gyro, dtype=np.float64),
        accel_m_s2=np.array(accel, dtype=np.float64),
        duty_left=np.array(duty_left, dtype=np.float64),
        duty_right=np.array(duty_right, dtype=np.float64),
        notes=_read_notes(path),
    )


def run_boot_ids(folder: str | Path) -> set[int]:
    """The MCU boot_ids the INFO messages in a run's ``log.jrec`` carry (one per boot).

    Raises
    ------
    CalibrationError
        The folder holds no readable log.
    """
    path = Path(folder)
    ids: set[int] = set()
    try:
        for rec in read_log(path):
            if rec.kind == KIND_RX and len(rec.payload) >= 2 and rec.payload[0] == Info.TYPE:
                ids.add(Info.unpack(rec.payload[2:]).boot_id)
    except RecordingError as exc:
        raise CalibrationError(str(exc)) from exc
    return ids


def load_reference(path: str | Path) -> Reference:
    """A reference trajectory: CSV with a header ``t_s,x_m,y_m,yaw_rad`` (MCU clock, metres,
    radians; other columns and lines starting with ``#`` are ignored, so the twin's
    ground-truth file of ``jackson sim --truth`` is one), sorted by time.

    Raises
    ------
    CalibrationError
        Missing file or columns, non-numbers, or fewer than two rows.
    """
    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    except OSError as exc:
        raise CalibrationError(f"reference {p}: cannot read it ({exc.strerror})") from exc
    except (UnicodeDecodeError, csv.Error) as exc:
        raise CalibrationError(f"reference {p}: not a CSV text file ({exc})") from exc
    cols = ("t_s", "x_m", "y_m", "yaw_rad")
    if not rows or any(c not in rows[0] for c in cols):
        raise CalibrationError(f"reference {p}: expected a CSV header with {', '.join(cols)}")
    try:
        data = np.array([[float(r[c]) for c in cols] for r in rows], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CalibrationError(f"reference {p}: not a number ({exc})") from exc
    if not np.all(np.isfinite(data)):
        raise CalibrationError(f"reference {p}: nan or inf among the numbers")
    if len(data) < 2 or np.any(np.diff(data[:, 0]) <= 0):
        raise CalibrationError(f"reference {p}: needs two or more rows with rising t_s")
    return Reference(data[:, 0], data[:, 1], data[:, 2], data[:, 3])


def write_notes(folder: Path, notes: dict[str, Any]) -> None:
    """Store what the user measured for a run in its ``calibration.json``."""
    (folder / NOTES_FILE).write_text(json.dumps(notes, indent=2) + "\n", encoding="utf-8")
