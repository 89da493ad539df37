"""Recorded runs, the shared constants and the error of every procedure."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from jackson.common.errors import JacksonError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

STANDARD_GRAVITY_M_S2 = 9.80665  # 1 g of the datasheet's micro-g (what the paper's digits use)
PAPER_STATIC_GRAVITY_M_S2 = 9.299  # Table 3: the MPU-6050 at rest on the physical robot
PAPER_ACCEL_SCALE = 1.054  # Table 3 quotes x1.054; 9.81 / 9.299 = 1.05495 (truncated there)

GYRO_DENSITY_DEG_S_RT_HZ = 0.005  # MPU-6050 datasheet rate noise spectral density
ACCEL_DENSITY_UG_RT_HZ = 400.0  # MPU-6050 datasheet accelerometer noise density
DLPF_BANDWIDTH_HZ = 21.0  # DLPF_CFG = 4: 21 Hz accelerometer / 20 Hz gyro (Sec. 2.2.4: "21 Hz")
FIRST_ORDER_NOISE_FACTOR = math.pi / 2.0  # noise bandwidth / -3 dB bandwidth of one pole

MOTION_MARGIN_FRAMES = 5  # frames before the first count change that may already be moving
MIN_TRAVEL_TICKS = 50  # a wheel that moved less did not drive (about 1.7 cm at 621 TPR)


MAX_GAP_PERIODS = 3.0  # a run with a longer gap between frames lost frames on the link
MIN_GAP_S = 0.1  # [s] gaps shorter than this are jitter at any telemetry rate


class CalibrationError(JacksonError, ValueError):
    """Recorded data that cannot give the result (one line for the user, naming the run)."""


def check_frames(run: RunData) -> None:
    """Refuse a run whose telemetry has a gap: every procedure fits what the frames show, and
    a link that lost seconds of them (a busy machine, frames of an earlier session) gives a
    wrong fit, not an error, unless it is caught here.

    Frames before the one the first command was written after are of a robot braked at rest
    (the settle time every script starts with) and are not checked: a host slow to take its
    first frames (the twin drops what its port cannot queue) loses only rest.

    Raises
    ------
    CalibrationError
        A gap longer than :data:`MAX_GAP_PERIODS` telemetry periods and :data:`MIN_GAP_S`.
    """
    driven = np.flatnonzero(
        (np.nan_to_num(run.duty_left) != 0) | (np.nan_to_num(run.duty_right) != 0)
    )
    first = int(driven[0]) if len(driven) else 0
    if run.frames - first < 3:
        return
    dt = np.diff(run.t_s[first:])
    period = float(np.median(dt))
    i = int(np.argmax(dt))
    gap, at = float(dt[i]), float(run.t_s[first + i] - run.t_s[0])
    if gap > max(MAX_GAP_PERIODS * period, MIN_GAP_S):
        raise CalibrationError(
            f"run {run.name}: {gap:.2f} s without a frame at {at:.2f} s "
            f"into it ({gap / period - 1:.0f} frames missing): the link lost them; nothing was "
            "written, record it again (a busy machine? another program on the port?)"
        )


def check_start(label: str, t_s: FloatArray, ticks: FloatArray, max_delay_s: float) -> None:
    """Refuse a step whose wheel first moved more than ``max_delay_s`` after its frame.

    A step is timed from the frame its duty was written after, on the MCU's clock. A duty that
    reached the motor later (a late motor command; on the twin, one that went on in real time
    while its host was busy) would be measured as a slow motor, so it is refused instead.

    Parameters
    ----------
    label : str
        The step, for the message.
    t_s : numpy.ndarray
        Frame times from the step's frame on [s].
    ticks : numpy.ndarray
        Counts since that frame, positive in the step's direction.
    max_delay_s : float
        The longest delay a motor of this kind has [s].

    Raises
    ------
    CalibrationError
        The wheel moved, but first later than ``max_delay_s``.
    """
    moved = np.flatnonzero(ticks >= 1)
    if len(moved) == 0 or moved[0] == 0:
        return
    delay = float(t_s[moved[0] - 1])
    if delay > max_delay_s:
        raise CalibrationError(
            f"{label} first moved the wheel {delay:.2f} s after its frame (at most "
            f"{max_delay_s:g} s): a late motor command or a twin that went on without its host; "
            "nothing was written, run it again"
        )


@dataclass(frozen=True)
class RunData:
    """One recorded run, as the calibration reads it (one row per telemetry frame).

    Attributes
    ----------
    name : str
        The run folder's name, for messages.
    t_s : numpy.ndarray
        MCU time of each frame [s] (unwrapped).
    enc_left : numpy.ndarray
        Cumulative left counts, unwrapped to int64 (no 32-bit wrap) [ticks].
    enc_right : numpy.ndarray
        Cumulative right counts [ticks].
    gyro_rad_s : numpy.ndarray
        Gyro rate in the *sensor* frame, shape (n, 3) [rad/s]; a calibration the
        device applied is undone; NaN where the IMU sample is missing or unusable.
    accel_m_s2 : numpy.ndarray
        Specific force in the sensor frame, shape (n, 3) [m/s^2], 1 g = 9.81.
    duty_left : numpy.ndarray
        Signed left duty written after the frame (commands.csv), NaN if unknown.
    duty_right : numpy.ndarray
        Signed right duty written after the frame.
    notes : mapping of str to float
        What the user measured for this run (``calibration.json``), e.g.
        ``measured_distance_m`` or ``true_rotation_rad``.
    """

    name: str
    t_s: FloatArray
    enc_left: IntArray
    enc_right: IntArray
    gyro_rad_s: FloatArray
    accel_m_s2: FloatArray
    duty_left: FloatArray
    duty_right: FloatArray
    notes: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.t_s)
        shapes = {
            "enc_left": self.enc_left.shape,
            "enc_right": self.enc_right.shape,
            "duty_left": self.duty_left.shape,
            "duty_right": self.duty_right.shape,
        }
        for key, shape in shapes.items():
            if shape != (n,):
                raise ValueError(f"RunData.{key}: expected shape ({n},), got {shape}")
        for key, arr in (("gyro_rad_s", self.gyro_rad_s), ("accel_m_s2", self.accel_m_s2)):
            if arr.shape != (n, 3):
                raise ValueError(f"RunData.{key}: expected shape ({n}, 3), got {arr.shape}")

    @property
    def frames(self) -> int:
        return len(self.t_s)

    @property
    def still_frames(self) -> int:
        """Frames at rest before the wheels first move, less a margin of
        :data:`MOTION_MARGIN_FRAMES` (all frames when they never move)."""
        if self.frames == 0:
            return 0
        moving = np.flatnonzero(
            (self.enc_left != self.enc_left[0]) | (self.enc_right != self.enc_right[0])
        )
        return self.frames if len(moving) == 0 else max(0, int(moving[0]) - MOTION_MARGIN_FRAMES)

    @property
    def moved(self) -> bool:
        """Whether either wheel turned during the run (any count changed)."""
        if self.frames == 0:
            return False
        return bool(
            np.any(self.enc_left != self.enc_left[0]) or np.any(self.enc_right != self.enc_right[0])
        )


def wheel_angle_rad(ticks: float | FloatArray, ticks_per_rev: float) -> FloatArray:
    """Wheel rotation of a tick count: dphi = 2 pi N / C_e [rad] (Eq. 9 without r)."""
    return np.asarray(2.0 * math.pi * np.asarray(ticks, dtype=np.float64) / ticks_per_rev)


def wheel_travel_m(ticks: float, ticks_per_rev: float, wheel_radius_m: float) -> float:
    """Wheel travel of a tick count: d_s = 2 pi r N / C_e [m] (Eq. A4)."""
    return 2.0 * math.pi * wheel_radius_m * ticks / ticks_per_rev
