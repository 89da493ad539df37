"""Lockstep's view of the host: how long the twin waits for a HEARTBEAT, and when it gives up.

In lockstep the twin emits telemetry frame k and serves the host until its HEARTBEAT
acknowledges frame k. A host that does not answer within ``timeout_s`` of wall time is looked
at (:meth:`~jackson.common.liveness.PeerWatch.busy`): one still using CPU is slow, and is
waited for in lockstep (a busy machine changes nothing the MCU sees); one gone, stopped, idle
or not found does not stop the world: it counts as gone, the twin moves on in real time (from
:attr:`HostWatch.pace_origin`), and the MCU's failsafe sees the silence in simulated time; the
host is back, and lockstep with it, when a new HEARTBEAT arrives.

**Stall.** A twin that waits longer than ``timeout_s`` (campaign trials wait without a limit)
could wait for ever for a host that stopped. How long the host takes says nothing on a busy
machine, so the twin judges it by its liveness (:mod:`jackson.common.liveness`): once it has
waited ``stall_s`` of wall time for one HEARTBEAT, it looks at the host (the processes holding
the other side of its pty, or the host's thread in this process, :attr:`HostWatch.peer`) every
half second. A host that consumed CPU since the last look is working: the wait starts over. The
twin gives up only when the host is gone or stopped, or is alive but did no work and says it
waits too (a host in this process, ``host_waiting``: a frame lost between them), or did no work
for the backstop (:data:`~jackson.common.liveness.BACKSTOP_S`, 60 s). Then
:attr:`HostWatch.stalled` holds one line (``lockstep stalled: the twin waited 10.0 s for the
host's HEARTBEAT after frame N (sim time T s): the host process is stopped``), the run returns,
and the clock never moves again. The link is served once more after the verdict before the
stall counts, so a HEARTBEAT that arrived while this process was kept from running is taken.
With ``host_waiting`` only the time both ends wait counts towards ``stall_s``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

from jackson.common.liveness import PeerWatch, Verdict

REASONS: dict[Verdict, str] = {
    "gone": "the host process is gone",
    "stopped": "the host process is stopped",
    "idle": "the host did no work",
}


@dataclass
class HostWatch:
    """The lockstep's state of the host.

    Attributes
    ----------
    timeout_s : float
        Wall time to wait for one HEARTBEAT before the host is looked at; it counts as gone
        unless it is still working [s].
    stall_s : float or None
        Wall time of waiting for one HEARTBEAT before the twin looks at the host's liveness
        [s] (None: never gives up).
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
    peer : PeerWatch
        The host's liveness, looked at once a wait reaches ``stall_s``.
    tell : callable or None
        Called with one line when the host is judged gone and when it answers again (``jackson
        sim`` prints them on stderr): a twin that went on without its host is never silent.
    """

    timeout_s: float
    stall_s: float | None
    host_waiting: Callable[[], float | None] | None = None
    stalled: str | None = None
    waiting_since: float | None = None
    timeouts: int = 0
    gone: int | None = None
    pace_origin: tuple[float, float] = (0.0, 0.0)
    peer: PeerWatch = field(default_factory=PeerWatch)
    tell: Callable[[str], None] | None = None

    def stalled_for(self, start: float, now: float) -> float | None:
        """How long the lockstep has stood still waiting for the host, since ``start``
        (monotonic s): the wait itself, or with ``host_waiting`` the time both ends have
        waited; None while the host works on a frame (slow, not stalled)."""
        if self.host_waiting is None:
            return now - start
        host = self.host_waiting()
        return None if host is None else now - max(start, host)

    def judge(self, now: float) -> Verdict | Literal["working"] | None:
        """The host's liveness once the wait reached ``stall_s`` (:meth:`PeerWatch.verdict`);
        a host in this process that waits too counts as waiting."""
        return self.peer.verdict(now, peer_waits=self.host_waiting is not None)

    def give_up(self, reason: Verdict, waited_s: float, frame: int, t_s: float) -> None:
        """Stall after ``waited_s`` for the HEARTBEAT of ``frame`` at sim time ``t_s``."""
        self.stalled = (
            f"lockstep stalled: the twin waited {waited_s:.1f} s for the host's HEARTBEAT after "
            f"frame {frame} (sim time {t_s:.2f} s): {REASONS[reason]}"
        )
