"""``jackson brake`` against the twin's I2C server (the real socket bus and PCA9685 model)."""

from __future__ import annotations

import re
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from jackson.host.actuation.i2c import open_bus
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import Pca9685Settings
from jackson.protocol import pca9685 as regs
from jackson.sim import pca9685 as model
from jackson.sim.i2c_server import I2cSocketServer
from jackson.sim.tb6612 import LEFT_WIRING, RIGHT_WIRING, BridgeMode, bridge_outputs

JACKSON = str(Path(sys.executable).parent / "jackson")


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[tuple[I2cSocketServer, str]]:
    server = I2cSocketServer(tmp_path / "i2c.sock")
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            server.service(0.05)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield server, f"unix:{server.path}"
    stop.set()
    thread.join(timeout=5)
    server.close()


def modes(server: I2cSocketServer) -> tuple[BridgeMode, BridgeMode]:
    chip = server.devices[0x40]
    assert isinstance(chip, model.Pca9685)
    left, right = bridge_outputs(chip, LEFT_WIRING, RIGHT_WIRING)
    return left.mode, right.mode


def drive(spec: str) -> None:
    """What a killed daemon leaves: the chip set up and both wheels driven forward."""
    from jackson.host.actuation.output import Pca9685Output

    p = Pca9685Settings(bus=spec)
    pca = Pca9685(open_bus(spec), p.address)
    pca.init(p.frequency_hz)
    Pca9685Output(pca, p.left, p.right).set(0.6, 0.6)
    pca.bus.close()


@pytest.mark.parametrize("state", ["driving", "reset chip", "asleep"])
def test_brake_leaves_both_bridges_in_short_brake(
    bus: tuple[I2cSocketServer, str], state: str
) -> None:
    server, spec = bus
    drive(spec)
    assert modes(server) == (BridgeMode.CW, BridgeMode.CW)
    chip = server.devices[0x40]
    assert isinstance(chip, model.Pca9685)
    if state == "reset chip":
        server.devices[0x40] = model.Pca9685()  # power-on state: asleep, outputs off
    elif state == "asleep":
        chip.write(regs.MODE1, bytes((regs.MODE1_SLEEP,)))  # a foreign write
    out = subprocess.run([JACKSON, "brake", "--i2c", spec], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "braked" in out.stdout
    assert modes(server) == (BridgeMode.SHORT_BRAKE, BridgeMode.SHORT_BRAKE)


def test_it_says_in_one_line_how_long_the_brake_took(bus: tuple[I2cSocketServer, str]) -> None:
    server, spec = bus
    drive(spec)
    t0 = time.monotonic()
    out = subprocess.run([JACKSON, "brake", "--i2c", spec], capture_output=True, text=True)
    wall_s = time.monotonic() - t0
    assert out.returncode == 0, out.stderr
    (line,) = out.stdout.splitlines()
    said = re.fullmatch(
        r"braked: PCA9685 at 0x40 on unix:\S+ \(attempt 1\): "
        r"([0-9.]+) s after the command started, ([0-9.]+) ms on the bus",
        line,
    )
    assert said is not None, line
    since_start_s, on_bus_s = float(said[1]), float(said[2]) / 1e3
    # its own process's age (10 ms ticks): within what this test saw from outside, and more
    # than the bus took (the interpreter's start and the imports come first)
    assert 0.0 < on_bus_s < since_start_s <= wall_s + 0.01, (line, wall_s)
    assert modes(server) == (BridgeMode.SHORT_BRAKE, BridgeMode.SHORT_BRAKE)


def test_a_config_broken_outside_the_motor_sections_still_brakes(
    bus: tuple[I2cSocketServer, str], tmp_path: Path
) -> None:
    """The brake reads only ``actuator`` and ``pca9685``: an EKF section someone broke does not
    keep the robot from braking (the daemon itself refuses that file)."""
    from jackson.host.config import DEFAULT_CONFIG

    server, spec = bus
    drive(spec)
    config = tmp_path / "broken.yaml"
    text = DEFAULT_CONFIG.read_text()
    config.write_text(text.replace("  frequency_hz: 30 ", "  frequency_hz: .nan ", 1))
    out = subprocess.run(
        [JACKSON, "brake", "--config", str(config), "--i2c", spec], capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    assert modes(server) == (BridgeMode.SHORT_BRAKE, BridgeMode.SHORT_BRAKE)
    daemon = subprocess.run(
        [JACKSON, "daemon", "--config", str(config), "--port", "nowhere"],
        capture_output=True,
        text=True,
    )
    assert daemon.returncode == 2 and "ekf.frequency_hz" in daemon.stderr


def test_unreachable_bus_is_one_line_and_exit_1(tmp_path: Path) -> None:
    out = subprocess.run(
        [JACKSON, "brake", "--i2c", f"unix:{tmp_path / 'gone.sock'}"],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "not braked after 4 attempts" in lines[0]
    assert "gone.sock" in lines[0] and "check that the twin runs" in lines[0]


def test_a_missing_adapter_names_what_to_check() -> None:
    out = subprocess.run(
        [JACKSON, "brake", "--i2c", "/dev/i2c-250"], capture_output=True, text=True
    )
    assert out.returncode == 1
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "/dev/i2c-250" in lines[0] and "ls /dev/i2c-*" in lines[0]


@pytest.mark.parametrize(
    ("flag", "value"), [("--address", "0x99"), ("--i2c", "i2c-1"), ("--i2c", "unix:")]
)
def test_a_bad_option_is_one_line_and_exit_2(flag: str, value: str) -> None:
    out = subprocess.run([JACKSON, "brake", flag, value], capture_output=True, text=True)
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1
    assert flag in out.stderr and value in out.stderr
