"""A foreign write on the motor driver is told on the console and ends a running mission with
the reason; the navigation service and teleoperation go on, told."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from jackson.host.actuation.i2c import open_bus
from jackson.host.actuation.output import READBACK_PERIOD_S
from jackson.host.daemon_link import FOREIGN_WRITE, LinkWatch
from jackson.protocol import HostState

from .test_resilient_output import Bus, Clock, bus, drive_until_driving, output, put_to_sleep

__all__ = ["bus"]  # the fixture


class Core:
    """The core as the link watch sees it: its mission and abort()."""

    def __init__(self, mission: Any) -> None:
        self.mission = mission
        self.host_state = HostState.ACTIVE
        self.abort_reason: str | None = None

    def abort(self, reason: str) -> None:
        self.abort_reason = self.abort_reason or reason


@pytest.mark.parametrize("mission", ["square", None], ids=["mission", "teleop"])
def test_a_foreign_write_is_told_and_ends_the_mission_with_the_reason(
    bus: Bus, mission: str | None
) -> None:
    clock = Clock()
    out = output(bus, clock)
    drive_until_driving(out, bus, clock)
    core = Core(None if mission is None else SimpleNamespace(done=False))
    told: list[str] = []
    watch = LinkWatch(SimpleNamespace(), out, core, None, told.append)  # type: ignore[arg-type]
    assert not watch.foreign_write() and not told
    foreign = open_bus(f"unix:{bus.path}")  # another program on the same bus
    put_to_sleep(foreign)
    foreign.close()
    written = clock.t
    ended = False
    while not told:  # the daemon asks after every frame; the output reads back every second
        assert clock.t - written <= READBACK_PERIOD_S + 0.05, "not told within a readback"
        clock.t += 0.05
        out.set(0.5, -0.5)
        ended = watch.foreign_write()
    assert told == [f"I2C: {FOREIGN_WRITE}"]
    if mission is None:
        assert not ended and core.abort_reason is None  # nothing to end: told only
    else:
        assert ended and core.abort_reason == FOREIGN_WRITE
    assert not watch.foreign_write() and len(told) == 1  # once per write
