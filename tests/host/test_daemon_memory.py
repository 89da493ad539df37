"""What a long-running daemon keeps: its navigation's control ticks are bounded (a trial keeps
them all, for its metrics and nav.csv)."""

from __future__ import annotations

import sys

from jackson.host.config import HostConfig
from jackson.host.control.navigate import (
    RECENT_SAMPLES,
    NavigateConfig,
    NavigateMission,
    NavSample,
)
from jackson.host.nav.types import Pose2D


def _tick(k: int) -> NavSample:
    return NavSample(k * 0.05, 0.01 * k, 0.0, 0.0, 0.2, 0.0, "following", 0, 1.0)


def test_the_daemons_navigation_keeps_only_its_recent_ticks() -> None:
    nav = NavigateConfig(start=Pose2D(), goals=(Pose2D(1.0, 0.0),), localisation="slam")
    daemon = NavigateMission(nav, HostConfig().limits, keep_samples=False)
    trial = NavigateMission(nav, HostConfig().limits)
    for k in range(5 * RECENT_SAMPLES):
        daemon.samples.append(_tick(k))
        trial.samples.append(_tick(k))
    assert len(daemon.samples) == RECENT_SAMPLES and len(trial.samples) == 5 * RECENT_SAMPLES
    assert daemon.samples[-1] == trial.samples[-1]  # the newest ticks are the ones kept
    assert daemon.samples[0].t_s == (4 * RECENT_SAMPLES) * 0.05
    size = sys.getsizeof(_tick(0)) + 9 * 24  # the object and its fields
    assert size * 20 * 3600 > 15e6  # every tick of a robot-hour would be about 20 MB


def test_the_c_heaps_free_memory_goes_back_once_a_period_of_mcu_time() -> None:
    """The daemon's HeapTrimmer: a trim per period of MCU time, none before the first period,
    none without a clock; on glibc the trim is real and gives freed memory back."""
    from pathlib import Path

    from jackson.host.daemon import HeapTrimmer

    heap = HeapTrimmer(period_s=60.0)
    if not heap.available:  # not glibc: nothing to trim
        return
    for k in range(20 * 200):  # 200 s of MCU time at 20 Hz
        heap.tick(k * 0.05)
        heap.tick(None)
    assert heap.trims == 3  # at 60, 120 and 180 s: a period after the first frame, and on

    def rss_kb() -> int:
        status = Path("/proc/self/status").read_text()
        return int(next(x for x in status.splitlines() if x.startswith("VmRSS")).split()[1])

    # 30 MB freed below a block still in use: malloc keeps it until a trim gives it back
    blocks = [bytearray(1500) for _ in range(20000)]
    last = blocks.pop()
    blocks.clear()
    before = rss_kb()
    heap._next_s = 0.0
    heap.tick(1.0)
    assert heap.trims == 4
    assert before - rss_kb() > 10_000, (before, rss_kb())
    del last
