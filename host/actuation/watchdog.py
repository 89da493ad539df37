"""The application-level /cmd_vel watchdog: brake when velocity commands stop arriving.

The daemon feeds the watchdog with the MCU time at which each velocity command arrives and
asks it on every 20 Hz control tick whether the command has gone stale; when it has, the
tick commands a brake (zero duty) instead of the last command. Checked once per tick, the
brake therefore starts no later than timeout_s plus one tick (0.60 s + 0.05 s) after the
last command (Table 2: /cmd_vel watchdog 0.60 s).

Time comes in as an argument (MCU seconds): the watchdog never reads a clock.
"""

from __future__ import annotations

import math

COMMAND_TIMEOUT_S = 0.60  # [s] /cmd_vel watchdog (the host YAML's cmd_vel_timeout_s)
TIME_TOLERANCE_S = 1e-9  # [s] float slack so a 0.05 s tick sum that is "0.6" counts as 0.6


class CommandWatchdog:
    """Expires when no command has been fed for ``timeout_s`` (and before the first command).

    The age is compared with a tolerance of :data:`TIME_TOLERANCE_S`, far below the MCU
    clock's 1 us resolution, so a check exactly ``timeout_s`` after the feed expires even
    when the two float times round differently. A check slightly before the last feed
    (less than ``timeout_s``: a command stamped after the tick's time) has age 0; a clock
    that steps back further (a restarted, re-based time) counts as expired until the next
    feed.
    """

    def __init__(self, timeout_s: float = COMMAND_TIMEOUT_S) -> None:
        if not 0.0 < timeout_s < math.inf:
            raise ValueError(f"timeout_s must be finite and > 0, got {timeout_s}")
        self.timeout_s = timeout_s
        self._t_last_s: float | None = None

    def feed(self, t_s: float) -> None:
        """Record that a velocity command arrived at MCU time ``t_s`` [s].

        Raises
        ------
        ValueError
            If ``t_s`` is NaN or infinite.
        """
        if not math.isfinite(t_s):
            raise ValueError(f"non-finite feed time: {t_s}")
        self._t_last_s = t_s

    def age(self, t_s: float) -> float:
        """Seconds since the last command at MCU time ``t_s``.

        Returns
        -------
        float
            t_s - t_last [s]; 0 when ``t_s`` is less than ``timeout_s`` before the last
            command; ``math.inf`` before any command, when ``t_s`` is further back, or when
            ``t_s`` is NaN.
        """
        if self._t_last_s is None or not t_s > self._t_last_s - self.timeout_s:
            return math.inf
        return max(0.0, t_s - self._t_last_s)

    def expired(self, t_s: float) -> bool:
        """True when the command is stale at ``t_s``: age >= timeout_s, or no command yet."""
        return self.age(t_s) >= self.timeout_s - TIME_TOLERANCE_S

    def reset(self) -> None:
        """Forget the last command: expired until the next :meth:`feed`."""
        self._t_last_s = None
