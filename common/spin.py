"""Brief busy-polling for the twin's lockstep links.

In lockstep the twin and its host hand the turn back and forth several times per telemetry
frame (telemetry out, I²C write in, its answer out, HEARTBEAT in). A process that blocks in
``select`` or ``recv`` for each of these pays the kernel's wake-up latency every time: on a
2-core machine about 45 µs per Unix-socket round trip (6 µs when the receiver is already
running). Polling for a short while before blocking keeps both ends awake across the
exchange; ``os.sched_yield`` between polls hands the CPU to the other end when both share a
core. The spin is bounded, so a slow partner costs at most ``spin_s`` of CPU per wait.

Only links to the twin spin (the twin's own loop, the twin's I²C socket and the tests'
wire-level peer); the daemon's serial link never does. Two ends in the same process
gain nothing (the GIL serialises them), so :func:`peer_is_this_process` lets a socket client
turn it off.
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

_PEERCRED = struct.Struct("3i")  # struct ucred: pid, uid, gid


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
        The last result of ``poll`` (falsy if nothing arrived within ``spin_s``: the caller
        then blocks as it would have without spinning).
    """
    result = poll()
    if result or spin_s <= 0:
        return result
    end = time.perf_counter() + spin_s
    while True:
        os.sched_yield()
        result = poll()
        if result or time.perf_counter() >= end:
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
