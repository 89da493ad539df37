"""MCU time to ROS time.

Stamps come from a :class:`StampClock`: MCU time itself (``use_sim_time``: the twin publishes
/clock on MCU time), or MCU time mapped onto the host's system clock (the robot: what a
wall-clock-stamped driver such as sllidar_ros2 stamps its scans with). docs/ros2.md, "Time".
"""

from __future__ import annotations

from collections import deque

NS_PER_S = 1_000_000_000
CLOCK_WINDOW_S = 10.0  # [s] of MCU time over which the least transport delay is found
CLOCK_SLEW = 0.1  # the offset in use moves at most this fraction of the MCU time passed


class StampClock:
    """MCU time to ROS time.

    With ``sim_time`` the stamp is MCU time itself (the twin's /clock is MCU time). Otherwise
    it is MCU time plus an offset onto the host's system clock: the least of
    ``host_receive - mcu`` over the last :data:`CLOCK_WINDOW_S` of MCU time (the transport
    delay only adds, so the least offset is the frame that waited least, and the window
    follows the two clocks' drift). The offset in use moves towards that target by at most
    :data:`CLOCK_SLEW` of the MCU time that passed, so ROS time runs monotonic with MCU time
    (no repeated or reversed stamps) while it settles. :attr:`jitter_s` holds the last
    frames' delays beyond the least one (what a per-frame receive stamp would have carried).

    Parameters
    ----------
    sim_time : bool
        Stamp with MCU time (``use_sim_time``).
    """

    def __init__(self, sim_time: bool) -> None:
        self.sim_time = sim_time
        self._window: deque[tuple[float, int]] = deque()  # (mcu t_s, offset ns), ascending
        self._offset_ns: float | None = None  # in use
        self._at_s = 0.0  # MCU time of the last offset update
        self.jitter_s: deque[float] = deque(maxlen=1000)

    @property
    def offset_s(self) -> float | None:
        """The offset in use, ROS time less MCU time [s] (None before the first frame)."""
        return None if self._offset_ns is None else self._offset_ns / NS_PER_S

    def observe(self, t_s: float, host_ns: int) -> None:
        """A frame of MCU time ``t_s`` received at ``host_ns`` of the host's system clock."""
        if self.sim_time:
            return
        off = host_ns - round(t_s * NS_PER_S)
        w = self._window
        while w and w[-1][1] >= off:  # a monotonic deque: the minimum is at the front
            w.pop()
        w.append((t_s, off))
        while w[0][0] < t_s - CLOCK_WINDOW_S:
            w.popleft()
        target = float(w[0][1])
        if self._offset_ns is None:
            self._offset_ns = target
        else:
            room = CLOCK_SLEW * max(0.0, t_s - self._at_s) * NS_PER_S
            self._offset_ns += min(room, max(-room, target - self._offset_ns))
        self._at_s = max(self._at_s, t_s)
        self.jitter_s.append((off - target) / NS_PER_S)

    @property
    def ready(self) -> bool:
        """Whether MCU time maps onto ROS time yet (always with ``sim_time``)."""
        return self.sim_time or self._offset_ns is not None

    def ns(self, t_s: float) -> int:
        """The ROS time [ns] of MCU time ``t_s`` (0 before the first frame on the robot)."""
        mcu = max(0, round(t_s * NS_PER_S))
        if self.sim_time:
            return mcu
        if self._offset_ns is None:
            return 0
        return mcu + round(self._offset_ns)
