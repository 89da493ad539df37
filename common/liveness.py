"""Whether the other end of a lockstep is alive and working, read from the kernel.

The twin and the host take turns every telemetry frame. How long one waits for the other says
nothing on a busy machine: a process the scheduler keeps from running, or one that spends
seconds on a frame (a host's start-up, a SLAM update), is slow, not stopped. What tells a
stopped end from a slow one is the kernel's view of it (``/proc/PID/stat``, or
``/proc/self/task/TID/stat`` for a thread of this process): a peer whose entry is gone, a
zombie or stopped (state ``T``, ``t``: SIGSTOP, a debugger) is not coming back; a peer whose
CPU time (``utime + stime``) advances by at least :data:`WORK_SHARE` of the wall time between
two looks is working; a peer that is alive but idle (waiting, or blocked outside the
lockstep) is neither.

:class:`PeerWatch` turns these looks into a verdict for an end that has waited long: ``None``
while the peer works (the wait starts over) or a short while has not yet passed, else a reason
(``"gone"``, ``"stopped"``, ``"idle"``). Which processes are the peer is found lazily, anew
for each wait that gets long (:func:`pty_peers`): the processes that hold the other side of the
twin's pty (the host's serial port), which change whenever a new host process opens the port.
Nothing here reads the wall clock for simulated results: it only decides when an end stops
waiting.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

PROBE_S = 0.5  # [s] of wall time between two looks at the peer
WORK_SHARE = 0.04  # CPU time per wall time above which a peer counts as working
BACKSTOP_S = 60.0  # [s] of wall time an alive but idle peer is waited for
_TICK_S = 1.0 / os.sysconf("SC_CLK_TCK")

Verdict = Literal["gone", "stopped", "idle"]


@dataclass(frozen=True)
class PeerState:
    """One look at a peer: whether it exists, is stopped, and its CPU time so far [s]."""

    alive: bool
    stopped: bool = False
    cpu_s: float = 0.0


def read_stat(path: str) -> PeerState:
    """The state in a ``/proc/.../stat`` file (a process's or a thread's)."""
    try:
        with open(path, "rb") as f:
            text = f.read().decode("ascii", "replace")
    except OSError:
        return PeerState(alive=False)
    fields = text[text.rindex(")") + 2 :].split()  # after the command name, which may hold spaces
    state = fields[0]
    if state in ("Z", "X", "x"):
        return PeerState(alive=False)
    cpu = (int(fields[11]) + int(fields[12])) * _TICK_S  # utime + stime (fields 14, 15)
    return PeerState(alive=True, stopped=state in ("T", "t"), cpu_s=cpu)


@dataclass(frozen=True)
class ProcessPeer:
    """Another process, by PID."""

    pid: int

    def look(self) -> PeerState:
        return read_stat(f"/proc/{self.pid}/stat")


@dataclass(frozen=True)
class ThreadPeer:
    """A thread of this process, by its native id (``threading.get_native_id``)."""

    tid: int

    def look(self) -> PeerState:
        return read_stat(f"/proc/self/task/{self.tid}/stat")


def pty_peers(pty: str, *, master: bool) -> list[ProcessPeer] | None:
    """The other processes holding one side of the pty ``pty`` (``/dev/pts/N``): its master
    (``master=True``: the twin, seen from the host) or the pty itself (the host, seen from the
    twin). Processes of other users, or ones that end meanwhile, are skipped. None (unknown)
    when ``pty`` is no pty, or when this process holds the master itself (the twin is a thread
    here: its runner names it, :class:`ThreadPeer`)."""
    try:
        index = int(os.path.basename(os.path.realpath(pty)))
        device = os.stat(pty).st_rdev
    except (OSError, ValueError):
        return None
    me, uid = os.getpid(), os.getuid()
    if master and any(
        _holds(str(me), fd, index, device, master) for fd in os.listdir("/proc/self/fd")
    ):
        return None
    found: list[ProcessPeer] = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit() or int(entry.name) == me:
            continue
        try:
            if entry.stat().st_uid != uid:
                continue
            fds = os.listdir(f"/proc/{entry.name}/fd")
        except OSError:
            continue
        if any(_holds(entry.name, fd, index, device, master) for fd in fds) and (
            master or not any(_holds(entry.name, fd, index, device, True) for fd in fds)
        ):  # a process holding the master too is the twin's own (a firmware process)
            found.append(ProcessPeer(int(entry.name)))
    return found


def _holds(pid: str, fd: str, index: int, device: int, master: bool) -> bool:
    """Whether descriptor ``fd`` of process ``pid`` is the pty's master (or the pty)."""
    try:
        if not master:
            return os.stat(f"/proc/{pid}/fd/{fd}").st_rdev == device
        if os.readlink(f"/proc/{pid}/fd/{fd}") not in ("/dev/ptmx", "/dev/pts/ptmx"):
            return False
        with open(f"/proc/{pid}/fdinfo/{fd}") as f:
            return any(ln.split() == ["tty-index:", str(index)] for ln in f)
    except OSError:
        return False


Finder = Callable[[], "Sequence[ProcessPeer | ThreadPeer] | None"]


class Peer:
    """What a watch looks at: one or more processes or threads (:class:`ProcessPeer`,
    :class:`ThreadPeer`), found by ``find`` when first needed (None: unknown).

    Who the peer is can change over a lockstep's life: each ``jackson calibrate`` run, or a
    daemon restarted by systemd, is a new process on the same pty. So the peers found are kept
    for one wait only (:meth:`forget` at a new wait), and found again within a wait when none
    of them is alive any more (the old host gone, a new one perhaps already on the port).
    """

    def __init__(self, find: Finder) -> None:
        self._find = find
        self._peers: Sequence[ProcessPeer | ThreadPeer] | None = None
        self._found = False
        self.finds = 0  # how many times the peers were found: CPU times compare within one find

    @classmethod
    def of(cls, *peers: ProcessPeer | ThreadPeer) -> Peer:
        """Peers known from the start."""
        return cls(lambda: peers)

    def forget(self) -> None:
        """Find the peers again at the next look."""
        self._found = False

    def look(self) -> list[PeerState] | None:
        """One look at each of them; None when who they are is unknown."""
        fresh = not self._found
        if fresh:
            self._peers, self._found = self._find(), True
            self.finds += 1
        if self._peers is None:
            return None
        states = [p.look() for p in self._peers]
        if fresh or any(s.alive for s in states):
            return states
        self._peers = self._find()  # those found are gone: who is there now
        self.finds += 1
        return None if self._peers is None else [p.look() for p in self._peers]


@dataclass
class PeerWatch:
    """The verdict on a peer an end has waited for long (the module's notes).

    Attributes
    ----------
    peer : Peer or None
        Who the other end is; None (or a :class:`Peer` that cannot tell): unknown, and only the
        peer's own word that it waits too, or :attr:`backstop_s`, ends a wait.
    backstop_s : float
        Wall time an alive but idle peer is waited for [s].
    """

    peer: Peer | None = None
    backstop_s: float = BACKSTOP_S
    _last: tuple[float, float, int] | None = field(default=None, repr=False)  # wall, CPU, find
    seen: str = ""  # what the last look at the peer found, in words (for a log line)
    _idle_since: float | None = field(default=None, repr=False)

    def reset(self) -> None:
        """A new wait: the next look is a first one, at the peers found anew."""
        self._last = self._idle_since = None
        if self.peer is not None:
            self.peer.forget()

    def _finds(self) -> int:
        return 0 if self.peer is None else self.peer.finds

    def busy(self, now: float) -> bool | None:
        """Whether a peer that has not answered in time is still working on its answer: True
        when its CPU time advanced by :data:`WORK_SHARE` of the wall time since the last look
        (slow, so wait on), False when it is gone, stopped, did no work, or who it is is
        unknown (it counts as gone), None at a first look (look again after :data:`PROBE_S`).
        """
        states = None if self.peer is None else self.peer.look()
        if states is None or not any(s.alive for s in states):
            self.seen = "is not known" if states is None else "is gone"
            return False
        if all(s.stopped or not s.alive for s in states):
            self.seen = "is stopped"
            return False
        cpu, finds = sum(s.cpu_s for s in states if s.alive), self._finds()
        last, self._last = self._last, (now, cpu, finds)
        if last is None or now - last[0] <= 0.0 or last[2] != finds:  # a first look at them
            self.seen = "was looked at once"
            return None
        used, wall = cpu - last[1], now - last[0]
        self.seen = f"used {used * 1e3:.0f} ms of CPU in {wall:.2f} s"
        return used >= WORK_SHARE * wall

    def verdict(self, now: float, peer_waits: bool = False) -> Verdict | Literal["working"] | None:
        """A look at the peer at monotonic ``now``, once the end has waited long:
        ``"working"`` when the peer's CPU time advanced by :data:`WORK_SHARE` of the wall time
        since the last look (slow, not stalled: the wait starts over), a reason to give up
        (``"gone"``, ``"stopped"``, ``"idle"``: the peer, alive, did no work since the last look
        and says it waits too (``peer_waits``), or has done none for :attr:`backstop_s`), or
        None to wait on (a first look, or an idle peer before the backstop)."""
        last = self._last
        if last is not None and now - last[0] < PROBE_S:
            return None
        if self._idle_since is None:
            self._idle_since = now
        states = None if self.peer is None else self.peer.look()
        if states is None:  # unknown: the peer's word, else the backstop
            return "idle" if peer_waits or now - self._idle_since >= self.backstop_s else None
        if not any(s.alive for s in states):
            return "gone"
        if all(s.stopped or not s.alive for s in states):
            return "stopped"
        cpu, finds = sum(s.cpu_s for s in states if s.alive), self._finds()
        self._last = (now, cpu, finds)
        if last is None or last[2] != finds:  # a first look at these peers
            return None
        if cpu - last[1] >= WORK_SHARE * (now - last[0]):
            self._idle_since = now
            return "working"
        return "idle" if peer_waits or now - self._idle_since >= self.backstop_s else None


STALL_EXIT = 75  # exit status of a lockstep stall: EX_TEMPFAIL, an infrastructure failure
