"""The one interface every health check implements, as a DWB critic scores a trajectory and a
diagnostic_updater task fills a status: :meth:`Check.observe` takes the check's input and
returns its findings.

A check keeps what it needs of the past (its windows and timers), never a sensor's state:
the monitor applies the findings to the sensors' state machines
(:class:`~jackson.host.health.states.SensorStates`) in the order they come, before the next
check runs, so a check that reads the states sees every earlier check's word on this frame.
What a check concludes beyond its findings (a frozen IMU, a spike that is not fused) it keeps
as an attribute of its last observation, for the checks after it and the policy.
"""

from __future__ import annotations

from typing import Protocol, TypeVar, runtime_checkable

from jackson.host.health.types import Finding

In = TypeVar("In", contravariant=True)


@runtime_checkable
class Check(Protocol[In]):
    """A health check: observes one input, says what it found of which sensor."""

    def observe(self, x: In, /) -> list[Finding]:
        """The findings of one observation, in the order they are to be applied."""
        ...
