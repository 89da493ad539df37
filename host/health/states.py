"""A health state per sensor with its hysteresis, and the record of their transitions.

Per sensor (``imu``, ``encoder_left``, ``encoder_right``, ``link``, ``lidar``):
``ok`` -> ``suspect`` (a failing sample: not fused) -> ``excluded`` (a failing test: not
fused until it passes again) -> ``recovered`` (``recover_s`` of passing samples after an
exclusion: fused again) -> ``ok`` (``recovered_hold_s`` later). ``suspect`` returns to ``ok``
after ``recover_s`` without a failure. Every check's :class:`~jackson.host.health.types.Finding`
moves a sensor through :meth:`SensorStates.apply`; :meth:`SensorStates.commit` records the
transitions a call made.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TypeVar

from jackson.host.health.config import HealthConfig
from jackson.host.health.types import SENSORS, Finding, Health, Transition

TRANSITIONS_KEPT = 1000  # the newest health transitions a monitor keeps (a daemon runs for days)


T = TypeVar("T")


class Recent(list[T]):
    """A list that keeps only its newest ``maxlen`` items (appended or added with ``+=``); it
    compares, indexes and pickles as a list. :attr:`added` counts every item ever added, so a
    reader that remembers it finds the items added since (:meth:`since`), trimmed or not."""

    maxlen = TRANSITIONS_KEPT  # until __init__ (or unpickling) sets the instance's own
    added = 0  # items ever added (a snapshot from before this count unpickles with 0)

    def __init__(self, maxlen: int) -> None:
        super().__init__()
        self.maxlen = maxlen

    def _trim(self) -> None:
        if len(self) > self.maxlen:
            del self[: len(self) - self.maxlen]

    def append(self, item: T) -> None:
        super().append(item)
        self.added += 1
        self._trim()

    def __iadd__(self, items: Iterable[T]) -> Recent[T]:  # type: ignore[override,misc]
        n = len(self)
        super().__iadd__(items)
        self.added += len(self) - n
        self._trim()
        return self

    def since(self, added: int) -> list[T]:
        """The items added after the reader's count was ``added`` (the newest ``maxlen`` of
        them if more were added since)."""
        new = min(self.added - added, len(self))
        return list(self[len(self) - new :]) if new > 0 else []


class SensorState:
    """One sensor's state machine (module docstring)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.state = Health.OK
        self.since_s = 0.0  # when the current state began
        self.clean_since_s: float | None = None  # first passing sample of the current clean run
        self.reason = ""

    def fail(self, t_s: float, exclude: bool, reason: str, out: list[Transition]) -> None:
        """A failing sample: ``suspect``, or ``excluded`` with ``exclude``; the clean run ends."""
        self.clean_since_s = None
        new = Health.EXCLUDED if exclude else Health.SUSPECT
        if self.state is Health.EXCLUDED or self.state is new:
            return
        self._go(t_s, new, reason, out)

    def pass_(self, t_s: float, cfg: HealthConfig, out: list[Transition]) -> None:
        """A passing sample: back towards ``ok`` once the clean run is long enough."""
        if self.clean_since_s is None:
            self.clean_since_s = t_s
        clean = t_s - self.clean_since_s
        if self.state is Health.EXCLUDED and clean >= cfg.recover_s - 1e-9:
            self._go(t_s, Health.RECOVERED, f"passed its tests for {clean:.1f} s", out)
        elif self.state is Health.SUSPECT and clean >= cfg.recover_s - 1e-9:
            self._go(t_s, Health.OK, f"passed its tests for {clean:.1f} s", out)
        elif self.state is Health.RECOVERED and t_s - self.since_s >= cfg.recovered_hold_s - 1e-9:
            self._go(t_s, Health.OK, f"{cfg.recovered_hold_s:.0f} s since it recovered", out)

    def _go(self, t_s: float, new: Health, reason: str, out: list[Transition]) -> None:
        out.append(Transition(t_s, self.name, self.state, new, reason))
        self.state, self.since_s, self.reason = new, t_s, reason


class SensorStates:
    """Every sensor's :class:`SensorState` and the transitions they made, newest last.

    Parameters
    ----------
    cfg : HealthConfig
        ``recover_s`` and ``recovered_hold_s``.

    Attributes
    ----------
    transitions : list of Transition
        The newest :data:`TRANSITIONS_KEPT` changes, in order.
    excluded : int
        Exclusions so far.
    """

    def __init__(self, cfg: HealthConfig) -> None:
        self.cfg = cfg
        self._s = {name: SensorState(name) for name in SENSORS}
        self.transitions: Recent[Transition] = Recent(TRANSITIONS_KEPT)
        self.excluded = 0

    def __getitem__(self, sensor: str) -> Health:
        return self._s[sensor].state

    @property
    def now(self) -> dict[str, Health]:
        """Each sensor's state now, in :data:`SENSORS` order."""
        return {name: s.state for name, s in self._s.items()}

    def reason(self, sensor: str) -> str:
        """Why the sensor entered its current state ('' while it never left ``ok``)."""
        return self._s[sensor].reason

    def all_ok(self) -> bool:
        """Every sensor is ``ok``."""
        return all(x.state is Health.OK for x in self._s.values())

    def quiet(self, t_s: float) -> bool:
        """No transition for ``recovered_hold_s`` before ``t_s`` (none recorded: quiet)."""
        return not self.transitions or t_s - self.transitions[-1].t_s >= self.cfg.recovered_hold_s

    def apply(self, findings: Iterable[Finding], out: list[Transition]) -> None:
        """Each finding to its sensor, in order; the transitions they cause to ``out``."""
        for f in findings:
            s = self._s[f.sensor]
            if f.passed:
                s.pass_(f.t_s, self.cfg, out)
            else:
                s.fail(f.t_s, f.exclude, f.reason, out)

    def commit(self, out: list[Transition]) -> None:
        """Record ``out``'s transitions (and count its exclusions)."""
        if not out:  # most frames: nothing to record
            return
        self.transitions += out
        self.excluded += sum(1 for x in out if x.new is Health.EXCLUDED)
