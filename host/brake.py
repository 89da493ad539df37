"""``jackson brake``: short-brake both wheels through the PCA9685 now, whatever left them.

systemd runs it after the daemon has stopped (``ExecStopPost``, deploy/jackson.service): a daemon
that crashed, was killed by the watchdog or exited leaves the PCA9685 holding its last duties,
and the MCU's interlock (docs/firmware.md) is then the only thing stopping the wheels. This puts
both TB6612FNG bridges into short brake (IN1 = IN2 = high, PWM off) on the PCA9685 itself,
re-initialising the chip first if it was reset or asleep, and reads the registers back.

It says in one line how long it took from the process's start (what systemd waits for, the
interpreter's start and the imports included) and how much of it on the bus. What it takes is
the interpreter (on an x86_64 machine with the ROS 2 wheels twice: their start-up hook
re-executes it), the imports and the configuration's YAML; so it imports only the motor
output's modules (not the CLI's, not the estimator), and reads each contiguous run of channels
back in one block read (each I2C transaction waits for the bus's other end: the twin's server
thread on a busy machine).
"""

from __future__ import annotations

import argparse
import errno
import os
import sys
import time
from pathlib import Path

from jackson.common.args import int_in
from jackson.common.errors import JacksonError
from jackson.host.actuation.i2c import (
    SOCKET_PREFIX,
    I2cError,
    I2cSpecError,
    check_bus_spec,
    open_bus,
)
from jackson.host.actuation.pca9685 import Pca9685, block_runs, led_registers
from jackson.host.actuation.settings import DEFAULT_CONFIG, Pca9685Settings, load_motor_settings
from jackson.host.actuation.tb6612 import bridge_duties
from jackson.protocol.pca9685 import led_on_l

ATTEMPTS = 4
BACKOFF_S = (0.1, 0.3, 1.0)  # [s] before the 2nd, 3rd and 4th attempt


class BrakeError(JacksonError, RuntimeError):
    """The bus or the chip could not be reached, or did not hold the brake."""


def brake_duties(p: Pca9685Settings) -> dict[int, float]:
    """PCA9685 channel duties with both bridges in short brake (and STBY high if wired)."""
    duties = {**bridge_duties(p.left, 0.0), **bridge_duties(p.right, 0.0)}
    if p.stby_channel is not None:
        duties[p.stby_channel] = 1.0
    return duties


def brake_once(p: Pca9685Settings) -> None:
    """One attempt: open the bus, (re)initialise if needed, brake, read back.

    Raises
    ------
    BrakeError
        A register read back differs from what was written.
    I2cError, OSError
        The bus failed.
    """
    bus = open_bus(p.bus)
    try:
        pca = Pca9685(bus, p.address)
        if not pca.registers_ok(p.frequency_hz):
            pca.init(p.frequency_hz)
        duties = brake_duties(p)
        pca.set_duties(duties)  # what Pca9685Output.brake() writes
        # read back a run of channels at a time (auto-increment: the chip is set up now)
        for run in block_runs(tuple(sorted(duties))):
            got = bus.read_i2c_block_data(p.address, led_on_l(run[0]), 4 * len(run))
            for k, ch in enumerate(run):
                if list(got[4 * k : 4 * k + 4]) != led_registers(duties[ch]):
                    regs = bytes(got[4 * k : 4 * k + 4]).hex()
                    raise BrakeError(f"channel {ch} reads {regs} after the brake")
        if not pca.registers_ok(p.frequency_hz):
            raise BrakeError("MODE1/MODE2/PRE_SCALE do not hold their values")
    finally:
        bus.close()


def _what_to_check(exc: BaseException, p: Pca9685Settings) -> str:
    """The likely cause of a failed attempt, as advice for the operator."""
    cause = exc.__cause__ if isinstance(exc.__cause__, OSError) else exc
    code = cause.errno if isinstance(cause, OSError) else None
    if p.bus.startswith(SOCKET_PREFIX) and code in (errno.ENOENT, errno.ECONNREFUSED):
        return "check that the twin runs (jackson sim prints its I2C socket)"
    if code == errno.ENOENT:
        return "check that the bus exists (ls /dev/i2c-*) and pca9685.bus"
    if code in (errno.EACCES, errno.EPERM):
        return "check that the user is in the group i2c"
    if code in (errno.EREMOTEIO, errno.ENXIO) or "acknowledged" in str(exc):
        return f"nothing answers at {p.address:#04x}: check the board's power, SDA/SCL and address"
    return "check the wiring and the PCA9685 board's power"


def brake(p: Pca9685Settings, attempts: int = ATTEMPTS) -> int:
    """Brake with retries; the number of attempts it took.

    Raises
    ------
    BrakeError
        Every attempt failed (the last reason and what to check).
    """
    last: BaseException = BrakeError("no attempt made")
    for k in range(attempts):
        if k:
            time.sleep(BACKOFF_S[min(k - 1, len(BACKOFF_S) - 1)])
        try:
            brake_once(p)
            return k + 1
        except (I2cError, OSError, BrakeError) as exc:
            last = exc
    raise BrakeError(
        f"PCA9685 at {p.address:#04x} on {p.bus}: not braked after {attempts} attempts "
        f"({last}); {_what_to_check(last, p)}; the MCU's interlock still brakes"
    )


def process_age_s() -> float | None:
    """Seconds since this process started (Linux: its start time in ``/proc/self/stat``, in
    clock ticks since boot, against ``CLOCK_BOOTTIME``; 10 ms resolution); None without
    ``/proc``. An ``exec`` keeps the start time: a re-executed interpreter counts from the
    first."""
    try:
        stat = Path("/proc/self/stat").read_text(encoding="ascii")
        start_ticks = int(stat.rsplit(")", 1)[1].split()[19])  # field 22, starttime
        return time.clock_gettime(time.CLOCK_BOOTTIME) - start_ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def bus_spec(text: str) -> str:
    """argparse type: ``/dev/i2c-N``, ``N`` or ``unix:/path/to.sock``."""
    try:
        check_bus_spec(text)
    except I2cSpecError as exc:
        raise argparse.ArgumentTypeError(
            f"expected /dev/i2c-N, N or unix:/path/to.sock, got {text!r}"
        ) from exc
    return text


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "brake",
        help="short-brake both wheels through the PCA9685 now (systemd runs it after the daemon)",
    )
    p.add_argument("--config", type=Path, help="host YAML (default: host/config/jackson.yaml)")
    p.add_argument(
        "--i2c", type=bus_spec, help="I2C bus of the PCA9685 (default: pca9685.bus of the config)"
    )
    p.add_argument(
        "--address", type=int_in(0x03, 0x77), help="PCA9685 address (default: the config's)"
    )
    p.set_defaults(func=cmd_brake)


class BrakeUsageError(JacksonError, ValueError):
    """Braking a PCA9685 that the configuration says the MCU drives (one line, exit 2)."""


def cmd_brake(args: argparse.Namespace) -> int:
    import dataclasses

    # only the motor output's sections: no estimator to import, and a broken section elsewhere
    # in the file does not keep the robot from braking (a ConfigError is one line, exit 2)
    actuator, p = load_motor_settings(args.config or DEFAULT_CONFIG)
    if args.i2c:
        p = dataclasses.replace(p, bus=args.i2c)
    if args.address is not None:
        p = dataclasses.replace(p, address=args.address)
    if actuator != "pca9685" and not args.i2c:
        raise BrakeUsageError(
            f"actuator is {actuator}: the MCU drives the motors and brakes them itself; "
            "give --i2c to brake a PCA9685 anyway"
        )
    on_bus = time.perf_counter()
    try:
        n = brake(p)
    except BrakeError as exc:
        print(f"jackson brake: {exc}", file=sys.stderr)
        return 1
    on_bus = time.perf_counter() - on_bus
    age = process_age_s()
    since = f"{age:.2f} s after the command started, " if age is not None else ""
    print(
        f"braked: PCA9685 at {p.address:#04x} on {p.bus} (attempt {n}): "
        f"{since}{on_bus * 1e3:.1f} ms on the bus"
    )
    return 0
