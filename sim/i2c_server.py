"""The twin's virtual I²C bus: a Unix-socket server speaking protocol/i2c-socket.md.

The host opens ``unix:/path/to.sock`` instead of ``/dev/i2c-1`` and issues the same
``write_byte_data`` / ``read_byte_data`` / ``write_i2c_block_data`` / ``read_i2c_block_data``
calls; this server applies each one to the device model at that address (the PCA9685 at 0x40 by
default) before answering it.

The server is single-threaded and never blocks: the twin calls :meth:`I2cSocketServer.service`
from its own loop, either on a timer or when :meth:`I2cSocketServer.fileno` (the descriptor of
the server's private selector, readable whenever a connection has something to do) becomes
readable in the twin's selector. Requests are handled one at a time, in arrival order per
connection, so the device state after a run depends only on the requests.
"""

from __future__ import annotations

import contextlib
import errno
import os
import selectors
import socket
import stat
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Protocol

from jackson.common.errors import JacksonError

# ---- wire format (protocol/i2c-socket.md) -----------------------------------------------------
from jackson.protocol.i2c_socket import (
    MAX_ADDRESS,
    MAX_BLOCK,
    OP_READ_BYTE_DATA,
    OP_READ_I2C_BLOCK_DATA,
    OP_WRITE_BYTE_DATA,
    OP_WRITE_I2C_BLOCK_DATA,
    REQUEST_HEADER_SIZE,
    STATUS_BAD_REQUEST,
    STATUS_NACK,
    STATUS_OK,
)
from jackson.protocol.pca9685 import DEFAULT_ADDRESS
from jackson.sim.pca9685 import Pca9685

_WRITE_OPS = (OP_WRITE_BYTE_DATA, OP_WRITE_I2C_BLOCK_DATA)  # the only requests carrying data
_RECV_SIZE = 4096  # [bytes] per recv call
_OUTBOX_LIMIT = 4096  # [bytes] of answers queued before they are sent
_LISTEN_BACKLOG = 8


class I2cDevice(Protocol):
    """A device model on the virtual bus (e.g. :class:`~jackson.sim.pca9685.Pca9685`)."""

    def write(self, reg: int, data: bytes) -> None:
        """Apply one write transaction of ``data`` starting at register ``reg``."""

    def read(self, reg: int, n: int) -> bytes:
        """Return ``n`` bytes of one read transaction starting at register ``reg``."""


class I2cServerError(JacksonError):
    """The server cannot serve at the path it was given."""


@dataclass(slots=True)
class I2cServerCounters:
    """What a server saw. ``requests`` counts every answered request, bad ones included."""

    requests: int = 0
    bad_requests: int = 0  # answered BAD_REQUEST
    nacks: int = 0  # answered NACK (no device at the address)
    connections: int = 0  # clients accepted
    refused: int = 0  # clients turned away while this process had no file descriptor free

    def as_dict(self) -> dict[str, int]:
        return asdict(self)


@dataclass(slots=True, eq=False)
class _Connection:
    sock: socket.socket
    inbox: bytearray = field(default_factory=bytearray)  # received, not yet handled
    outbox: bytearray = field(default_factory=bytearray)  # responses not yet sent
    events: int = selectors.EVENT_READ  # what the selector waits for on this socket


class I2cSocketServer:
    """Unix stream-socket server of the virtual I²C bus (protocol/i2c-socket.md).

    Parameters
    ----------
    path : str or PathLike
        Socket file to create. A stale socket file nobody listens on is replaced.
    devices : mapping of int to I2cDevice or None
        7-bit address -> device model; by default one PCA9685 at 0x40.

    Raises
    ------
    I2cServerError
        ``path`` is another kind of file, a live server's socket, or cannot
        be bound.
    """

    def __init__(
        self, path: str | os.PathLike[str], devices: Mapping[int, I2cDevice] | None = None
    ) -> None:
        self.path = Path(path)
        if devices is None:
            devices = {DEFAULT_ADDRESS: Pca9685()}
        for address in devices:
            if not 0 <= address <= MAX_ADDRESS:
                raise ValueError(f"I2C address {address:#x} is not a 7-bit address")
        self.devices: dict[int, I2cDevice] = dict(devices)
        self.counters = I2cServerCounters()
        self._connections: dict[int, _Connection] = {}  # by file descriptor
        _remove_stale_socket(self.path)
        self._listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            self._listener.bind(str(self.path))
        except OSError as exc:
            self._listener.close()
            raise I2cServerError(f"cannot create I2C socket {self.path}: {exc.strerror}") from exc
        self._listener.listen(_LISTEN_BACKLOG)
        self._listener.setblocking(False)
        self._selector = selectors.DefaultSelector()
        self._selector.register(self._listener, selectors.EVENT_READ, None)
        self._spare: int | None = os.open(os.devnull, os.O_RDONLY)  # for :meth:`_refuse`
        self._closed = False

    def fileno(self) -> int:
        """Descriptor that is readable whenever :meth:`service` has work (epoll/kqueue).

        Register the server itself in the twin's selector (``sel.register(server,
        EVENT_READ)``) and call ``service(0)`` when it reports readable.
        """
        fileno: Callable[[], int] | None = getattr(self._selector, "fileno", None)
        if fileno is None:
            raise I2cServerError("this platform's selector has no descriptor; poll service()")
        return fileno()

    def service(self, timeout_s: float = 0.0) -> int:
        """Accept clients and answer every request that has arrived.

        Waits at most ``timeout_s`` for the first activity, then handles everything that is
        ready (without waiting again) and returns. Each request is applied to its device
        before its response is sent.

        Parameters
        ----------
        timeout_s : float
            Longest wait for activity [s]; 0 polls.

        Returns
        -------
        int
            Number of requests answered (OK, NACK and BAD_REQUEST alike).
        """
        answered = 0
        timeout = max(0.0, timeout_s)
        while True:
            events = self._selector.select(timeout)
            if not events:
                return answered
            for key, mask in events:
                if key.data is None:
                    self._accept()
                else:
                    answered += self._serve(key.data, mask)
            timeout = 0.0

    def close(self) -> None:
        """Disconnect every client, stop listening and remove the socket file."""
        if self._closed:
            return
        self._closed = True
        for conn in list(self._connections.values()):
            self._drop(conn)
        self._selector.unregister(self._listener)
        self._listener.close()
        self._selector.close()
        if self._spare is not None:
            os.close(self._spare)
            self._spare = None
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()

    def __enter__(self) -> I2cSocketServer:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ---- connections --------------------------------------------------------------------------
    def _accept(self) -> None:
        while True:
            try:
                sock, _ = self._listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                if exc.errno not in (errno.EMFILE, errno.ENFILE):
                    return  # the client gave up (ECONNABORTED...): nothing to serve
                self._refuse()
                return
            sock.setblocking(False)
            conn = _Connection(sock)
            self._connections[sock.fileno()] = conn
            self._selector.register(sock, selectors.EVENT_READ, conn)
            self.counters.connections += 1

    def _refuse(self) -> None:
        """No descriptor free: spend the spare one to accept and close the waiting client, so
        it sees the connection end and the listener does not stay readable forever."""
        self.counters.refused += 1
        if self._spare is None:
            return
        os.close(self._spare)
        self._spare = None
        with contextlib.suppress(OSError):
            self._listener.accept()[0].close()
        with contextlib.suppress(OSError):
            self._spare = os.open(os.devnull, os.O_RDONLY)

    def _drop(self, conn: _Connection) -> None:
        self._connections.pop(conn.sock.fileno(), None)
        self._selector.unregister(conn.sock)
        conn.sock.close()

    def _serve(self, conn: _Connection, mask: int) -> int:
        """Receive what is there, answer every complete request, send what the socket takes."""
        if mask & selectors.EVENT_READ:
            try:
                chunk = conn.sock.recv(_RECV_SIZE)
            except (BlockingIOError, InterruptedError):
                chunk = None
            except OSError:  # reset by the peer: a disconnect like any other
                chunk = b""
            if chunk == b"":
                self._drop(conn)  # a partial request left behind is discarded
                return 0
            if chunk:
                conn.inbox += chunk
        answered = 0
        while True:
            while len(conn.outbox) < _OUTBOX_LIMIT:
                request = _take_request(conn.inbox)
                if request is None:
                    break
                conn.outbox += self._answer(*request)
                answered += 1
            if not conn.outbox:
                self._watch(conn, selectors.EVENT_READ)
                return answered
            if not self._flush(conn):
                return answered
            if conn.outbox:
                # The client is not reading: stop reading from it until its answers drain.
                self._watch(conn, selectors.EVENT_WRITE)
                return answered

    def _watch(self, conn: _Connection, events: int) -> None:
        """Wait for ``events`` on the client's socket (a system call only on a change)."""
        if conn.events != events:
            self._selector.modify(conn.sock, events, conn)
            conn.events = events

    def _flush(self, conn: _Connection) -> bool:
        """Send as much of the outbox as the socket takes; False if the peer is gone."""
        try:
            sent = conn.sock.send(conn.outbox)
        except (BlockingIOError, InterruptedError):
            return True
        except OSError:  # broken pipe, reset: the client left without its answers
            self._drop(conn)
            return False
        del conn.outbox[:sent]
        return True

    # ---- requests -----------------------------------------------------------------------------
    def _answer(self, op: int, addr: int, reg: int, length: int, data: bytes) -> bytes:
        """Apply one request to its device and return the response bytes."""
        self.counters.requests += 1
        if not _well_formed(op, addr, length):
            self.counters.bad_requests += 1
            return bytes((STATUS_BAD_REQUEST, 0))
        device = self.devices.get(addr)
        if device is None:
            self.counters.nacks += 1
            return bytes((STATUS_NACK, 0))
        if op in _WRITE_OPS:
            device.write(reg, data)
            return bytes((STATUS_OK, 0))
        n = 1 if op == OP_READ_BYTE_DATA else length
        out = device.read(reg, n)
        if len(out) != n:
            raise RuntimeError(f"device {addr:#04x} returned {len(out)} bytes for a {n}-byte read")
        return bytes((STATUS_OK, n)) + out


def _take_request(inbox: bytearray) -> tuple[int, int, int, int, bytes] | None:
    """Remove one complete request from ``inbox``: (op, addr, reg, len, data), or None.

    A request is 4 header bytes plus, for the write ops only, ``len`` data bytes; so the size of
    any request, well-formed or not, follows from its first and fourth bytes.
    """
    if len(inbox) < REQUEST_HEADER_SIZE:
        return None
    op, addr, reg, length = inbox[:REQUEST_HEADER_SIZE]
    size = REQUEST_HEADER_SIZE + (length if op in _WRITE_OPS else 0)
    if len(inbox) < size:
        return None
    data = bytes(inbox[REQUEST_HEADER_SIZE:size])
    del inbox[:size]
    return op, addr, reg, length, data


def _well_formed(op: int, addr: int, length: int) -> bool:
    if addr > MAX_ADDRESS:
        return False
    if op == OP_WRITE_BYTE_DATA:
        return length == 1
    if op == OP_READ_BYTE_DATA:
        return length == 0
    if op in (OP_WRITE_I2C_BLOCK_DATA, OP_READ_I2C_BLOCK_DATA):
        return 1 <= length <= MAX_BLOCK
    return False


def _remove_stale_socket(path: Path) -> None:
    """Remove a socket file left by a server that is gone; refuse anything else."""
    try:
        mode = path.lstat().st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISSOCK(mode):
        raise I2cServerError(
            f"cannot create I2C socket {path}: a file that is not a socket is there"
        )
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        probe.connect(str(path))
    except OSError:
        path.unlink()  # nobody listens: stale
        return
    finally:
        probe.close()
    raise I2cServerError(f"cannot create I2C socket {path}: another server is listening on it")
