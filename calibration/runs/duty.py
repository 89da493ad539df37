"""Raw duty runs: the daemon with a duty script as its command source (deadband, steps)."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Protocol

from jackson.calibration.procedures.step import WheelStepScript
from jackson.calibration.runs.folders import RunError
from jackson.calibration.runs.link import (
    Link,
    _meta,
    _open_link,
    _progress,
    _stopped,
    _write_config,
    wall_backstop_s,
)
from jackson.host.actuation.output import MotorOutput, Pca9685Output
from jackson.host.core import DutySource
from jackson.host.core.results import CoreListener, FrameResult
from jackson.host.daemon import Daemon
from jackson.protocol import (
    Message,
)


class DutyScript(DutySource, Protocol):
    """Raw duties per telemetry frame (:class:`jackson.host.core.DutySource`) with a length."""

    total_s: float


class _Progress(CoreListener):
    """Moves a progress bar on MCU time."""

    def __init__(self, update: Callable[[float], None]) -> None:
        self.update = update
        self.t0: float | None = None

    def on_result(self, result: FrameResult) -> None:
        self.t0 = result.t_s if self.t0 is None else self.t0
        self.update(result.t_s - self.t0)


def duty_run(
    link: Link, folder: Path, script: DutyScript, *, label: str, meta: dict[str, Any]
) -> Path:
    """Record one raw duty run: the daemon with ``script`` as its command source, so the duties
    go to the PCA9685 as they are (no limits, no deadband compensation); no IMU calibration is
    sent (the device keeps the one it holds, and :func:`load_run` undoes it with the one the
    device's INFO states, so the procedures read raw values either way).

    Raises
    ------
    RunError
        The port, the bus, no telemetry, or an actuator other than the PCA9685.
    ProtocolMismatchError
        Firmware of another protocol version.
    """
    cfg = link.config
    if cfg.actuator != "pca9685":
        raise RunError("raw duty runs drive the PCA9685: the config needs actuator: pca9685")
    transport, bus, pca = _open_link(link)
    assert bus is not None and pca is not None  # actuator: pca9685
    p = cfg.pca9685

    def output(send: Callable[[Message], object]) -> MotorOutput:
        return Pca9685Output(pca, p.left, p.right, p.stby_channel)

    _write_config(folder, cfg)
    wall_limit_s = wall_backstop_s(script.total_s)
    daemon = Daemon(
        cfg,
        output,
        transport,
        run_folder=folder,
        meta=meta,
        duty_source=script,
        imu_calibration=False,
    )
    try:
        with _progress(link.console, label, script.total_s) as progress:
            daemon.core.listeners.append(_Progress(progress))
            transport.send_hello()  # the session starts once the daemon is set up
            daemon.run(max_s=wall_limit_s)
    finally:
        transport.close()
        bus.close()
    if not script.done:
        hit = wall_limit_s if daemon.wall_limit_hit else None
        raise _stopped(label, daemon.core.frames, link.port, hit)
    return folder


class DeadbandScript:
    """Duty staircases per wheel and direction: coarse, then finer around the breakaway.

    For each of left forward, left reverse, right forward, right reverse: brake for
    ``settle_s``, then for each stage (step, hold): raise the duty of that wheel alone in
    ``step`` increments held ``hold`` seconds, from ``start`` to at most ``max_duty``, until
    its counts move in the ramp's direction for ``persist_frames`` frames; brake, and begin
    the next (finer) stage two of the previous steps below the duty that moved the wheel.
    """

    ORDER = (("left", 1), ("left", -1), ("right", 1), ("right", -1))

    def __init__(
        self,
        *,
        stages: Sequence[tuple[float, float]] = ((0.02, 0.25), (0.004, 0.5), (0.001, 0.8)),
        start_duty: float = 0.0,
        max_duty: float = 0.6,
        persist_frames: int = 3,
        settle_s: float = 0.5,
    ) -> None:
        self.stages = list(stages)
        self.start_duty = start_duty
        self.max_duty = max_duty
        self.persist = persist_frames
        self.settle_s = settle_s
        self.done = False
        coarse_levels = max_duty / stages[0][0]
        fine = sum(3 * prev[0] / st[0] * st[1] for prev, st in itertools.pairwise(stages))
        self.total_s = 4 * (coarse_levels * stages[0][1] / 3 + fine + len(stages) * settle_s)
        self.results: dict[tuple[str, int], float | None] = {}
        self._segment = 0
        self._stage = 0
        self._phase = "settle"
        self._t_phase: float | None = None
        self._from = start_duty
        self._ref = 0
        self._moved_run = 0
        self._written: list[float] = []

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        if self.done:
            return 0.0, 0.0
        side, sign = self.ORDER[self._segment]
        count = enc_left if side == "left" else enc_right
        if self._t_phase is None:
            self._t_phase = t_s
        if self._phase == "settle":
            if t_s - self._t_phase < self.settle_s:
                return 0.0, 0.0
            self._phase, self._t_phase = "ramp", t_s
            self._ref, self._moved_run, self._written = count, 0, []
        step, hold = self.stages[self._stage]
        moved = sign * (count - self._ref) >= 1
        self._moved_run = self._moved_run + 1 if moved else 0
        if self._moved_run >= self.persist:  # moved at frame m: the duty written before it
            hi = self._written[len(self._written) - self.persist]
            self._end_ramp(hi, t_s)
            return 0.0, 0.0
        level = math.floor((t_s - self._t_phase) / hold + 1e-9)
        duty = self._from + (level + 1) * step
        if duty > self.max_duty + 1e-12:
            self.results[(side, sign)] = None  # never moved
            self._next_segment(t_s)
            return 0.0, 0.0
        self._written.append(duty)
        d = sign * round(duty, 6)
        return (d, 0.0) if side == "left" else (0.0, d)

    def _end_ramp(self, hi: float, t_s: float) -> None:
        side, sign = self.ORDER[self._segment]
        step = self.stages[self._stage][0]
        if self._stage + 1 < len(self.stages):
            self._stage += 1
            self._from = max(self.start_duty, hi - 2.0 * step)
            self._phase, self._t_phase = "settle", t_s
        else:
            self.results[(side, sign)] = hi
            self._next_segment(t_s)

    def _next_segment(self, t_s: float) -> None:
        self._segment += 1
        self._stage = 0
        self._from = self.start_duty
        self._phase, self._t_phase = "settle", t_s
        if self._segment >= len(self.ORDER):
            self.done = True


class StepScript:
    """Brake ``settle_s``, both wheels at ``duty`` for ``drive_s``, then brake until the counts
    have stood still for ``still_s`` (at most ``max_stop_s``)."""

    def __init__(
        self,
        duty: float = 1.0,
        drive_s: float = 3.0,
        *,
        settle_s: float = 1.0,
        still_s: float = 0.5,
        max_stop_s: float = 3.0,
    ) -> None:
        self.duty = duty
        self.drive_s = drive_s
        self.settle_s = settle_s
        self.still_s = still_s
        self.max_stop_s = max_stop_s
        self.total_s = settle_s + drive_s + 1.0 + still_s
        self.done = False
        self._t0: float | None = None
        self._last_counts: tuple[int, int] | None = None
        self._last_change = 0.0

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        if self._t0 is None:
            self._t0 = t_s
        e = t_s - self._t0
        if e < self.settle_s:
            return 0.0, 0.0
        if e < self.settle_s + self.drive_s:
            return self.duty, self.duty
        counts = (enc_left, enc_right)
        if counts != self._last_counts:
            self._last_counts, self._last_change = counts, e
        braking = e - self.settle_s - self.drive_s
        if e - self._last_change >= self.still_s or braking >= self.max_stop_s:
            self.done = True
        return 0.0, 0.0


def record_deadband_run(link: Link, out: Path, script: DeadbandScript | None = None) -> Path:
    """The deadband staircases of all four wheel directions, in one raw duty run."""
    script = script or DeadbandScript()
    return duty_run(
        link,
        out / "deadband",
        script,
        label="deadband staircases",
        meta=_meta(link, "deadband", stages=[list(s) for s in script.stages]),
    )


def record_step_run(
    link: Link, out: Path, script: StepScript | None = None, *, rate_hz: int = 200
) -> Path:
    """A duty step on both wheels and the brake after it, in one raw duty run.

    The telemetry runs at ``rate_hz`` for this run (SET_RATE; the next session of the
    daemon sets the configured rate back): the stop lasts only a few frames at 20 Hz.
    """
    script = script or StepScript()
    cfg = link.config
    fast = dataclasses.replace(
        cfg, serial=dataclasses.replace(cfg.serial, telemetry_rate_hz=rate_hz)
    )
    return duty_run(
        dataclasses.replace(link, config=fast),
        out / "characterise",
        script,
        label=f"duty step {script.duty:g} for {script.drive_s:g} s",
        meta=_meta(link, "characterise", duty=script.duty, drive_s=script.drive_s, rate_hz=rate_hz),
    )


def record_wheel_step_run(
    link: Link, out: Path, script: WheelStepScript | None = None, *, rate_hz: int = 200
) -> Path:
    """Duty steps from rest per wheel and direction (:mod:`jackson.calibration.procedures.
    step`), in one raw duty run at ``rate_hz`` telemetry (the motor's time constant is tens of
    milliseconds: 20 Hz frames cannot tell it from the dead time)."""
    script = script or WheelStepScript()
    cfg = link.config
    fast = dataclasses.replace(
        cfg, serial=dataclasses.replace(cfg.serial, telemetry_rate_hz=rate_hz)
    )
    return duty_run(
        dataclasses.replace(link, config=fast),
        out / "step",
        script,
        label=f"{len(script.steps)} duty steps",
        meta=_meta(
            link, "step", steps=[dataclasses.asdict(s) for s in script.steps], rate_hz=rate_hz
        ),
    )
