"""The host's front end: one telemetry frame in, one frozen :class:`Measurement` out.

Everything the host derives from the MCU's frames before any decision is made, in one place:
the MCU time unwrapped (:class:`~jackson.protocol.TimestampUnwrapper`), frames lost by SEQ, the
counts since the previous frame and since the first, wheel odometry (Eq. 2, 3, 9), the gyro's
yaw rate less the start-up bias (:class:`~jackson.host.estimation.ekf.GyroBiasEstimator`) and the
accelerometer in SI units. An MCU reset (an INFO with another ``boot_id``, protocol/spec.md
§8.6) makes the next frame a new origin for all of them at once: its counts and clock restart,
so that frame measures no motion and no time, and the counts since the first frame go on from
where they were.

:class:`jackson.host.core.HostCore`, the sensor view of ``jackson monitor``
(:class:`jackson.host.monitor.SensorWatch`) and the calibration's run reader
(:func:`jackson.calibration.runs.folders.read_run`) all use it, so the three see the same
numbers from the same frames.
"""

from __future__ import annotations

from dataclasses import dataclass

from jackson.host.config import HostConfig
from jackson.host.estimation.ekf import GyroBiasEstimator
from jackson.host.estimation.odometry import OdometryState, WheelOdometry, tick_delta
from jackson.host.health.types import HealthInput
from jackson.protocol import Info, Telemetry, TelemetryFlags, TimestampUnwrapper
from jackson.protocol.units import accel_m_s2, yaw_rate_rad_s

_IMU_OK = int(TelemetryFlags.IMU_OK)  # a plain int: IntFlag's & builds an enum member


@dataclass(frozen=True)
class Measurement:
    """What one telemetry frame measured.

    Attributes
    ----------
    t_s : float
        MCU time, unwrapped [s].
    telemetry : Telemetry
        The frame as decoded.
    odometry : OdometryState
        Wheel odometry after this frame.
    ticks : tuple of int
        Counts (left, right) since the previous frame (0 at the first frame and at a new
        origin).
    dt_s : float
        MCU time since the previous frame [s] (0 at the first frame and at a new origin).
    counts : tuple of int
        Cumulative counts (left, right): the first frame's, plus every frame's ``ticks`` since.
    lost : int
        Frames missing by SEQ since the previous telemetry frame.
    imu_ok : bool
        The frame carries an IMU sample (IMU_OK).
    raw_wz_rad_s : float or None
        The gyro's yaw rate as measured [rad/s] (None without a sample).
    wz_rad_s : float or None
        The yaw rate less the gyro bias [rad/s] (None without a sample or a known bias).
    accel_m_s2 : tuple of float or None
        The accelerometer (x, y, z) [m/s^2] (None without a sample).
    """

    t_s: float
    telemetry: Telemetry
    odometry: OdometryState
    ticks: tuple[int, int]
    dt_s: float
    counts: tuple[int, int]
    lost: int
    imu_ok: bool
    raw_wz_rad_s: float | None
    wz_rad_s: float | None
    accel_m_s2: tuple[float, float, float] | None

    @property
    def wheel_rad_s(self) -> tuple[float, float]:
        """The wheels' speeds (left, right) from the counts [rad/s]."""
        o = self.odometry
        return o.wheel_velocity_left_rad_s, o.wheel_velocity_right_rad_s

    def health_input(
        self, wheel_cmd_rad_s: tuple[float, float], commanded_still: bool
    ) -> HealthInput:
        """The health monitor's input for this frame, with the command side's two facts.

        Parameters
        ----------
        wheel_cmd_rad_s : tuple of float
            The wheel speeds commanded at the previous frame [rad/s].
        commanded_still : bool
            The robot was commanded to stand still (braked or a zero command).

        Returns
        -------
        HealthInput
        """
        t, a = self.telemetry, self.accel_m_s2
        return HealthInput(
            t_s=self.t_s,
            imu_ok=self.imu_ok,
            imu_raw=(*t.accel, *t.gyro, t.temp),
            wz_rad_s=self.wz_rad_s,
            wheel_rad_s=self.wheel_rad_s,
            ticks=self.ticks,
            dt_s=self.dt_s,
            wheel_cmd_rad_s=wheel_cmd_rad_s,
            commanded_still=commanded_still,
            accel_y_m_s2=a[1] if a is not None else None,
            accel_x_m_s2=a[0] if a is not None else None,
        )


class FrontEnd:
    """Frames in, :class:`Measurement` out (module docstring).

    Parameters
    ----------
    cfg : HostConfig
        The robot's geometry (odometry) and the gyro bias window (``ekf.gyro_bias_window_s``).
    """

    def __init__(self, cfg: HostConfig) -> None:
        self.unwrapper = TimestampUnwrapper()
        self.odometry = WheelOdometry(cfg.robot)
        self.gyro_bias = GyroBiasEstimator(window_s=cfg.ekf.gyro_bias_window_s)
        self.bias_ever_known = False  # a re-measurement later does not undo it
        self.boot_id: int | None = None  # the MCU's, from its INFO
        self.resets = 0  # INFO with another boot_id
        self.frames = 0  # telemetry frames measured
        self.t_s: float | None = None  # the MCU time of the last frame measured
        self._new_origin = False  # the next frame starts a new origin (an MCU reset)
        self._prev: tuple[float, int, int] | None = None  # t_s and raw counts of the last frame
        self._counts: tuple[int, int] | None = None
        self._last_seq: int | None = None
        self._lost = 0  # frames missing by SEQ since the last telemetry frame

    def frame_seq(self, seq: int) -> None:
        """Every frame's SEQ, in order (telemetry and the rest): the gaps count as lost."""
        if self._last_seq is not None:
            self._lost += (seq - self._last_seq - 1) & 0xFF
        self._last_seq = seq

    def link_up(self) -> None:
        """The port was (re)opened: frames sent while nobody read it are not lost on the link,
        so SEQ gaps count again from this session's first frame."""
        self._last_seq = None
        self._lost = 0

    def info(self, msg: Info) -> bool:
        """The MCU's INFO; True when it is an MCU reset (another ``boot_id`` than the last):
        the next telemetry frame is then a new origin, and the lost frames count from the new
        boot's first."""
        reset = self.boot_id is not None and msg.boot_id != self.boot_id
        self.boot_id = msg.boot_id
        if reset:
            self.resets += 1
            self.reanchor()
        return reset

    def reanchor(self) -> None:
        """The MCU's counts and clock restarted: the next frame is a new origin."""
        self._new_origin = True
        self._lost = 0

    def remeasure_bias(self) -> None:
        """Measure the gyro bias again over the next standstill (the health monitor's verdict
        asks: :attr:`~jackson.host.health.Verdict.remeasure_gyro_bias`)."""
        self.gyro_bias.reset()

    def measure(self, t: Telemetry) -> Measurement:
        """One telemetry frame.

        Parameters
        ----------
        t : Telemetry
            The frame (its SEQ already given to :meth:`frame_seq`).

        Returns
        -------
        Measurement
        """
        if self._new_origin:
            self._new_origin = False
            self.unwrapper.reanchor()
            self.odometry.reanchor()
            self._prev = None  # no motion, no time across the reset
        t_s = self.t_s = self.unwrapper.unwrap(t.t_us) / 1e6
        self.frames += 1
        raw = (t.enc_left, t.enc_right)
        if self._prev is None:
            ticks, dt_s = (0, 0), 0.0
        else:
            p_t, p_l, p_r = self._prev
            ticks, dt_s = (tick_delta(p_l, raw[0]), tick_delta(p_r, raw[1])), t_s - p_t
        self._prev = (t_s, raw[0], raw[1])
        c = self._counts
        self._counts = raw if c is None else (c[0] + ticks[0], c[1] + ticks[1])
        odo = self.odometry.update(t_s, t.enc_left, t.enc_right)
        imu_ok = bool(t.flags & _IMU_OK)
        raw_wz = wz = accel = None
        if imu_ok:
            raw_wz = yaw_rate_rad_s(t)
            still = odo.wheel_velocity_left_rad_s == 0 and odo.wheel_velocity_right_rad_s == 0
            self.gyro_bias.add(t_s, raw_wz, still)
            bias = self.gyro_bias.bias_rad_s
            if bias is not None:
                self.bias_ever_known = True
                wz = raw_wz - bias
            accel = accel_m_s2(t)
        lost, self._lost = self._lost, 0
        return Measurement(t_s, t, odo, ticks, dt_s, self._counts, lost, imu_ok, raw_wz, wz, accel)
