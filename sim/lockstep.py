"""Lockstep's view of the host: how long the twin waits for a HEARTBEAT, and when it gives up.

In lockstep the twin emits telemetry frame k and serves the host until its HEARTBEAT
acknowledges frame k. A host that does not answer within ``timeout_s`` of wall time does not
stop the world: it counts as gone, the twin moves on in real time (from :attr:`HostWatch.
pace_origin`), and the MCU's failsafe sees the silence in simulated time; the host is back, and
lockstep with it, when a new HEARTBEAT arrives.

**Stall.** A twin that waits longer than ``timeout_s`` (campaign trials wait without a limit)
can wait for ever for a host that stopped. After ``stall_s`` of wall time waiting for one
HEARTBEAT, its clock standing still, the twin gives up: :attr:`HostWatch.stalled` holds one
line (``lockstep stalled: the twin waited 10.0 s for the host's HEARTBEAT after frame N (sim
time T s)``), the run returns, and the clock never moves again. Only the wait counts: a host
that answers each frame, however late, never stalls it. The link is served once more after the
limit before the stall counts, so a HEARTBEAT that arrived while this process was kept from
running is taken. With ``host_waiting`` (a host in this process) only the time both ends wait
counts: a host that is working on a frame, however slowly (a starved process), is not stalled.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass
class HostWatch:
    """The lockstep's state of the host.

    Attributes
    ----------
    timeout_s : float
        Wall time to wait for one HEARTBEAT before the host counts as gone [s].
    stall_s : float or None
        Wall time of waiting for one HEARTBEAT before the twin gives up [s] (None: never).
    host_waiting : callable or None
        A host in this process: since when it waits for a telemetry frame (monotonic s),
        None while it works on one.
    stalled : str or None
        The stall line, once the twin gave up.
    waiting_since : float or None
        Since when the twin waits for the host's HEARTBEAT (monotonic s), None otherwise; it
        stays set after a stall (the twin will never send again).
    timeouts : int
        Waits that ran out (the host went silent).
    gone : int or None
        The MCU's heartbeat mark when the host went silent; None while it answers.
    pace_origin : tuple of float
        Wall and simulated time [s] the twin runs in real time from, while nobody answers.
    """

    timeout_s: float
    stall_s: float | None
    host_waiting: Callable[[], float | None] | None = None
    stalled: str | None = None
    waiting_since: float | None = None
    timeouts: int = 0
    gone: int | None = None
    pace_origin: tuple[float, float] = (0.0, 0.0)

    def stalled_for(self, start: float, now: float) -> float | None:
        """How long the lockstep has stood still waiting for the host, since ``start``
        (monotonic s): the wait itself, or with ``host_waiting`` the time both ends have
        waited; None while the host works on a frame (slow, not stalled)."""
        if self.host_waiting is None:
            return now - start
        host = self.host_waiting()
        return None if host is None else now - max(start, host)

    def give_up(self, waited_s: float, frame: int, t_s: float) -> None:
        """Stall after ``waited_s`` for the HEARTBEAT of ``frame`` at sim time ``t_s``."""
        self.stalled = (
            f"lockstep stalled: the twin waited {waited_s:.1f} s for the host's HEARTBEAT after "
            f"frame {frame} (sim time {t_s:.2f} s)"
        )
