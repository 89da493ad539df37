"""The daemon's CPU meter: percentiles from a fixed-size histogram, the share of a core over
the robot's time, and a report health.json can hold."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from jackson.host.cpu import BINS_PER_DECADE, CpuMeter

BIN_RATIO = 10.0 ** (1.0 / BINS_PER_DECADE)  # a bin's upper edge over its lower one


def test_percentiles_are_within_a_bin_of_the_exact_ones() -> None:
    rng = np.random.default_rng(3)
    frames_us = rng.lognormal(np.log(2000.0), 0.8, 5000)
    meter = CpuMeter()
    for us in frames_us:
        meter.frame(float(us))
    for q in (0.5, 0.9, 0.99):
        exact = float(np.quantile(frames_us, q))
        assert exact / BIN_RATIO <= meter.percentile_us(q) <= exact * BIN_RATIO**2
    assert meter.max_us == pytest.approx(frames_us.max())
    assert meter.percentile_us(1.0) == pytest.approx(frames_us.max())
    assert meter.frames == 5000


def test_the_memory_does_not_grow_with_the_frames() -> None:
    meter = CpuMeter()
    size = meter._counts.nbytes
    for us in (0.1, 5.0, 3e4, 1e9):  # below the first bin and beyond the last are counted
        meter.frame(us)
    assert meter._counts.nbytes == size and int(meter._counts.sum()) == 4


def test_share_of_core_is_process_cpu_over_robot_time() -> None:
    meter = CpuMeter()
    assert meter.share_of_core == 0.0 and meter.percentile_us(0.5) == 0.0
    meter.robot_time(10.0)
    t0 = time.process_time()
    while time.process_time() - t0 < 0.05:  # burn CPU: the meter reads process time
        sum(range(1000))
    meter.robot_time(11.0)
    assert meter.robot_s == pytest.approx(1.0)
    assert 0.04 < meter.share_of_core < 1.0
    meter.frame(1500.0)
    report = meter.report(0.05)
    json.dumps(report)  # health.json holds it
    assert report["frames"] == 1 and report["frame_share_of_period"]["median"] == pytest.approx(
        report["frame_us"]["median"] * 1e-6 / 0.05
    )
    assert "% of a core" in meter.line()


def test_polling_a_lockstep_twin_is_not_the_daemons_work() -> None:
    """CPU spent in jackson.common.spin's polls (a twin's links only) is left out."""
    from jackson.common import spin

    meter = CpuMeter()
    meter.robot_time(0.0)
    t0 = time.process_time()
    while time.process_time() - t0 < 0.02:  # work
        sum(range(1000))
    spun0 = spin.contention.spun_s
    while spin.contention.spun_s - spun0 < 0.05:  # polling a partner that never answers
        spin.contention.backoff = 0  # (a busy machine would have ended the spin)
        spin.spin_poll(lambda: False, 0.01)
    meter.robot_time(1.0)
    spent = time.process_time() - t0  # the work and the polling, with the loop around them
    # the work is counted, the 50 ms of polling is not (on a loaded machine the loop's own
    # bookkeeping costs more, so the bound is on what was left out, not on what stayed)
    assert meter.process_s > 0.015 and spent - meter.process_s > 0.04
