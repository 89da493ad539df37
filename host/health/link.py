"""The link: frames lost on the serial line (by their sequence numbers, or dropped as corrupt).

More than ``link_loss_fraction`` of the frames of the last ``link_window_s`` lost (and at least
two) make the link ``suspect``; below half of it it passes, ``ok`` again after ``recover_s``.
The EKF does not depend on it (counts, not deltas: a lost frame loses no distance); the
operator should know.
"""

from __future__ import annotations

from collections import deque

from jackson.host.health.config import HealthConfig
from jackson.host.health.types import Finding, LinkInput, failing, passing


class LinkCheck:
    """A :class:`~jackson.host.health.check.Check` of received frames (module docstring)."""

    def __init__(self, cfg: HealthConfig) -> None:
        self.cfg = cfg
        self._window: deque[tuple[float, int]] = deque()  # (t, lost before it)
        self._missing = 0  # the sum of the window's lost counts

    def observe(self, x: LinkInput) -> list[Finding]:
        cfg, t_s, window = self.cfg, x.t_s, self._window
        window.append((t_s, x.lost))
        missing = self._missing + x.lost
        while window and window[0][0] <= t_s - cfg.link_window_s + 1e-9:
            missing -= window.popleft()[1]
        self._missing = missing
        total = len(window) + missing
        if missing >= 2 and missing > cfg.link_loss_fraction * total:
            why = f"{missing} of {total} frames lost in {cfg.link_window_s:.0f} s"
            return [failing("link", t_s, why, exclude=False)]
        if missing <= 0.5 * cfg.link_loss_fraction * total:
            return [passing("link", t_s)]
        return []
