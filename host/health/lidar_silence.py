"""LiDAR silence: revolutions that do not come.

Per revolution (:meth:`LidarSilence.revolution`), the spacing: the revolutions of the last
``lidar_window_s`` against those its period (learned over the first
:data:`LIDAR_LEARN_SCANS`) says were due; more than ``lidar_loss_fraction`` missing make the
LiDAR ``suspect``. Per telemetry frame (:meth:`LidarSilence.observe`): a LiDAR that scanned and
stopped (dead, unplugged, its motor stalled) is excluded after ``lidar_silence_s``. Sooner,
while a mission navigates by it, no usable scan (silence, garbage, noise) for the time the
robot needs to cover ``lidar_blind_m`` at its speed makes it blind: :attr:`LidarSilence.blind`
holds the robot (braked) until a usable scan comes, without ending the mission.

A silence that began when the daemon itself stopped running (:meth:`LidarSilence.host_stalled`:
the frames that waited meanwhile arrive together, the LiDAR's bytes all with the first) is the
host's, not the LiDAR's: within the stall's reach on MCU time it holds a navigating robot without
a finding, and the LiDAR is excluded only when its silence outlasts that reach by
``lidar_silence_s``.
"""

from __future__ import annotations

import math
from collections import deque

from jackson.host.health.config import HealthConfig
from jackson.host.health.states import SensorStates
from jackson.host.health.types import Finding, LidarFrame, failing
from jackson.protocol.rplidar import A1M8_SCAN_PERIOD_S

LIDAR_LEARN_SCANS = 20  # the revolution period is learned over the first scans
LIDAR_SILENCE_PERIODS = 1.5  # a silence shorter than this many revolutions is the stream's own
# spacing (a revolution every 0.135 s, read at 50 ms frames: gaps of 0.10 and 0.15 s)
# the A1M8's revolution, until the monitor has learned the sensor's own
LIDAR_PERIOD_S = A1M8_SCAN_PERIOD_S


class LidarSilence:
    """A :class:`~jackson.host.health.check.Check` of telemetry frames, and the spacing of the
    revolutions (module docstring).

    Parameters
    ----------
    cfg : HealthConfig
        ``lidar_silence_s``, ``lidar_blind_m``, ``lidar_window_s``, ``lidar_loss_fraction``.
    states : SensorStates
        Read only: why the LiDAR is in its state (said when it blinds the robot).

    Attributes
    ----------
    scans : int
        Revolutions judged (those that are a turn).
    missing : float
        Fraction of revolutions missing over the last full window.
    spacing_ok : bool
        The last revolution's spacing passed (well inside the band: hysteresis).
    period_s : float or None
        The revolution period learned [s].
    blind : bool
        Navigating without a usable scan too long (or on garbage): hold the robot.
    blinds : int
        Times it was blinded by silence.
    """

    # (from, to) MCU time a stall of the daemon reaches (class default: a core pickled before
    # it was known restores without it)
    _host_stall: tuple[float, float] | None = None

    def __init__(self, cfg: HealthConfig, states: SensorStates) -> None:
        self.cfg = cfg
        self.states = states
        self.scans = 0
        self.missing = 0.0
        self.spacing_ok = True
        self.period_s: float | None = None
        self.blind = False
        self.blinds = 0
        self._first_s: float | None = None
        self._last_s: float | None = None
        self._used_s: float | None = None  # the last scan that could be used
        self._window_from = 0.0  # the spacing's window is full from here + window
        self._times: deque[float] = deque()
        self._speed_m_s = 0.0  # the wheels' forward speed at the last frame

    def revolution(self, t_s: float) -> list[Finding]:
        """A revolution came at ``t_s``: the spacing over the last ``lidar_window_s``."""
        cfg = self.cfg
        self.scans += 1
        if self._first_s is None:
            self._first_s = self._window_from = t_s
        last = self._last_s
        if last is not None and t_s - last >= cfg.lidar_silence_s - 1e-9:
            # back after a silence (judged by itself): the spacing is counted afresh
            self._times.clear()
            self._window_from = t_s
        n = self.scans
        if self.period_s is None and n > LIDAR_LEARN_SCANS:
            self.period_s = (t_s - self._first_s) / (n - 1)
        self._last_s = t_s
        self._times.append(t_s)
        while self._times and self._times[0] <= t_s - cfg.lidar_window_s + 1e-9:
            self._times.popleft()
        period = self.period_s
        self.spacing_ok = True
        full = t_s - self._window_from >= cfg.lidar_window_s - 1e-9
        if period is None or period <= 0.0 or not full:
            return []
        expected = cfg.lidar_window_s / period
        self.missing = max(0.0, 1.0 - len(self._times) / expected)
        if self.missing > cfg.lidar_loss_fraction:
            got = len(self._times)
            why = (
                f"{got} revolutions in {cfg.lidar_window_s:.0f} s where {expected:.0f} were "
                f"due ({self.missing:.0%} lost)"
            )
            self.spacing_ok = False
            return [failing("lidar", t_s, why, exclude=False)]
        if self.missing > 0.5 * cfg.lidar_loss_fraction:
            self.spacing_ok = False  # hysteresis: back only well inside
        return []

    def used(self, t_s: float) -> None:
        """A usable scan at ``t_s``: the hold ends."""
        self._used_s = t_s
        self.blind = False

    def host_stalled(self, t_s: float, stalled_s: float) -> None:
        """The daemon did not run for ``stalled_s`` wall seconds after its frame of MCU time
        ``t_s``: a silence beginning from a revolution before it until ``stalled_s`` after it
        is the daemon's (module docstring)."""
        self._host_stall = (t_s - self.revolutions_s(LIDAR_SILENCE_PERIODS), t_s + stalled_s)

    def revolutions_s(self, n: float) -> float:
        """``n`` revolution periods [s] (the learned period, else the A1M8's)."""
        return n * (self.period_s or LIDAR_PERIOD_S)

    def _hosts(self, since: float | None) -> bool:
        """A silence from ``since`` began within the reach of the daemon's stall: its own."""
        stall = self._host_stall
        return stall is not None and since is not None and stall[0] <= since <= stall[1]

    def limit_s(self) -> float:
        """How long the LiDAR may be silent now [s]: ``lidar_silence_s``, shorter while the
        robot drives, so that it covers at most ``lidar_blind_m`` on its last scan (never
        under :data:`LIDAR_SILENCE_PERIODS` revolutions, the stream's own spacing)."""
        cfg = self.cfg
        period = self.period_s or LIDAR_PERIOD_S
        floor = LIDAR_SILENCE_PERIODS * period
        speed = abs(self._speed_m_s)
        blind = cfg.lidar_blind_m / speed if speed > 1e-6 else math.inf
        return max(floor, min(cfg.lidar_silence_s, blind))

    def observe(self, x: LidarFrame) -> list[Finding]:
        t_s = x.t_s
        self._speed_m_s = x.speed_m_s
        last = self._last_s
        # a silence the daemon's stall began counts from the stall's end
        stall = self._host_stall
        counted = stall[1] if stall is not None and self._hosts(last) else last
        if counted is not None and t_s - counted >= self.cfg.lidar_silence_s - 1e-9:
            assert last is not None
            why = f"no scan for {t_s - last:.2f} s (dead, unplugged or its motor stopped)"
            return [failing("lidar", t_s, why, exclude=True)]
        used = self._used_s if self._used_s is not None else last
        if not x.needed or used is None or self.blind:
            return []
        limit = self.limit_s()
        if t_s - used < limit - 1e-9:
            return []
        self.blind = True
        if self._hosts(used):
            return []  # the daemon's stall: held, the LiDAR not blamed (the daemon told it)
        self.blinds += 1
        why = (
            f"no usable scan for {t_s - used:.2f} s at {abs(self._speed_m_s):.2f} m/s: "
            f"braked until one comes ({self.states.reason('lidar') or 'silence'})"
        )
        return [failing("lidar", t_s, why, exclude=False)]
