"""The serial transport over a real pty: exclusive, flushed, polled, and it says HELLO again."""

from __future__ import annotations

import os
import queue
import re
import select
import threading
import time
from collections.abc import Iterator

import pytest

from jackson.host.transport import (
    LinkError,
    LinkEvent,
    Reconnection,
    SerialTransport,
    Session,
    StallWatch,
)
from jackson.protocol import (
    Frame,
    FrameDecoder,
    Hello,
    Info,
    Telemetry,
    decode_message,
    encode_frame,
)

INFO = encode_frame(Info(), 200)
"""The device's answer to HELLO: the session starts with it."""


@pytest.fixture
def pty() -> Iterator[tuple[int, str]]:
    master, slave = os.openpty()
    path = os.ttyname(slave)
    yield master, path
    os.close(master)
    os.close(slave)


def device_reads(master: int, want: int, timeout_s: float = 10.0) -> list:
    """Frames the device side reads until ``want`` arrived (or the deadline)."""
    dec = FrameDecoder()
    got: list = []
    deadline = time.monotonic() + timeout_s
    while len(got) < want and time.monotonic() < deadline:
        ready, _, _ = select.select([master], [], [], deadline - time.monotonic())
        if ready:
            got += [decode_message(f) for f in dec.feed(os.read(master, 4096))]
    return got


def next_frame(t: SerialTransport, timeout_s: float = 10.0) -> object:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        item = t.items.get(timeout=timeout_s)
        if not isinstance(item, LinkEvent):
            return item
    raise AssertionError("no frame")


def test_a_second_opener_gets_one_clear_line(pty: tuple[int, str]) -> None:
    _, path = pty
    first = SerialTransport(path)
    first.open()
    try:
        with pytest.raises(LinkError, match="in use by another program"):
            SerialTransport(path).open()
    finally:
        first.close()


def test_bytes_buffered_before_the_session_are_discarded(pty: tuple[int, str]) -> None:
    master, path = pty
    os.write(master, encode_frame(Telemetry(t_us=1), 0))  # a stale frame in the buffer
    t = SerialTransport(path)
    t.open()
    try:
        os.write(master, INFO + encode_frame(Telemetry(t_us=2), 1))
        _, frame = next_frame(t)  # type: ignore[misc]
        assert isinstance(decode_message(frame), Info)
        _, frame = next_frame(t)  # type: ignore[misc]
        assert decode_message(frame) == Telemetry(t_us=2)
        assert t.stale_frames == 0  # discarded with the input buffer, never decoded
    finally:
        t.close()


@pytest.mark.parametrize("reader_thread", [False, True], ids=["inline", "reader-thread"])
def test_frames_a_device_queued_before_the_hello_are_dropped_not_handed_on(
    pty: tuple[int, str], reader_thread: bool
) -> None:
    """A device that streamed into an unread port still holds frames of that time (a USB CDC
    transmit buffer) and sends them after the host opened the port: they are counted stale,
    never handed on, and HELLO goes again until the INFO that starts the session."""
    master, path = pty
    t = SerialTransport(path)
    t.silence_s = 0.2
    t.open(reader_thread=reader_thread)
    try:
        assert [type(m) for m in device_reads(master, 1)] == [Hello]
        stale = b"".join(encode_frame(Telemetry(t_us=k), k) for k in range(50))
        os.write(master, stale)
        got = _events_until(t, "silent")
        assert not [g for g in got if isinstance(g, tuple)]  # nothing of it reached the caller
        silent = got[-1]
        assert isinstance(silent, LinkEvent)
        assert re.fullmatch(
            r"no answer to HELLO for \d+\.\d s; 50 frames from before it dropped", silent.detail
        )
        assert t.stale_frames == 50 and not t.in_session
        assert any(isinstance(m, Hello) for m in device_reads(master, 1))  # asked again
        os.write(master, INFO + encode_frame(Telemetry(t_us=99), 201))
        handed = [g for g in _events_until(t, "never", timeout_s=1.0) if isinstance(g, tuple)]
        assert [type(decode_message(f)) for _, f in handed] == [Info, Telemetry]
        assert t.in_session and t.stale_frames == 50
        assert t.decoder.counters.seq_lost == 0  # nobody was there to read them: not lost
    finally:
        t.close()


def test_a_silent_device_gets_hello_again(pty: tuple[int, str]) -> None:
    master, path = pty
    t = SerialTransport(path)
    t.silence_s = 0.2
    t.open()
    try:
        hellos = [m for m in device_reads(master, 3) if isinstance(m, Hello)]
        assert len(hellos) >= 3  # the first, then one per silent period
        # one connection, one session id: a device still in it resumes instead of restarting
        assert len({h.session for h in hellos}) == 1 and hellos[0].session != 0
        kinds = []
        while True:
            try:
                item = t.items.get_nowait()
            except queue.Empty:
                break
            if isinstance(item, LinkEvent):
                kinds.append(item.kind)
        assert "silent" in kinds
    finally:
        t.close()


def test_a_partial_frame_is_dropped_while_the_line_is_idle(pty: tuple[int, str]) -> None:
    master, path = pty
    t = SerialTransport(path)
    t.open()
    try:
        os.write(master, encode_frame(Telemetry(t_us=3), 0)[:20])  # cut short: nothing follows
        changed = threading.Event()
        deadline = time.monotonic() + 10.0
        while t.decoder.counters.timeouts == 0 and time.monotonic() < deadline:
            changed.wait(0.005)  # the counter has no notification: poll it until the deadline
        assert t.decoder.counters.timeouts == 1  # expired by polling, not by the next byte
        assert t.decoder.pending == 0
    finally:
        t.close()


# ------------------------------------------------ without the reader thread (the daemon's way)


def test_without_the_reader_thread_get_reads_the_port_itself(pty: tuple[int, str]) -> None:
    master, path = pty
    t = SerialTransport(path)
    t.open(reader_thread=False)
    try:
        assert t.spin_s > 0.0  # a pty: polled briefly before blocking
        assert all(th.name != "jackson-serial" for th in threading.enumerate())
        up = t.get(1.0)
        assert isinstance(up, LinkEvent) and up.kind == "up"
        assert t.get(0.01) is None  # nothing sent yet: the wait ends empty
        os.write(master, INFO)
        assert isinstance(decode_message(t.get(10.0)[1]), Info)  # type: ignore[index]
        os.write(master, encode_frame(Telemetry(t_us=7), 0) + encode_frame(Telemetry(t_us=8), 1))
        got = [t.get(10.0), t.get(10.0)]
        assert [decode_message(item[1]) for item in got] == [  # type: ignore[index]
            Telemetry(t_us=7),
            Telemetry(t_us=8),
        ]
        assert any(isinstance(m, Hello) for m in device_reads(master, 1))
    finally:
        t.close()


def test_heard_time_waits_until_the_caller_has_taken_every_frame_read(
    pty: tuple[int, str],
) -> None:
    """An answer queued behind frames the caller has not taken yet is not "unheard": the
    heard clock stays at the read before until the caller has taken them all."""
    master, path = pty
    t = SerialTransport(path)
    t.open(reader_thread=False)
    try:
        up = t.get(1.0)
        assert isinstance(up, LinkEvent) and up.kind == "up"
        assert t.get(0.01) is None  # a read that found nothing: heard up to it
        quiet = t.heard_s()
        assert 0.0 < quiet <= time.monotonic()
        os.write(master, INFO + b"".join(encode_frame(Telemetry(t_us=k), k) for k in range(5)))
        wrote = time.monotonic()
        first = t.get(10.0)  # one read takes all six; the caller has taken one
        assert first is not None and not isinstance(first, LinkEvent)
        assert t.heard_s() == quiet  # five of that read still wait: not heard yet
        for _ in range(4):
            assert t.get(10.0) is not None
            assert t.heard_s() == quiet
        assert t.get(10.0) is not None  # the last of them
        assert t.heard_s() >= wrote  # all taken: heard up to that read
    finally:
        t.close()


def test_heard_time_with_the_reader_thread_follows_the_queue(pty: tuple[int, str]) -> None:
    master, path = pty
    t = SerialTransport(path)
    t.open()
    try:
        assert isinstance(t.get(10.0), LinkEvent)
        os.write(master, INFO + encode_frame(Telemetry(t_us=1), 0))
        wrote = time.monotonic()
        # not read yet, or read and still queued: either way not heard
        assert t.heard_s() < wrote
        assert t.get(10.0) is not None and t.get(10.0) is not None
        # the reader reads on while the port is quiet: its next read, once both were taken,
        # is heard; each get() waits on the reader's queue for it
        deadline = time.monotonic() + 10.0
        while t.heard_s() < wrote:
            assert time.monotonic() < deadline, "the reader never read again"
            assert t.get(0.05) is None
    finally:
        t.close()


def test_without_the_reader_thread_silence_and_partial_frames_are_handled_in_get(
    pty: tuple[int, str],
) -> None:
    master, path = pty
    t = SerialTransport(path)
    t.silence_s = 0.2
    t.open(reader_thread=False)
    try:
        os.write(master, INFO + encode_frame(Telemetry(t_us=3), 0)[:20])  # cut: nothing follows
        kinds: list[str] = []
        deadline = time.monotonic() + 10.0
        while ("silent" not in kinds or t.decoder.counters.timeouts == 0) and (
            time.monotonic() < deadline
        ):
            item = t.get(0.05)
            if isinstance(item, LinkEvent):
                kinds.append(item.kind)
        assert "silent" in kinds
        assert t.decoder.counters.timeouts == 1 and t.decoder.pending == 0
        hellos = [m for m in device_reads(master, 2) if isinstance(m, Hello)]
        assert len(hellos) >= 2  # the first, and again after the silence
    finally:
        t.close()


@pytest.mark.parametrize("reader_thread", [False, True], ids=["inline", "reader-thread"])
def test_time_the_caller_spends_on_a_frame_is_not_silence(
    pty: tuple[int, str], reader_thread: bool
) -> None:
    """A lockstep device (the twin) sends its next frame only after the host's answer to
    this one. A host that works longer than ``silence_s`` on a frame has not heard silence:
    no HELLO (which would restart the device's session and move its telemetry clock)."""
    master, path = pty
    t = SerialTransport(path)
    t.silence_s = 0.2
    t.open(reader_thread=reader_thread)
    try:
        assert [type(m) for m in device_reads(master, 1)] == [Hello]
        os.write(master, INFO)
        for k in range(3):
            os.write(master, encode_frame(Telemetry(t_us=k), k))  # frame k, then the turn
            _first_telemetry(t)  # is the host's
            busy_until = time.monotonic() + 0.5  # the host's work on frame k: 2.5 silence_s
            while time.monotonic() < busy_until:
                sum(range(1000))
        assert t.silences == 0 and t.hellos == 1
        # waiting for a frame that does not come is silence, as before
        kinds: list[str] = []
        deadline = time.monotonic() + 10.0
        while "silent" not in kinds and time.monotonic() < deadline:
            item = t.get(0.05)
            if isinstance(item, LinkEvent):
                kinds.append(item.kind)
        assert t.silences == 1 and t.hellos == 2
    finally:
        t.close()


def _first_telemetry(t: SerialTransport) -> tuple[int, object]:
    """get() until a telemetry frame is handed over (the INFO and link events before it)."""
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline:
        item = t.get(0.05)
        if isinstance(item, tuple) and item[1].type == Telemetry.TYPE:
            return item
    raise AssertionError("no telemetry frame")


def _events_until(t: SerialTransport, kind: str, timeout_s: float = 10.0) -> list[object]:
    """Everything get() hands over until a link event of ``kind`` (or the deadline)."""
    got: list[object] = []
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        item = t.get(0.05)
        if item is None:
            continue
        got.append(item)
        if isinstance(item, LinkEvent) and item.kind == kind:
            break
    return got


@pytest.mark.parametrize("reader_thread", [False, True], ids=["inline", "reader-thread"])
def test_a_lockstep_device_that_stops_is_a_stall_reported_once(
    pty: tuple[int, str], reader_thread: bool
) -> None:
    """No telemetry frame for ``stall_s`` of waiting: one ``stalled`` event naming the wait."""
    master, path = pty
    t = SerialTransport(path)
    t.stall_s = 0.5
    t.stall_backstop_s = 0.5  # the device is this process: no liveness to look at
    t.silence_s = 0.1  # HELLOs and INFO-less silence do not reset the stall's clock
    t.open(reader_thread=reader_thread)
    try:
        os.write(master, INFO + encode_frame(Telemetry(t_us=1), 0))
        _first_telemetry(t)
        back = time.monotonic()  # the host waits for the next frame from here
        got = _events_until(t, "stalled")
        waited = time.monotonic() - back
        assert not [g for g in got if isinstance(g, tuple)]
        stall = got[-1]
        assert isinstance(stall, LinkEvent) and stall.kind == "stalled"
        assert re.fullmatch(
            r"the host waited (0\.[5-9]|1\.\d) s for a telemetry frame: the twin did no work",
            stall.detail,
        )
        assert 0.5 <= waited < 5.0
        assert t.stalled and t.silences >= 2
        # once: waiting on does not report it again
        later = _events_until(t, "stalled", timeout_s=0.5)
        assert not [g for g in later if isinstance(g, LinkEvent) and g.kind == "stalled"]
    finally:
        t.close()


def test_a_device_sending_slowly_is_not_a_stall(pty: tuple[int, str]) -> None:
    """Frames 0.3 s apart, 3 s in all, at a 0.5 s limit: slow progress, no stall."""
    master, path = pty
    t = SerialTransport(path)
    t.stall_s = 0.5
    t.open(reader_thread=False)
    done = threading.Event()

    def device() -> None:
        os.write(master, INFO)
        for k in range(10):
            if done.wait(0.3):  # the device's slowness under test
                return
            os.write(master, encode_frame(Telemetry(t_us=k), k))

    writer = threading.Thread(target=device, daemon=True)
    writer.start()
    try:
        frames = 0
        while frames < 10:
            item = t.get(10.0)
            assert not (isinstance(item, LinkEvent) and item.kind == "stalled")
            frames += isinstance(item, tuple)
        assert not t.stalled
    finally:
        done.set()
        writer.join()
        t.close()


def test_a_host_slow_on_a_frame_or_a_peer_at_work_is_not_a_stall(pty: tuple[int, str]) -> None:
    """Only the time both ends wait counts: the host's work on a frame does not (it is not
    waiting), nor does waiting while a twin in the same process says it works on its frame."""
    master, path = pty
    t = SerialTransport(path)
    t.stall_s = 0.3
    peer_since: list[float | None] = [None]  # the twin: working
    t.peer_waiting = lambda: peer_since[0]
    t.open(reader_thread=False)
    try:
        os.write(master, INFO + encode_frame(Telemetry(t_us=1), 0))
        _first_telemetry(t) and t.waiting_since is None  # at work on the frame
        busy_until = time.monotonic() + 0.6  # the host's work: twice the limit
        while time.monotonic() < busy_until:
            sum(range(1000))
        quiet_until = time.monotonic() + 0.6  # then waits while the twin works: twice again
        while time.monotonic() < quiet_until:
            assert t.get(0.05) is None
        assert not t.stalled
        peer_since[0] = time.monotonic()  # the twin waits for the host too: a deadlock
        got = _events_until(t, "stalled")
        stall = got[-1]
        assert isinstance(stall, LinkEvent) and stall.kind == "stalled"
        assert time.monotonic() - peer_since[0] >= 0.3
    finally:
        t.close()


@pytest.mark.parametrize(
    ("exc", "serial", "lidar"),
    [
        (
            OSError(13, "Permission denied"),
            "permission denied on the serial port /dev/p: add yourself to the dialout group",
            "permission denied on the LiDAR port /dev/p: add yourself to the dialout group",
        ),
        (
            OSError(11, "Resource temporarily unavailable"),
            "serial port /dev/p is in use by another program (a running jackson daemon or "
            "monitor?): stop it first, or look with: fuser -v /dev/p",
            "LiDAR port /dev/p is in use by another program: stop it first, "
            "or look with: fuser -v /dev/p",
        ),
        (
            OSError(2, "No such file or directory"),
            "serial port /dev/p does not exist: is the robot plugged in? "
            "(look for /dev/ttyACM* or /dev/jackson-mcu)",
            "LiDAR port /dev/p does not exist: is the RPLIDAR plugged in? "
            "(look for /dev/ttyUSB* or /dev/jackson-lidar, docs/lidar.md)",
        ),
        (
            OSError(5, "Input/output error"),
            "cannot open serial port /dev/p: [Errno 5] Input/output error",
            "cannot open LiDAR port /dev/p: [Errno 5] Input/output error",
        ),
    ],
)
def test_a_port_that_cannot_be_opened_is_explained_once_for_both_kinds(
    exc: OSError, serial: str, lidar: str
) -> None:
    # one explanation (common/errors.py) for the MCU's port and the LiDAR's, each in its words
    from jackson.host.lidar.rplidar import LidarError
    from jackson.host.lidar.rplidar import open_error as lidar_open_error
    from jackson.host.transport import open_error

    mcu, lid = open_error("/dev/p", exc), lidar_open_error("/dev/p", exc)
    assert isinstance(mcu, LinkError) and isinstance(lid, LidarError)
    assert str(mcu).startswith(serial) and "\n" not in str(mcu)
    assert str(lid).startswith(lidar) and "\n" not in str(lid)


# ---------------------------------------------------------------------- the link's state, alone


def test_reconnection_waits_0_1_s_then_doubles_to_2_s_and_starts_over_once_open(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    now = [100.0]
    monkeypatch.setattr(time, "monotonic", lambda: now[0])
    r = Reconnection()
    r.lost()
    assert r.left_s() == pytest.approx(0.1)
    waits = []
    for _ in range(7):
        r.failed()
        waits.append(round(r.left_s(), 6))
    assert waits == [0.2, 0.4, 0.8, 1.6, 2.0, 2.0, 2.0]
    r.opened()
    r.lost()
    assert r.left_s() == pytest.approx(0.1) and r.count == 1


def test_each_connection_draws_its_own_session_id() -> None:
    s = Session()
    ids = {s.id}
    for _ in range(50):
        s.connected(0.0)
        ids.add(s.id)
    assert len(ids) == 51 and 0 not in ids


def test_a_session_starts_at_its_info_and_counts_the_frames_before_it_stale() -> None:
    s = Session()
    tele = Frame(Telemetry.TYPE, 0, Telemetry(t_us=1).pack())
    info = Frame(Info.TYPE, 1, Info().pack())
    assert s.frames([tele, tele]) == [] and s.stale_frames == 2 and not s.started
    assert s.frames([tele, info, tele]) == [info, tele]
    assert s.started and s.stale_frames == 3
    s.connected(5.0)  # a new connection waits for its own INFO
    assert not s.started and s.wait_s == 5.0


def test_a_stall_is_reported_once_and_only_after_one_more_read_past_the_limit() -> None:
    w = StallWatch()
    w.limit_s = 1.0
    w.peer.backstop_s = 0.0  # no twin to look at: the limit alone decides
    w.waiting_since = 10.0
    assert w.check(10_500_000_000) is None  # 0.5 s: still waiting
    assert w.check(11_000_000_000) is None  # at the limit: one more read first
    event = w.check(11_200_000_000)
    assert event is not None and event.kind == "stalled"
    assert event.detail == "the host waited 1.2 s for a telemetry frame: the twin did no work"
    assert w.stalled and w.check(20_000_000_000) is None  # once


def test_a_telemetry_frame_at_the_limit_disarms_the_stall() -> None:
    w = StallWatch()
    w.limit_s = 1.0
    w.peer.backstop_s = 0.0  # no twin to look at: the limit alone decides
    w.waiting_since = 10.0
    assert w.check(11_000_000_000) is None  # armed
    w.working()  # the read found a telemetry frame
    assert w.check(11_100_000_000) is None and not w.stalled
    assert StallWatch().check(10**12) is None  # no limit: never
