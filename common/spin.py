"""Brief busy-polling for the twin's lockstep links.

In lockstep the twin and its host hand the turn back and forth several times per telemetry
frame (telemetry out, I²C write in, its answer out, HEARTBEAT in). A process that blocks in
``select`` or ``recv`` for each of these pays the kernel's wake-up latency every time: on a
2-core machine about 45 µs per Unix-socket round trip (6 µs when the receiver is already
running). Polling for a short while before blocking keeps both ends awake across the
exchange; ``os.sched_yield`` between polls hands the CPU to the other end when both share a
core. The spin is bounded, so a slow partner costs at most ``spin_s`` of CPU per wait.

Only links to the twin spin (the twin's own loop, the twin's I²C socket, the daemon's serial
port when it is a pty, and the tests' wire-level peer); the robot's USB port and I²C bus never
do. Two ends in the same process
gain nothing (the GIL serialises them), so :func:`peer_is_this_process` lets a socket client
turn it off.

A spin helps only while the partner has a core of its own. When other work keeps both cores
busy, ``os.sched_yield`` hands the CPU to that work for a whole scheduler tick (4 ms seen on
a 2-core machine with three CPU-bound processes), where a process blocked in ``select`` would
have been woken, ahead of it, as soon as its bytes arrived. So a yield that takes longer than
:data:`STOLEN_S` ends the spin, and the process's next :data:`BACKOFF_WAITS` waits block at
once; then it tries spinning again. The state is per process: contention is the machine's.
"""

from __future__ import annotations

import os
import socket
import struct
import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")

DEFAULT_SPIN_S = 0.0005
"""How long a lockstep wait polls before it blocks [s]: above the twin's and a minimal host's
work per frame (about 0.1-0.15 ms each), far below a telemetry period."""

STOLEN_S = 0.001
"""A yield longer than this [s] means another process ran on this core: the CPU is
contended (an uncontended yield takes about a microsecond)."""

BACKOFF_WAITS = 256
"""Waits that block at once, without spinning, after a yield was stolen."""

_PEERCRED = struct.Struct("3i")  # struct ucred: pid, uid, gid


class _Contention:
    """This process's view of the machine: waits left to block at once, yields stolen, and
    the CPU time spent spinning (a benchmark tells it apart from the work)."""

    backoff = 0
    stolen = 0
    spun_s = 0.0


contention = _Contention()


def spin_poll(poll: Callable[[], T], spin_s: float) -> T:
    """Call ``poll`` until it returns something truthy or ``spin_s`` has passed.

    Parameters
    ----------
    poll : callable
        A non-blocking check, e.g. ``lambda: selector.select(0)``.
    spin_s : float
        Longest time to keep polling [s]; 0 polls once.

    Returns
    -------
    T
        The last result of ``poll`` (falsy if nothing arrived within ``spin_s``, or when the
        CPU is contended (see the module's notes): the caller then blocks as it would have
        without spinning).
    """
    result = poll()
    if result or spin_s <= 0:
        return result
    state = contention
    if state.backoff > 0:  # the CPU was contended lately: block at once
        state.backoff -= 1
        return result
    clock = time.perf_counter
    cpu0 = time.thread_time()
    now = clock()
    end = now + spin_s
    while True:
        os.sched_yield()
        then, now = now, clock()
        result = poll()
        if now - then > STOLEN_S:  # another process had this core: stop spinning for a while
            state.stolen += 1
            state.backoff = BACKOFF_WAITS
            break
        if result or now >= end:
            break
    state.spun_s += time.thread_time() - cpu0  # CPU time: a stolen yield was not ours
    return result


def peer_is_this_process(sock: socket.socket) -> bool:
    """Whether the other end of a connected Unix socket is this very process (Linux).

    Returns False where the kernel does not tell (no ``SO_PEERCRED``).
    """
    opt = getattr(socket, "SO_PEERCRED", None)
    if opt is None or sock.family != socket.AF_UNIX:
        return False
    try:
        pid, _, _ = _PEERCRED.unpack(sock.getsockopt(socket.SOL_SOCKET, opt, _PEERCRED.size))
    except OSError:
        return False
    return int(pid) == os.getpid()
