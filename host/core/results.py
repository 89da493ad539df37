"""What the host's core hands on: one :class:`FrameResult` per telemetry frame, to every
:class:`CoreListener` (the run folder, the rosbag2, the ROS bridge, a bench's clock).

Listeners receive results, never the core itself, so a listener depends on this module alone
and cannot reach into the core's stages.
"""

from __future__ import annotations

from dataclasses import dataclass

from jackson.host.control.base import Mission
from jackson.host.estimation.ekf import EkfState
from jackson.host.estimation.odometry import OdometryState
from jackson.host.health import Transition, Verdict
from jackson.host.nav.types import Scan
from jackson.protocol import Frame, Telemetry


@dataclass(frozen=True)
class FrameResult:
    """What the core made of one telemetry frame, handed to every listener.

    Attributes
    ----------
    t_s : float
        The frame's unwrapped MCU time [s].
    telemetry : Telemetry
        The frame.
    odometry : OdometryState
        Wheel odometry after the frame.
    v_cmd, w_cmd : float
        The command before the limits [m/s, rad/s].
    v, w : float
        The command after the limits (0 when braked).
    duties : tuple of float
        The wheel duties sent to the motor output (0 when braked).
    braked : bool
        The motors were braked at this frame.
    frame : int
        Telemetry frames handled so far, this one included.
    verdict : Verdict or None
        The health monitor's verdict at this frame (None: the monitor is off).
    mission : Mission or None
        The mission in force (None: external commands), for listeners that publish its state.
    """

    t_s: float
    telemetry: Telemetry
    odometry: OdometryState
    v_cmd: float
    w_cmd: float
    v: float
    w: float
    duties: tuple[float, float]
    braked: bool
    frame: int
    verdict: Verdict | None
    mission: Mission | None


class CoreListener:
    """Receives what the core computes (the run folder, the rosbag2, the ROS bridge); no-op
    defaults. Called on the core's thread, in the order the core works."""

    def on_command(self, v_m_s: float, w_rad_s: float, host_time_ns: int) -> None:
        """An external velocity command, taken at the telemetry frame that applies it."""

    def on_frame(self, frame: Frame, host_time_ns: int) -> None:
        """Every frame received, before it is handled."""

    def on_request(self, data: bytes, host_time_ns: int) -> None:
        """A navigation service's request (encoded), before the telemetry frame applying it."""

    def on_settings(self, data: bytes, host_time_ns: int) -> None:
        """Live settings (:meth:`~jackson.host.core.settings.LiveSettings.encode`), before the
        telemetry frame applying them."""

    def on_event(self, host_time_ns: int, text: str) -> None:
        """Something the operator should know (an MCU reset, an abort)."""

    def on_filtered(self, t_s: float, state: EkfState) -> None:
        """Each 30 Hz EKF output."""

    def on_lidar(self, data: bytes, host_time_ns: int) -> None:
        """Raw bytes from the LiDAR's port, as read (before the frame they preceded)."""

    def on_scan(self, scan: Scan) -> None:
        """A LiDAR revolution, stamped with the MCU time of the frame it arrived before."""

    def on_result(self, result: FrameResult) -> None:
        """After a telemetry frame was handled (odometry, EKF, command are current)."""

    def on_health(self, transition: Transition) -> None:
        """A sensor changed its health state (before the frame's :meth:`on_result`)."""
