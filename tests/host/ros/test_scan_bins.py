"""A revolution on a LaserScan's evenly spaced angles (host/ros/scan_bins.py)."""

from __future__ import annotations

import numpy as np

from jackson.host.ros.scan_bins import binned_ranges


def test_evenly_spaced_measurements_are_written_as_they_are() -> None:
    angles = np.linspace(-3.0, 3.0, 7)
    ranges = np.arange(7, dtype=np.float64) + 1.0
    np.testing.assert_array_equal(binned_ranges(angles, ranges), ranges.astype(np.float32))


def test_each_measurement_lands_at_its_own_angle_and_a_bin_none_reaches_has_no_return() -> None:
    # five measurements over 0..4 rad, the middle three bunched towards the start
    angles = np.array([0.0, 0.9, 1.2, 1.9, 4.0])
    ranges = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    out = binned_ranges(angles, ranges)  # bins at 0, 1, 2, 3, 4 rad
    assert out[0] == 1.0 and out[4] == 5.0
    assert out[1] == 2.0  # 0.9 is nearer bin 1 than 1.2 is: the nearer wins
    assert out[2] == 4.0  # 1.9
    assert np.isinf(out[3])  # nothing near 3 rad


def test_a_decreasing_revolution_bins_the_same_way() -> None:
    angles = np.array([2.0, 1.1, 0.0])
    out = binned_ranges(angles, np.array([7.0, 8.0, 9.0]))  # bins at 2, 1, 0 rad
    np.testing.assert_array_equal(out, np.array([7.0, 8.0, 9.0], np.float32))
