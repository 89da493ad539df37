"""The gyro's z bias, estimated while the robot stands still at start-up."""

from __future__ import annotations

import math

from jackson.host.estimation.ekf.model import TIME_EPSILON_S


class GyroBiasEstimator:
    """The gyro z bias, averaged while the robot stands still at start-up.

    Samples are averaged while ``standing_still`` holds (both wheel velocities zero); the
    estimate is ready once the window spans at least ``window_s`` of MCU time and holds at
    least ``min_samples`` samples, and is frozen from then on. Motion (or time running
    backwards) before that restarts the window. The daemon subtracts :attr:`bias_rad_s` from
    the gyro rate before :meth:`~jackson.host.estimation.ekf.Ekf.update_gyro`.

    Parameters
    ----------
    window_s : float
        Standstill needed [s] (default 2 s: 41 frames at 20 Hz); 0 switches the estimate
        off (the bias is 0 from the start).
    min_samples : int
        Fewest samples averaged.
    """

    def __init__(self, window_s: float = 2.0, min_samples: int = 20) -> None:
        if not 0.0 <= window_s < math.inf:
            raise ValueError(f"window_s must be finite and >= 0, got {window_s}")
        if min_samples < 1:
            raise ValueError(f"min_samples must be >= 1, got {min_samples}")
        self.window_s = window_s
        self.min_samples = min_samples
        self.reset()

    def reset(self) -> None:
        """Drop the samples and any estimate."""
        self._samples: list[float] = []
        self._t_first_s = 0.0
        self._t_last_s = 0.0
        self._bias_rad_s: float | None = 0.0 if self.window_s == 0.0 else None

    @property
    def bias_rad_s(self) -> float | None:
        """The mean gyro z rate over the still window [rad/s]; None until ready."""
        return self._bias_rad_s

    @property
    def ready(self) -> bool:
        return self._bias_rad_s is not None

    @property
    def sample_count(self) -> int:
        """Samples in the current window."""
        return len(self._samples)

    def add(self, t_s: float, wz: float, standing_still: bool) -> None:
        """Offer one gyro z sample [rad/s] taken at MCU time t_s [s]."""
        if self._bias_rad_s is not None:
            return
        if not math.isfinite(wz):
            return
        if not standing_still:
            self._samples.clear()
            return
        if self._samples and t_s < self._t_last_s:
            self._samples.clear()
        if not self._samples:
            self._t_first_s = t_s
        self._samples.append(wz)
        self._t_last_s = t_s
        span_s = t_s - self._t_first_s
        if len(self._samples) >= self.min_samples and span_s >= self.window_s - TIME_EPSILON_S:
            self._bias_rad_s = math.fsum(self._samples) / len(self._samples)
