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
