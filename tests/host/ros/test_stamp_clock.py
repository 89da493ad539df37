"""MCU time to ROS time (``StampClock``): the least transport delay, monotonic, jitter kept."""

from __future__ import annotations

import numpy as np

from jackson.host.ros.messages import CLOCK_SLEW, StampClock

NS = 1_000_000_000


def test_sim_time_is_mcu_time() -> None:
    clock = StampClock(sim_time=True)
    clock.observe(1.0, 5 * NS)
    assert clock.ns(1.25) == 1_250_000_000 and clock.offset_s is None


def test_the_offset_is_the_least_delay_and_stamps_never_go_back() -> None:
    rng = np.random.default_rng(3)
    epoch = 1_795_000_000 * NS  # the host's clock when the MCU's read 0
    clock = StampClock(sim_time=False)
    assert clock.ns(0.5) == 0  # nothing to map with yet
    stamps = []
    t = 0.0
    for k in range(400):  # 20 s of frames at 20 Hz: 1 ms least delay, exponential on top
        t = 0.05 * (k + 1)
        delay = 0.001 + rng.exponential(0.004) + (0.2 if k == 0 else 0.0)  # a slow first frame
        clock.observe(t, epoch + round((t + delay) * NS))
        stamps.append(clock.ns(t))
    assert abs(clock.ns(t) - (epoch + round((t + 0.001) * NS))) < 0.0005 * NS
    steps = np.diff(stamps)
    assert steps.min() >= (1.0 - CLOCK_SLEW) * 0.05 * NS - 1  # monotonic while it settled
    jitter = np.asarray(clock.jitter_s)
    assert jitter.min() >= 0.0 and 0.002 < np.median(jitter) < 0.004
