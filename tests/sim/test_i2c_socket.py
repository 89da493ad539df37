"""The virtual I²C bus over a real Unix socket (protocol/i2c-socket.md): raw bytes, end to end."""

from __future__ import annotations

import select
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

import pytest

from jackson.host.actuation.i2c import I2cError, SocketI2cBus
from jackson.protocol.pca9685 import (
    LED_FULL,
    MODE1,
    MODE1_AI,
    MODE1_ALLCALL,
    MODE1_RESTART,
    MODE1_SLEEP,
    MODE2,
    MODE2_OUTDRV,
    PRE_SCALE,
    led_on_l,
    prescale_for,
)
from jackson.sim.i2c_server import I2cServerError, I2cSocketServer
from jackson.sim.pca9685 import Pca9685
from jackson.sim.tb6612 import LEFT_WIRING, RIGHT_WIRING, BridgeMode, bridge_outputs

PCA = 0x40
OK, NACK, BAD = b"\x00\x00", b"\x01\x00", b"\x02\x00"


@pytest.fixture
def server(tmp_path: Path) -> Iterator[I2cSocketServer]:
    srv = I2cSocketServer(tmp_path / "i2c.sock")
    yield srv
    srv.close()


def pca_of(server: I2cSocketServer) -> Pca9685:
    device = server.devices[PCA]
    assert isinstance(device, Pca9685)
    return device


def connect(server: I2cSocketServer) -> socket.socket:
    client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    client.connect(str(server.path))
    client.setblocking(False)
    return client


def answer(server: I2cSocketServer, client: socket.socket, n: int) -> bytes:
    """Service the server until ``n`` response bytes have reached ``client``."""
    received = bytearray()
    deadline = time.monotonic() + 2.0
    while len(received) < n:
        assert time.monotonic() < deadline, f"only {received.hex()} of {n} bytes answered"
        server.service(0.01)
        with suppress(BlockingIOError):
            received += client.recv(n - len(received))
    return bytes(received)


@contextmanager
def serving(server: I2cSocketServer) -> Iterator[I2cSocketServer]:
    """Run the server's service loop in a background thread, as the twin's loop would."""
    stop = threading.Event()

    def loop() -> None:
        while not stop.is_set():
            server.service(0.01)

    thread = threading.Thread(target=loop, daemon=True)
    thread.start()
    try:
        yield server
    finally:
        stop.set()
        thread.join()


# ---- raw bytes --------------------------------------------------------------------------------
def test_spec_examples_byte_for_byte(server: I2cSocketServer) -> None:
    client = connect(server)
    client.sendall(bytes.fromhex("01 40 00 01 21"))  # wake, AI
    assert answer(server, client, 2) == OK
    client.sendall(bytes.fromhex("03 40 06 04 00 00 9a 09"))
    assert answer(server, client, 2) == OK
    client.sendall(bytes.fromhex("02 40 00 00"))
    assert answer(server, client, 3) == bytes.fromhex("00 01 21")
    client.sendall(bytes.fromhex("01 41 00 01 10"))
    assert answer(server, client, 2) == NACK
    client.sendall(bytes.fromhex("07 40 00 00"))
    assert answer(server, client, 2) == BAD
    client.sendall(bytes.fromhex("02 40 fe 00"))
    assert answer(server, client, 3) == bytes.fromhex("00 01 1e")
    assert pca_of(server).channel_duty(0) == 0x99A / 4096
    client.close()


def test_block_read_returns_the_requested_bytes(server: I2cSocketServer) -> None:
    client = connect(server)
    client.sendall(bytes.fromhex("01 40 00 01 21"))  # AI on
    assert answer(server, client, 2) == OK
    client.sendall(bytes.fromhex("04 40 06 04"))
    assert answer(server, client, 6) == bytes.fromhex("00 04 00 00 00 10")  # LED0: full-off


def test_request_split_across_sends_is_buffered(server: I2cSocketServer) -> None:
    client = connect(server)
    client.sendall(bytes.fromhex("01 40 00 01 31"))  # AI on, still asleep
    assert answer(server, client, 2) == OK
    request = bytes.fromhex("03 40 06 04 00 00 00 08")
    for byte in request[:-1]:
        client.send(bytes((byte,)))
        server.service(0.01)
        with pytest.raises(BlockingIOError):
            client.recv(2)
    client.send(request[-1:])
    assert answer(server, client, 2) == OK
    assert pca_of(server).read(led_on_l(0), 4) == bytes.fromhex("00 00 00 08")
    assert server.counters.requests == 2


def test_pipelined_requests_are_answered_in_order(server: I2cSocketServer) -> None:
    client = connect(server)
    client.sendall(
        bytes.fromhex("01 40 fe 01 05")  # PRE_SCALE = 5 (asleep at power-on)
        + bytes.fromhex("02 40 fe 00")
        + bytes.fromhex("02 41 fe 00")
        + bytes.fromhex("02 40 01 00")
    )
    assert answer(server, client, 10) == bytes.fromhex("00 00  00 01 05  01 00  00 01 04")


@pytest.mark.parametrize(
    "request_hex",
    [
        "07 40 00 00",  # unknown op
        "00 40 00 00",  # op 0 is unknown too
        "01 40 00 02 aa bb",  # write_byte_data carries exactly 1 byte
        "01 40 00 00",  # ... not 0
        "02 40 00 01",  # read_byte_data requests no length
        "03 40 06 00",  # an empty block
        "03 40 06 21" + " 00" * 33,  # a block above 32 bytes, consumed whole
        "04 40 06 00",  # reading 0 bytes
        "04 40 06 21",  # reading 33 bytes
        "01 80 00 01 00",  # not a 7-bit address
    ],
)
def test_malformed_request_is_answered_bad_request_and_server_keeps_serving(
    server: I2cSocketServer, request_hex: str
) -> None:
    client = connect(server)
    client.sendall(bytes.fromhex(request_hex) + bytes.fromhex("02 40 00 00"))
    assert answer(server, client, 5) == BAD + bytes.fromhex("00 01 11")
    assert server.counters.bad_requests == 1
    assert server.counters.requests == 2
    assert pca_of(server).read(MODE1, 1) == b"\x11"  # nothing was applied


def test_wrong_address_is_nacked_and_changes_nothing(server: I2cSocketServer) -> None:
    client = connect(server)
    client.sendall(bytes.fromhex("03 41 00 01 00"))
    assert answer(server, client, 2) == NACK
    assert server.counters.nacks == 1
    assert pca_of(server).asleep


def test_disconnect_mid_request_is_normal(server: I2cSocketServer) -> None:
    first = connect(server)
    first.sendall(bytes.fromhex("01 40 00"))  # a partial request
    server.service(0.01)
    first.close()
    server.service(0.01)
    second = connect(server)
    second.sendall(bytes.fromhex("02 40 00 00"))
    assert answer(server, second, 3) == bytes.fromhex("00 01 11")
    assert server.counters.connections == 2
    assert server.counters.bad_requests == 0


def test_concurrent_clients_are_served_independently(server: I2cSocketServer) -> None:
    a, b = connect(server), connect(server)
    a.sendall(bytes.fromhex("01 40 fe"))
    b.sendall(bytes.fromhex("01 40 fe 01 09"))
    assert answer(server, b, 2) == OK
    a.sendall(bytes.fromhex("01 07"))  # completes a's request "01 40 fe 01 07"
    assert answer(server, a, 2) == OK
    assert pca_of(server).read(PRE_SCALE, 1) == b"\x07"


def test_client_that_reads_late_gets_every_answer(server: I2cSocketServer) -> None:
    count = 100_000  # far more answers than a socket buffers: the server must hold back
    requests = bytes.fromhex("02 40 fe 00") * count
    client = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    client.connect(str(server.path))
    sender = threading.Thread(target=client.sendall, args=(requests,))
    sender.start()
    answered = 0
    deadline = time.monotonic() + 5.0
    while answered < count // 2 and time.monotonic() < deadline:
        answered += server.service(0.01)  # nobody reads yet: answers pile up
    received = bytearray()
    client.settimeout(0.01)
    while len(received) < 3 * count:
        assert time.monotonic() < deadline + 10.0
        answered += server.service(0.0)
        with suppress(TimeoutError):
            received += client.recv(65536)
    sender.join()
    assert answered == count
    assert bytes(received) == bytes.fromhex("00 01 1e") * count
    client.close()


def test_fileno_is_readable_when_work_is_pending(server: I2cSocketServer) -> None:
    assert select.select([server], [], [], 0.0)[0] == []
    client = connect(server)
    assert select.select([server], [], [], 1.0)[0] == [server]  # a connection to accept
    server.service(0.0)
    assert select.select([server], [], [], 0.0)[0] == []
    client.sendall(bytes.fromhex("02 40 00 00"))
    assert select.select([server], [], [], 1.0)[0] == [server]
    assert server.service(0.0) == 1


def test_service_returns_0_after_its_timeout_when_idle(server: I2cSocketServer) -> None:
    start = time.monotonic()
    assert server.service(0.05) == 0
    assert time.monotonic() - start >= 0.04


def test_close_removes_the_socket_file(tmp_path: Path) -> None:
    path = tmp_path / "bus.sock"
    srv = I2cSocketServer(path)
    assert path.exists()
    srv.close()
    assert not path.exists()
    srv.close()  # twice is harmless


def test_stale_socket_file_is_replaced(tmp_path: Path) -> None:
    path = tmp_path / "bus.sock"
    stale = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    stale.bind(str(path))
    stale.close()  # the file stays, nobody listens
    with I2cSocketServer(path) as srv:
        client = connect(srv)
        client.sendall(bytes.fromhex("02 40 00 00"))
        assert answer(srv, client, 3) == bytes.fromhex("00 01 11")


def test_a_live_server_socket_is_not_taken_over(server: I2cSocketServer) -> None:
    with pytest.raises(I2cServerError, match="another server"):
        I2cSocketServer(server.path)


def test_a_regular_file_is_not_replaced(tmp_path: Path) -> None:
    path = tmp_path / "bus.sock"
    path.write_text("keep me")
    with pytest.raises(I2cServerError, match="not a socket"):
        I2cSocketServer(path)
    assert path.read_text() == "keep me"


# ---- end to end: the host's client against the twin's server ----------------------------------
def set_channel(bus: SocketI2cBus, channel: int, duty: float) -> None:
    """What the host's PCA9685 driver sends for one channel: one 4-byte auto-increment block."""
    if duty >= 1.0:
        regs = [0x00, LED_FULL, 0x00, 0x00]  # full-on
    elif duty <= 0.0:
        regs = [0x00, 0x00, 0x00, LED_FULL]  # full-off
    else:
        off = round(duty * 4096)
        regs = [0x00, 0x00, off & 0xFF, off >> 8]
    bus.write_i2c_block_data(PCA, led_on_l(channel), regs)


def test_host_drives_left_forward_60_and_right_reverse_30(server: I2cSocketServer) -> None:
    with serving(server), SocketI2cBus(server.path) as bus:
        # init sequence: sleep, set the prescaler, wake, wait for the oscillator, restart + AI
        bus.write_byte_data(PCA, MODE1, MODE1_SLEEP | MODE1_ALLCALL)
        bus.write_byte_data(PCA, PRE_SCALE, prescale_for(1000.0))
        bus.write_byte_data(PCA, MODE1, MODE1_ALLCALL)
        time.sleep(500e-6)
        bus.write_byte_data(PCA, MODE1, MODE1_RESTART | MODE1_AI | MODE1_ALLCALL)
        bus.write_byte_data(PCA, MODE2, MODE2_OUTDRV)
        # left forward at 60 %: IN1 high, IN2 low, PWM 0.6
        set_channel(bus, LEFT_WIRING.in1, 1.0)
        set_channel(bus, LEFT_WIRING.in2, 0.0)
        set_channel(bus, LEFT_WIRING.pwm, 0.6)
        # right reverse at 30 %: IN1 low, IN2 high, PWM 0.3
        set_channel(bus, RIGHT_WIRING.in1, 0.0)
        set_channel(bus, RIGHT_WIRING.in2, 1.0)
        set_channel(bus, RIGHT_WIRING.pwm, 0.3)
        # every call has returned, so the twin holds every register
        assert bus.read_byte_data(PCA, MODE1) == MODE1_AI | MODE1_ALLCALL
        assert bus.read_i2c_block_data(PCA, led_on_l(LEFT_WIRING.pwm), 4) == [0, 0, 0x9A, 0x09]
        pca = pca_of(server)
        left, right = bridge_outputs(pca, LEFT_WIRING, RIGHT_WIRING, stby_channel=None)
    assert pca.frequency_hz == pytest.approx(1017.25, abs=0.01)
    assert left.mode is BridgeMode.CW
    assert left.drive == pytest.approx(0.6, abs=1 / 4096)
    assert right.mode is BridgeMode.CCW
    assert right.drive == pytest.approx(-0.3, abs=1 / 4096)
    assert server.counters.bad_requests == server.counters.nacks == 0


def test_host_gets_i2c_error_for_a_wrong_address_and_keeps_working(
    server: I2cSocketServer,
) -> None:
    with serving(server), SocketI2cBus(server.path) as bus:
        with pytest.raises(I2cError, match="no device acknowledged"):
            bus.write_byte_data(0x41, MODE1, 0x00)
        assert bus.read_byte_data(PCA, PRE_SCALE) == 0x1E


def test_two_host_clients_one_after_another(server: I2cSocketServer) -> None:
    with serving(server):
        with SocketI2cBus(server.path) as bus:
            bus.write_byte_data(PCA, PRE_SCALE, 0x79)
        with SocketI2cBus(server.path) as bus:
            assert bus.read_byte_data(PCA, PRE_SCALE) == 0x79


def test_out_of_file_descriptors_a_new_client_is_refused_and_the_bus_serves_on(
    server: I2cSocketServer,
) -> None:
    """With every descriptor of the process taken (EMFILE), a connecting client is accepted
    and closed at once on the server's spare descriptor; the clients already connected are
    still answered, and new ones are served once descriptors are free again."""
    import errno
    import os

    first = connect(server)
    first.sendall(bytes((0x02, PCA, MODE2, 0)))
    assert answer(server, first, 3)[0] == 0  # accepted and served (status OK)
    filler: list[int] = []
    try:
        while True:  # take every free descriptor
            try:
                filler.append(os.open(os.devnull, os.O_RDONLY))
            except OSError as exc:
                assert exc.errno == errno.EMFILE
                break
            if len(filler) > 1_000_000:
                pytest.skip("no descriptor limit on this machine")
        os.close(filler.pop())  # one for the client's socket
        late = connect(server)  # sits in the backlog until accepted
        served = server.counters.connections
        server.service(0.1)
        assert server.counters.refused >= 1
        assert server.counters.connections == served
        first.sendall(bytes((0x02, PCA, MODE2, 0)))  # read MODE2 with no descriptor free
        assert answer(server, first, 3)[0] == 0
        late.setblocking(True)
        late.settimeout(5)
        assert late.recv(16) == b""  # the refused client sees the connection closed
        late.close()
    finally:
        for fd in filler:
            os.close(fd)
    again = connect(server)
    again.sendall(bytes((0x02, PCA, MODE2, 0)))
    assert answer(server, again, 3)[0] == 0
    again.close()
    first.close()
