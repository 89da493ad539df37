"""systemd's service notifications for the daemon: READY, WATCHDOG and STOPPING.

Under ``Type=notify`` with ``WatchdogSec=`` (deploy/jackson.service) systemd expects the daemon's
main loop to ping it; a daemon that hangs (a deadlock, SIGSTOP, a bus call that never returns)
stops pinging, and systemd kills it with SIGABRT and runs ``ExecStopPost=jackson brake``. The
MCU's interlock has braked the motors 0.6 s after the last heartbeat by then; this is the
second layer, on the Jetson. The datagrams are sent by the ``sdnotify`` package.
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from typing import Protocol

import sdnotify

DEFAULT_PING_S = 0.5  # [s] between pings when systemd gives no WATCHDOG_USEC


class Notifier(Protocol):
    """What the daemon tells its supervisor (:class:`SystemdNotifier` tells systemd)."""

    def ready(self) -> None:
        """Set up: the first INFO arrived."""
        ...

    def watchdog(self) -> None:
        """Alive (called every loop; the notifier paces its pings)."""
        ...

    def stopping(self) -> None:
        """Shutting down."""
        ...


class SystemdNotifier:
    """Sends READY=1, WATCHDOG=1 (at most every ``ping_s``) and STOPPING=1 to ``NOTIFY_SOCKET``.

    Parameters
    ----------
    watchdog_s : float or None
        systemd's watchdog period (``WATCHDOG_USEC``); pings go at a quarter of it,
        so a slow loop turn or a lost datagram does not trip it. None: every DEFAULT_PING_S.
    """

    def __init__(self, watchdog_s: float | None = None) -> None:
        self._notifier = sdnotify.SystemdNotifier()
        self.ping_s = DEFAULT_PING_S if watchdog_s is None else max(0.01, watchdog_s / 4.0)
        self._last_ping = -float("inf")

    def _notify(self, state: str) -> None:
        self._notifier.notify(state)  # never raises: a missing socket is ignored

    def ready(self) -> None:
        self._notify("READY=1")

    def watchdog(self) -> None:
        """Called every loop turn; pings only once per ``ping_s``."""
        now = time.monotonic()
        if now - self._last_ping >= self.ping_s:
            self._last_ping = now
            self._notify("WATCHDOG=1")

    def status(self, text: str) -> None:
        self._notify(f"STATUS={' '.join(text.split())}")

    def stopping(self) -> None:
        self._notify("STOPPING=1")


def watchdog_period_s(environ: Mapping[str, str] | None = None) -> float | None:
    """systemd's watchdog period from ``WATCHDOG_USEC`` (for this process: ``WATCHDOG_PID``)."""
    env = os.environ if environ is None else environ
    usec = env.get("WATCHDOG_USEC", "")
    pid = env.get("WATCHDOG_PID", "")
    if not usec.isdigit() or int(usec) == 0 or (pid.isdigit() and int(pid) != os.getpid()):
        return None
    return int(usec) / 1e6


def notifier_from_env() -> SystemdNotifier | None:
    """A notifier when systemd started this process with ``NOTIFY_SOCKET``, else None.

    Only the process environment counts: the ``sdnotify`` package connects to the
    ``NOTIFY_SOCKET`` it finds there.
    """
    if not os.environ.get("NOTIFY_SOCKET"):
        return None
    return SystemdNotifier(watchdog_period_s())
