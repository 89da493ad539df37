"""The robot (or twin) a calibration records on, and what every recording shares."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn

from jackson.calibration.runs.folders import RunError
from jackson.host.actuation.i2c import I2cBus, I2cError, open_bus
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import HostConfig, dump_config
from jackson.host.transport import LinkError, SerialTransport

WALL_BACKSTOP_S = 600.0  # [s] of wall time beyond the scaled run length, for a hung host
WALL_BACKSTOP_FACTOR = 20.0  # wall seconds per second of MCU time a run may take


def wall_backstop_s(mcu_s: float) -> float:
    """The wall time a run of ``mcu_s`` seconds on the MCU's clock may take before it is cut.

    Scripts and missions start and end their steps on the MCU's clock, so a slow host only
    makes a run take longer, never changes it: on the twin in lockstep a busy machine slows
    the MCU's clock with the host. This limit is a far backstop for a host that hangs while
    frames keep coming, not a measure of the run.

    Parameters
    ----------
    mcu_s : float
        The run's expected length on the MCU's clock [s].

    Returns
    -------
    float
        The wall-time limit [s].
    """
    return WALL_BACKSTOP_S + WALL_BACKSTOP_FACTOR * mcu_s


@dataclass(frozen=True)
class Link:
    """A robot (or the twin) to record on, and what the host believes about it.

    Attributes
    ----------
    port : str
        The MCU's serial port (the twin prints its pty).
    config : HostConfig
        The host configuration; ``pca9685.bus`` names the PCA9685's bus (``--i2c``).
    console : Console or None
        Where progress bars go; None: no progress display.
    """

    port: str
    config: HostConfig
    console: Console | None = field(default=None, compare=False)


@contextmanager
def _progress(
    console: Console | None, label: str, total_s: float
) -> Iterator[Callable[[float], None]]:
    """A rich progress bar in seconds of MCU time; a no-op without a console."""
    if console is None:
        yield lambda elapsed_s: None
        return
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:5.1f}/{task.total:.0f} s"),
        console=console,
        transient=True,
    ) as progress:
        task = progress.add_task(label, total=total_s)
        yield lambda elapsed_s: progress.update(task, completed=min(elapsed_s, total_s))


def _meta(link: Link, procedure: str, **extra: Any) -> dict[str, Any]:
    return {
        "mission": None,  # commands came from a calibration script
        "calibration": procedure,
        "port": link.port,
        "started": dt.datetime.now().isoformat(),
        **extra,
    }


def _write_config(folder: Path, cfg: HostConfig) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.yaml").write_text(
        yaml.safe_dump(dump_config(cfg), sort_keys=False), encoding="utf-8"
    )


def _open_pca(cfg: HostConfig) -> tuple[I2cBus, Pca9685]:
    p = cfg.pca9685
    try:
        bus = open_bus(p.bus)
        pca = Pca9685(bus, p.address)
        pca.init(p.frequency_hz)
    except (I2cError, OSError) as exc:
        raise RunError(f"PCA9685 at {p.address:#04x} on {p.bus}: {exc}") from exc
    return bus, pca


def _open_link(link: Link) -> tuple[SerialTransport, I2cBus | None, Pca9685 | None]:
    """The MCU's port and, with ``actuator: pca9685``, the PCA9685 (initialised), or RunError."""
    cfg = link.config
    transport = SerialTransport(link.port, cfg.serial.baudrate)
    try:
        transport.open(reader_thread=False, hello=False)  # HELLO when the daemon runs
    except LinkError as exc:
        raise RunError(str(exc)) from exc
    if cfg.actuator != "pca9685":
        return transport, None, None
    try:
        bus, pca = _open_pca(cfg)
    except RunError:
        transport.close()
        raise
    return transport, bus, pca


def _stopped(label: str, frames: int, port: str, wall_limit_s: float | None = None) -> RunError:
    """A run that ended before its script or mission did (``wall_limit_s``: on that backstop)."""
    if wall_limit_s is not None:
        return RunError(
            f"{label}: not finished after {wall_limit_s:.0f} s of wall time ({frames} telemetry "
            f"frames from {port}): the host hung or the machine is overloaded; run it again"
        )
    return RunError(
        f"{label}: stopped after {frames} telemetry frames from {port}"
        + (" (no telemetry: is the firmware running?)" if frames == 0 else "")
    )
