"""A real-time priority for the daemon's frame thread (``jackson daemon --realtime``).

The daemon reads the MCU's port and writes the motors on one thread (the transport is opened
without a reader thread). On a busy machine that thread waits for a core behind other work;
under ``SCHED_FIFO`` it runs as soon as its bytes arrive. Only that thread gets the policy:
it is set with ``SCHED_RESET_ON_FORK``, so every thread started after it (recording, the
bag, ROS, the control socket, the live view) runs at the normal policy and cannot starve the
machine. Setting it needs root or ``CAP_SYS_NICE`` (or systemd's ``CPUSchedulingPolicy``,
deploy/jackson.service); without the permission the daemon says so in one line and runs at
normal priority. docs/jetson.md has the measurements.
"""

from __future__ import annotations

import os

PRIORITY = 40  # SCHED_FIFO 1-99: below the kernel's threaded interrupts (50 on PREEMPT_RT)
MIN_PRIORITY = 1
MAX_PRIORITY = 99


def make_realtime(priority: int = PRIORITY) -> str:
    """Put the calling thread under ``SCHED_FIFO`` at ``priority``, threads it starts later
    back at the normal policy; the operator's line saying what was done or why not."""
    if not MIN_PRIORITY <= priority <= MAX_PRIORITY:
        raise ValueError(f"real-time priority {priority}: expected {MIN_PRIORITY}-{MAX_PRIORITY}")
    if not hasattr(os, "SCHED_FIFO"):
        return "realtime: SCHED_FIFO is not available on this system; normal priority"
    policy = os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0)
    try:
        os.sched_setscheduler(0, policy, os.sched_param(priority))
    except PermissionError:
        return (
            f"realtime: SCHED_FIFO {priority} not permitted (needs root or CAP_SYS_NICE, or "
            "CPUSchedulingPolicy=fifo in the service); normal priority"
        )
    except OSError as exc:
        return f"realtime: SCHED_FIFO {priority} refused ({exc.strerror}); normal priority"
    return f"realtime: frame thread SCHED_FIFO priority {priority}"
