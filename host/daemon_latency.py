"""How long the daemon takes to answer a telemetry frame: from the moment its bytes were read
from the port to the moment the frame's HEARTBEAT was written, after the motor command (the
PCA9685 block write or MOTOR_PWM) that the frame produced.

This is the figure a busy machine stretches: the CPU a frame costs stays the same, but the
frame waits for a core behind other work. The MCU drives on the last command until the next
one, so a latency near the 50 ms telemetry period means the wheels run one frame behind, and
one near the MCU's failsafe trips it. The latencies go into a histogram of fixed size (like
:class:`jackson.host.cpu.CpuMeter`'s), so the meter's memory stays flat however long the daemon
runs; they are reported in health.json (``latency``) and ``jackson status``, never in the run's
recorded outputs, which a replay reproduces bit for bit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

BINS_PER_DECADE = 50  # the histogram's resolution: 4.7 % of a value
LOWEST_US = 1.0  # [us] the first bin's lower edge
DECADES = 7  # [us] up to 10 s


class LatencyMeter:
    """The distribution of telemetry-to-command latency, one value per telemetry frame.

    :meth:`arrived` is called with the frame's receive time before the frame is handled,
    :meth:`written` after each HEARTBEAT is written; the first HEARTBEAT after an arrival
    closes it (a HEARTBEAT without a pending frame, e.g. at shutdown, is not counted).

    Attributes
    ----------
    frames : int
        Frames measured.
    max_us : float
        The longest latency [us].
    """

    def __init__(self) -> None:
        self._counts = np.zeros(BINS_PER_DECADE * DECADES + 1, dtype=np.int64)
        self.frames = 0
        self.max_us = 0.0
        self._pending_ns: int | None = None

    def arrived(self, rx_ns: int) -> None:
        """A telemetry frame read from the port at ``rx_ns`` (time.monotonic_ns)."""
        self._pending_ns = rx_ns

    def written(self, now_ns: int) -> None:
        """A HEARTBEAT written at ``now_ns``: the pending frame's latency, if any."""
        if self._pending_ns is None:
            return
        self.add((now_ns - self._pending_ns) / 1e3)
        self._pending_ns = None

    def add(self, latency_us: float) -> None:
        """One frame's latency [us]."""
        self.frames += 1
        self.max_us = max(self.max_us, latency_us)
        k = math.floor(math.log10(max(latency_us, LOWEST_US) / LOWEST_US) * BINS_PER_DECADE)
        self._counts[min(k, len(self._counts) - 1)] += 1

    def percentile_us(self, q: float) -> float:
        """The ``q`` quantile (0-1) [us]: the upper edge of its bin (at most :attr:`max_us`);
        0 before any frame."""
        if self.frames == 0:
            return 0.0
        k = int(np.searchsorted(np.cumsum(self._counts), q * self.frames, side="left"))
        return min(LOWEST_US * math.pow(10.0, (k + 1) / BINS_PER_DECADE), self.max_us)

    def report(self, period_s: float) -> dict[str, Any]:
        """health.json's ``latency`` entry: median, p99 and max [us] and each as a share of
        the telemetry period ``period_s``."""
        us = {
            "median": self.percentile_us(0.5),
            "p99": self.percentile_us(0.99),
            "max": self.max_us,
        }
        return {
            "frames": self.frames,
            "us": us,
            "share_of_period": {name: value * 1e-6 / period_s for name, value in us.items()},
        }
