"""The daemon's watch over its link and motor path, alone: what the operator is told of a HELLO
nobody answers and of the PCA9685's I2C path, and the link's problems in one phrase each."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

from jackson.host.daemon_link import LinkHealth, LinkWatch
from jackson.protocol import HostState


def _watch(output: Any = None) -> tuple[LinkWatch, list[str], Any]:
    told: list[str] = []
    core = SimpleNamespace(host_state=HostState.ACTIVE, info=None)
    transport = SimpleNamespace(port_name="/dev/ttyACM0", silence_s=0.5)
    watch = LinkWatch(transport, output, core, None, told.append)  # type: ignore[arg-type]
    return watch, told, core


def test_an_unanswered_hello_is_told_at_once_then_at_each_doubling_of_the_retries() -> None:
    watch, told, _ = _watch()
    for k in range(9):
        watch.unanswered(f"silent {k}")
    assert told[0] == (
        "no answer on /dev/ttyACM0: is the firmware flashed? (make flash); is it the MCU's "
        "port? HELLO is sent again every 0.5 s (silent 0)"
    )
    assert told[1:] == [
        "still no answer on /dev/ttyACM0: HELLO sent 3 times (silent 1)",
        "still no answer on /dev/ttyACM0: HELLO sent 5 times (silent 3)",
        "still no answer on /dev/ttyACM0: HELLO sent 9 times (silent 7)",
    ]


def test_an_i2c_outage_is_told_once_and_its_end_once_and_the_heartbeat_says_shutdown() -> None:
    health = SimpleNamespace(bus_down=False, i2c_errors=0, reinits=0, last_error="")
    output = SimpleNamespace(health=lambda: health)
    watch, told, core = _watch(output)
    watch.started(0.0)
    health.i2c_errors, health.last_error = 1, "EIO"
    watch.motor_path()
    health.i2c_errors, health.bus_down = 3, True
    watch.motor_path()
    assert core.host_state is HostState.SHUTDOWN and not watch.bus_up
    health.reinits, health.bus_down = 1, False
    watch.motor_path()
    watch.motor_path()
    assert core.host_state is HostState.ACTIVE and watch.bus_up
    assert told == [
        "I2C: PCA9685 write failed (EIO): retrying; the MCU interlock brakes if it lasts 0.5 s",
        "PCA9685 bus down (EIO): braking through the MCU interlock",
        "I2C: PCA9685 back and re-initialised (3 failed writes)",
        "PCA9685 bus back: motor output re-initialised",
    ]


def test_link_health_names_each_problem_once() -> None:
    assert LinkHealth(link_up=True).problems() == []
    assert LinkHealth(frames_lost=2, i2c_bus_up=False).problems() == [
        "serial link down",
        "2 frames lost",
        "PCA9685 bus down: braked by the MCU interlock",
    ]
