"""The host's I²C bus: the interface, the socket client's bytes and errors, and open_bus."""

from __future__ import annotations

import inspect
import socket
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import smbus2

from jackson.host.actuation.i2c import I2cBus, I2cError, SocketI2cBus, open_bus

HANG = b"hang"  # script entry: read the request, never answer
CLOSE = b"close"  # script entry: read the request, then disconnect


class ScriptedPeer:
    """A stand-in for the twin: reads requests of known sizes and sends canned responses."""

    def __init__(self, path: Path, script: list[tuple[int, bytes]], split: bool = False) -> None:
        self.path = path
        self.script = script
        self.split = split  # send responses one byte at a time
        self.requests: list[bytes] = []
        self._listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._listener.bind(str(path))
        self._listener.listen(1)
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        conn, _ = self._listener.accept()
        with conn:
            for size, response in self.script:
                request = b""
                while len(request) < size:
                    chunk = conn.recv(size - len(request))
                    if not chunk:
                        return
                    request += chunk
                self.requests.append(request)
                if response == CLOSE:
                    return
                if response == HANG:
                    self._done.wait(5.0)
                    return
                if self.split:
                    for byte in response:
                        conn.sendall(bytes((byte,)))
                        time.sleep(0.002)
                else:
                    conn.sendall(response)
            self._done.wait(5.0)

    def stop(self) -> None:
        self._done.set()
        self._thread.join()
        self._listener.close()


@contextmanager
def peer(
    tmp_path: Path, script: list[tuple[int, bytes]], split: bool = False
) -> Iterator[ScriptedPeer]:
    p = ScriptedPeer(tmp_path / "i2c.sock", script, split)
    try:
        yield p
    finally:
        p.stop()


# ---- the interface ----------------------------------------------------------------------------
def test_smbus2_smbus_satisfies_the_interface() -> None:
    bus = smbus2.SMBus()  # no adapter opened
    assert isinstance(bus, I2cBus)
    for name in (
        "write_byte_data",
        "read_byte_data",
        "write_i2c_block_data",
        "read_i2c_block_data",
    ):
        ours = list(inspect.signature(getattr(I2cBus, name)).parameters)[1:]  # without self
        theirs = list(inspect.signature(getattr(bus, name)).parameters)
        assert theirs[: len(ours)] == ours, name


def test_socket_bus_satisfies_the_interface(tmp_path: Path) -> None:
    with peer(tmp_path, []) as p, SocketI2cBus(p.path) as bus:
        assert isinstance(bus, I2cBus)


def test_i2c_error_is_an_os_error_like_smbus2_errors() -> None:
    assert issubclass(I2cError, OSError)


# ---- bytes on the wire (protocol/i2c-socket.md) -----------------------------------------------
def test_write_byte_data_sends_op_1_with_one_data_byte(tmp_path: Path) -> None:
    with peer(tmp_path, [(5, b"\x00\x00")]) as p, SocketI2cBus(p.path) as bus:
        bus.write_byte_data(0x40, 0xFE, 0x05)
    assert p.requests == [bytes.fromhex("01 40 fe 01 05")]


def test_read_byte_data_sends_op_2_and_returns_the_byte(tmp_path: Path) -> None:
    with peer(tmp_path, [(4, b"\x00\x01\x21")]) as p, SocketI2cBus(p.path) as bus:
        assert bus.read_byte_data(0x40, 0x00) == 0x21
    assert p.requests == [bytes.fromhex("02 40 00 00")]


def test_write_i2c_block_data_sends_op_3_with_the_block(tmp_path: Path) -> None:
    with peer(tmp_path, [(8, b"\x00\x00")]) as p, SocketI2cBus(p.path) as bus:
        bus.write_i2c_block_data(0x40, 0x06, [0x00, 0x00, 0x9A, 0x09])
    assert p.requests == [bytes.fromhex("03 40 06 04 00 00 9a 09")]


def test_read_i2c_block_data_sends_op_4_and_returns_a_list(tmp_path: Path) -> None:
    response = bytes.fromhex("00 04 0a 0b 0c 0d")
    with peer(tmp_path, [(4, response)]) as p, SocketI2cBus(p.path) as bus:
        assert bus.read_i2c_block_data(0x40, 0x06, 4) == [0x0A, 0x0B, 0x0C, 0x0D]
    assert p.requests == [bytes.fromhex("04 40 06 04")]


def test_response_split_in_pieces_is_reassembled(tmp_path: Path) -> None:
    script = [(4, b"\x00\x04\x01\x02\x03\x04"), (4, b"\x00\x01\x07")]
    with peer(tmp_path, script, split=True) as p, SocketI2cBus(p.path) as bus:
        assert bus.read_i2c_block_data(0x40, 0x06, 4) == [1, 2, 3, 4]
        assert bus.read_byte_data(0x40, 0xFE) == 7


# ---- errors -----------------------------------------------------------------------------------
def test_nack_raises_i2c_error_and_the_bus_stays_usable(tmp_path: Path) -> None:
    script = [(5, b"\x01\x00"), (4, b"\x00\x01\x11")]
    with peer(tmp_path, script) as p, SocketI2cBus(p.path) as bus:
        nack = r"write_byte_data at 0x41 register 0x00: no device acknowledged"
        with pytest.raises(I2cError, match=nack):
            bus.write_byte_data(0x41, 0x00, 0x10)
        assert bus.read_byte_data(0x40, 0x00) == 0x11


def test_bad_request_raises_i2c_error(tmp_path: Path) -> None:
    with (
        peer(tmp_path, [(4, b"\x02\x00")]) as p,
        SocketI2cBus(p.path) as bus,
        pytest.raises(I2cError, match="malformed"),
    ):
        bus.read_byte_data(0x40, 0x00)


def test_timeout_raises_i2c_error_and_closes_the_bus(tmp_path: Path) -> None:
    with peer(tmp_path, [(4, HANG)]) as p, SocketI2cBus(p.path, timeout_s=0.1) as bus:
        with pytest.raises(I2cError, match=r"no answer from I2C socket .* within 0.1 s"):
            bus.read_byte_data(0x40, 0x00)
        with pytest.raises(I2cError, match="is closed"):
            bus.read_byte_data(0x40, 0x00)


def test_disconnect_raises_i2c_error(tmp_path: Path) -> None:
    with (
        peer(tmp_path, [(5, CLOSE)]) as p,
        SocketI2cBus(p.path) as bus,
        pytest.raises(I2cError, match="closed by the other end"),
    ):
        bus.write_byte_data(0x40, 0x00, 0x00)


def test_response_of_the_wrong_length_raises_i2c_error(tmp_path: Path) -> None:
    with (
        peer(tmp_path, [(4, b"\x00\x00")]) as p,
        SocketI2cBus(p.path) as bus,
        pytest.raises(I2cError, match="sent 0 bytes, expected 1"),
    ):
        bus.read_byte_data(0x40, 0x00)


def test_unknown_status_raises_i2c_error(tmp_path: Path) -> None:
    with (
        peer(tmp_path, [(4, b"\x09\x00")]) as p,
        SocketI2cBus(p.path) as bus,
        pytest.raises(I2cError, match="unknown status 9"),
    ):
        bus.read_byte_data(0x40, 0x00)


def test_connecting_to_a_missing_socket_raises_i2c_error(tmp_path: Path) -> None:
    with pytest.raises(I2cError, match="cannot connect to I2C socket"):
        SocketI2cBus(tmp_path / "nobody.sock")


def test_calls_after_close_raise_i2c_error(tmp_path: Path) -> None:
    with peer(tmp_path, []) as p:
        bus = SocketI2cBus(p.path)
        bus.close()
        bus.close()  # twice is harmless
        with pytest.raises(I2cError, match="is closed"):
            bus.write_byte_data(0x40, 0x00, 0x00)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda b: b.write_byte_data(0x80, 0x00, 0x00), "7-bit address"),
        (lambda b: b.write_byte_data(0x40, 0x100, 0x00), "register"),
        (lambda b: b.write_byte_data(0x40, 0x00, -1), "value"),
        (lambda b: b.write_i2c_block_data(0x40, 0x06, []), "block length 0"),
        (lambda b: b.write_i2c_block_data(0x40, 0x06, [0] * 33), "block length 33"),
        (lambda b: b.write_i2c_block_data(0x40, 0x06, [256]), "data byte"),
        (lambda b: b.read_i2c_block_data(0x40, 0x06, 0), "block length 0"),
    ],
)
def test_out_of_range_arguments_raise_value_error_before_sending(
    tmp_path: Path, call: Callable[[SocketI2cBus], object], match: str
) -> None:
    with (
        peer(tmp_path, []) as p,
        SocketI2cBus(p.path) as bus,
        pytest.raises(ValueError, match=match),
    ):
        call(bus)
    assert p.requests == []


# ---- open_bus ---------------------------------------------------------------------------------
def test_open_bus_unix_spec_gives_a_socket_bus(tmp_path: Path) -> None:
    with peer(tmp_path, [(4, b"\x00\x01\x11")]) as p:
        bus = open_bus(f"unix:{p.path}")
        assert isinstance(bus, SocketI2cBus)
        assert bus.read_byte_data(0x40, 0x00) == 0x11
        bus.close()


@pytest.mark.parametrize("spec", ["/dev/i2c-1", "1"])
def test_open_bus_device_spec_gives_smbus2(spec: str, monkeypatch: pytest.MonkeyPatch) -> None:
    opened: list[int] = []

    class FakeSMBus(smbus2.SMBus):
        def __init__(self, bus: int) -> None:
            opened.append(bus)

    monkeypatch.setattr(smbus2, "SMBus", FakeSMBus)
    assert isinstance(open_bus(spec), FakeSMBus)
    assert opened == [1]


def test_open_bus_missing_adapter_raises_i2c_error() -> None:
    with pytest.raises(I2cError, match="cannot open I2C bus /dev/i2c-987"):
        open_bus("/dev/i2c-987")


@pytest.mark.parametrize(
    "spec", ["", "i2c-1", "/dev/i2c-", "/dev/i2c-1a", "/dev/spidev0.0", "COM3", "-1", "unix"]
)
def test_open_bus_unknown_spec_raises_i2c_error(spec: str) -> None:
    with pytest.raises(I2cError, match="unknown I2C bus"):
        open_bus(spec)


def test_open_bus_empty_socket_path_raises_i2c_error() -> None:
    with pytest.raises(I2cError, match="names no socket"):
        open_bus("unix:")
