"""The host's I²C bus: one small interface, a real bus (smbus2) or the twin's socket behind it.

Everything on the host that talks to an I²C chip (the PCA9685 driver) takes an :class:`I2cBus`
and never knows which bus it got: ``open_bus("/dev/i2c-1")`` on the robot,
``open_bus("unix:/path/to.sock")`` against the digital twin (protocol/i2c-socket.md).
"""

from __future__ import annotations

import functools
import os
import socket
import struct
from collections.abc import Sequence
from types import TracebackType
from typing import Protocol, runtime_checkable

from jackson.common.errors import JacksonError
from jackson.common.spin import DEFAULT_SPIN_S, peer_is_this_process, spin_poll

# ---- wire format (protocol/i2c-socket.md) -----------------------------------------------------
from jackson.protocol.i2c_socket import (
    MAX_ADDRESS,
    MAX_BLOCK,
    OP_READ_BYTE_DATA,
    OP_READ_I2C_BLOCK_DATA,
    OP_WRITE_BYTE_DATA,
    OP_WRITE_I2C_BLOCK_DATA,
    RESPONSE_HEADER_SIZE,
    STATUS_BAD_REQUEST,
    STATUS_NACK,
    STATUS_OK,
)

SOCKET_PREFIX = "unix:"
DEFAULT_TIMEOUT_S = 2.0  # [s] longest wait for one response

_HEADER = struct.Struct("4B")
_OP_NAMES = {
    OP_WRITE_BYTE_DATA: "write_byte_data",
    OP_READ_BYTE_DATA: "read_byte_data",
    OP_WRITE_I2C_BLOCK_DATA: "write_i2c_block_data",
    OP_READ_I2C_BLOCK_DATA: "read_i2c_block_data",
}


class I2cError(JacksonError, OSError):
    """An I²C transfer or bus failed: no device answered, timeout, lost link, bad bus spec.

    A subclass of OSError because smbus2 reports the same failures on a real bus as OSError
    (a NACK is errno 121, EREMOTEIO), so ``except OSError`` covers either bus.
    """


@runtime_checkable
class I2cBus(Protocol):
    """The SMBus calls the host uses; ``smbus2.SMBus`` satisfies it as it is.

    Addresses are 7-bit, registers and values 8-bit, blocks 1..32 bytes.
    """

    def write_byte_data(self, i2c_addr: int, register: int, value: int) -> None:
        """Write one byte to ``register`` of the device at ``i2c_addr``."""

    def read_byte_data(self, i2c_addr: int, register: int) -> int:
        """Read one byte from ``register`` of the device at ``i2c_addr``."""

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: Sequence[int]) -> None:
        """Write ``data`` in one transaction starting at ``register``."""

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int) -> list[int]:
        """Read ``length`` bytes in one transaction starting at ``register``."""

    def close(self) -> None:
        """Release the bus."""


class SocketI2cBus:
    """:class:`I2cBus` over the twin's Unix socket (protocol/i2c-socket.md).

    Every call sends one request and blocks until its response, so when a call returns the
    twin has applied it.

    Parameters
    ----------
    path : str or PathLike
        The twin's I²C socket file.
    timeout_s : float
        Longest wait for a response [s]; after a timeout the bus is closed, since a
        late response would be taken for the next one.
    spin_s : float or None
        How long to poll for a response before blocking [s] (jackson.common.spin);
        None: :data:`~jackson.common.spin.DEFAULT_SPIN_S` when the twin is another
        process, 0 when it runs in this one.

    Raises
    ------
    I2cError
        The socket cannot be connected.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        timeout_s: float = DEFAULT_TIMEOUT_S,
        spin_s: float | None = None,
    ) -> None:
        self.path = os.fspath(path)
        self.timeout_s = timeout_s
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.settimeout(timeout_s)
        try:
            sock.connect(self.path)
        except OSError as exc:
            sock.close()
            reason = exc.strerror or str(exc)
            raise I2cError(f"cannot connect to I2C socket {self.path}: {reason}") from exc
        self._sock: socket.socket | None = sock
        if spin_s is None:
            spin_s = 0.0 if peer_is_this_process(sock) else DEFAULT_SPIN_S
        self.spin_s = spin_s

    def write_byte_data(self, i2c_addr: int, register: int, value: int) -> None:
        """Write one byte to ``register`` of the device at ``i2c_addr``.

        Raises
        ------
        I2cError
            No device answered, or the link failed.
        ValueError
            An argument is out of range.
        """
        _check_byte("value", value)
        self._transfer(OP_WRITE_BYTE_DATA, i2c_addr, register, 1, bytes((value,)))

    def read_byte_data(self, i2c_addr: int, register: int) -> int:
        """Read one byte from ``register`` of the device at ``i2c_addr``.

        Raises
        ------
        I2cError
            No device answered, or the link failed.
        ValueError
            An argument is out of range.
        """
        return self._transfer(OP_READ_BYTE_DATA, i2c_addr, register, 0, b"", expect=1)[0]

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: Sequence[int]) -> None:
        """Write ``data`` (1..32 bytes) in one transaction starting at ``register``.

        Raises
        ------
        I2cError
            No device answered, or the link failed.
        ValueError
            An argument is out of range.
        """
        _check_length(len(data))
        try:
            payload = bytes(data)
        except ValueError:
            for value in data:
                _check_byte("data byte", value)
            raise
        self._transfer(OP_WRITE_I2C_BLOCK_DATA, i2c_addr, register, len(payload), payload)

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int) -> list[int]:
        """Read ``length`` (1..32) bytes in one transaction starting at ``register``.

        Raises
        ------
        I2cError
            No device answered, or the link failed.
        ValueError
            An argument is out of range.
        """
        _check_length(length)
        return list(
            self._transfer(OP_READ_I2C_BLOCK_DATA, i2c_addr, register, length, b"", expect=length)
        )

    def close(self) -> None:
        """Disconnect from the twin; later calls raise :class:`I2cError`."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def __enter__(self) -> SocketI2cBus:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _transfer(
        self, op: int, addr: int, reg: int, length: int, data: bytes, expect: int = 0
    ) -> bytes:
        """Send one request and return the data of its OK response.

        The per-call path formats nothing: the error message is built only when a call fails.
        """
        if not 0 <= addr <= MAX_ADDRESS:
            raise ValueError(f"I2C address {addr:#x} is not a 7-bit address")
        _check_byte("register", reg)
        sock = self._sock
        if sock is None:
            raise I2cError(f"{_what(op, addr, reg)}: I2C socket {self.path} is closed")
        try:
            sock.sendall(_HEADER.pack(op, addr, reg, length) + data)
            status, n, payload = self._receive(sock, expect, op, addr, reg)
        except TimeoutError as exc:
            self.close()
            raise I2cError(
                f"{_what(op, addr, reg)}: no answer from I2C socket {self.path} "
                f"within {self.timeout_s} s"
            ) from exc
        except OSError as exc:
            if isinstance(exc, I2cError):
                raise
            self.close()
            reason = exc.strerror or str(exc)
            raise I2cError(
                f"{_what(op, addr, reg)}: I2C socket {self.path} failed: {reason}"
            ) from exc
        if status == STATUS_OK and n == expect:
            return payload
        what = _what(op, addr, reg)
        if status == STATUS_NACK:
            raise I2cError(f"{what}: no device acknowledged on I2C socket {self.path}")
        if status == STATUS_BAD_REQUEST:
            raise I2cError(f"{what}: I2C socket {self.path} rejected the request as malformed")
        if status != STATUS_OK:
            self.close()
            raise I2cError(f"{what}: I2C socket {self.path} answered unknown status {status}")
        self.close()
        raise I2cError(f"{what}: I2C socket {self.path} sent {n} bytes, expected {expect}")

    def _receive(
        self, sock: socket.socket, expect: int, op: int, addr: int, reg: int
    ) -> tuple[int, int, bytes]:
        """One response: (status, length, data). The first read asks for the header and the
        ``expect`` bytes of an OK answer together (one system call for the usual response);
        a shorter answer (NACK, BAD_REQUEST) is complete once its header's length arrived."""
        buf = b""
        size = RESPONSE_HEADER_SIZE + expect  # until the header tells
        while len(buf) < size:
            want = size - len(buf)
            chunk = self._recv(sock, want)
            if not chunk:
                self.close()
                raise I2cError(
                    f"{_what(op, addr, reg)}: I2C socket {self.path} closed by the other end"
                )
            buf += chunk
            if len(buf) >= RESPONSE_HEADER_SIZE:
                size = RESPONSE_HEADER_SIZE + buf[1]
        if len(buf) > size:  # only one request is ever outstanding: cannot happen on the wire
            self.close()
            raise I2cError(
                f"{_what(op, addr, reg)}: I2C socket {self.path} sent more than one response"
            )
        return buf[0], buf[1], buf[RESPONSE_HEADER_SIZE:]

    def _recv(self, sock: socket.socket, n: int) -> bytes:
        """Up to ``n`` bytes: polled for :attr:`spin_s` first when spinning, else a blocking
        read (with the twin in this process nobody can answer while this thread polls)."""
        if self.spin_s <= 0.0:
            return sock.recv(n)
        got = spin_poll(functools.partial(_recv_now, sock, n), self.spin_s)
        return got[0] if got else sock.recv(n)


def _what(op: int, addr: int, reg: int) -> str:
    """The call named for an error message."""
    return f"{_OP_NAMES[op]} at {addr:#04x} register {reg:#04x}"


def _recv_now(sock: socket.socket, n: int) -> tuple[bytes] | tuple[()]:
    """``(chunk,)`` if the socket has data or is closed (``b""``), ``()`` if it would block."""
    try:
        return (sock.recv(n, socket.MSG_DONTWAIT),)
    except (BlockingIOError, InterruptedError):
        return ()


class I2cSpecError(I2cError):
    """A bus name that is none of ``/dev/i2c-N``, ``N`` or ``unix:/path``: no retry can help."""


def check_bus_spec(spec: str) -> None:
    """Raise :class:`I2cSpecError` unless ``spec`` names a bus in a form :func:`open_bus` knows."""
    if spec.startswith(SOCKET_PREFIX):
        if len(spec) == len(SOCKET_PREFIX):
            raise I2cSpecError(f"I2C bus {spec!r} names no socket: expected unix:/path/to.sock")
        return
    number = spec.removeprefix("/dev/i2c-")
    if not number.isdigit() or not number.isascii():
        raise I2cSpecError(
            f"unknown I2C bus {spec!r}: expected /dev/i2c-N, N or unix:/path/to.sock"
        )


def open_bus(spec: str) -> I2cBus:
    """Open the I²C bus named by ``spec``.

    Parameters
    ----------
    spec : str
        ``unix:/path/to.sock`` for the twin's socket, ``/dev/i2c-N`` or ``N`` for a
        Linux I²C adapter (smbus2, imported only then).

    Returns
    -------
    I2cBus
        The open bus.

    Raises
    ------
    I2cError
        ``spec`` is none of these forms, or the bus cannot be opened.
    """
    check_bus_spec(spec)
    if spec.startswith(SOCKET_PREFIX):
        return SocketI2cBus(spec[len(SOCKET_PREFIX) :])
    number = spec.removeprefix("/dev/i2c-")
    try:
        import smbus2  # only the robot needs it
    except ImportError as exc:
        raise I2cError(f"cannot open I2C bus /dev/i2c-{number}: smbus2 is not installed") from exc
    try:
        return smbus2.SMBus(int(number))
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise I2cError(f"cannot open I2C bus /dev/i2c-{number}: {reason}") from exc


def _check_byte(name: str, value: int) -> None:
    if not 0 <= value <= 0xFF:
        raise ValueError(f"I2C {name} {value} outside 0..255")


def _check_length(length: int) -> None:
    if not 1 <= length <= MAX_BLOCK:
        raise ValueError(f"I2C block length {length} outside 1..{MAX_BLOCK}")
