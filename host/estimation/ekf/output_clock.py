"""When the EKF's estimate is published: robot_localization's ``frequency`` on MCU time."""

from __future__ import annotations

import math


class OutputClock:
    """The instants of the filter's outputs: every ``1 / frequency_hz`` of MCU time (30 Hz, as
    robot_localization's ``frequency``), from the first multiple of the period at or after the
    first frame, prediction only between measurements.

    Parameters
    ----------
    frequency_hz : float
        Output rate [Hz].
    """

    def __init__(self, frequency_hz: float) -> None:
        self.frequency_hz = frequency_hz
        self._next_s: float | None = None

    def due(self, t_s: float) -> list[float]:
        """The output instants up to a frame at ``t_s`` [s] not yet given, in order."""
        period = 1.0 / self.frequency_hz
        if self._next_s is None:
            self._next_s = math.ceil(t_s / period) * period
        out = []
        while self._next_s <= t_s + 1e-9:
            out.append(self._next_s)
            self._next_s += period
        return out
