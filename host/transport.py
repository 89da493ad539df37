"""The serial link to the MCU: the reader, the handshake, reconnection.

The reader owns the port: it opens it exclusively (a second program opening the same port
gets one clear line instead of stealing frames), discards whatever was buffered, sends HELLO,
reads, decodes and hands every frame on with the host's receive time. It runs either in its own
thread, queueing what it gets, or (``open(reader_thread=False)``, as the daemon and the monitor
run it) in the caller's thread inside :meth:`SerialTransport.get`, so a telemetry frame reaches
the frame loop without a hand-over between threads (in lockstep with the twin, one wake-up per
frame fewer; on the twin's pty it polls briefly before it blocks). While no byte arrives it
polls the decoder every few milliseconds, so a partial frame is dropped 20 ms after its last
byte arrived (protocol/spec.md §5.2). When the port disappears (USB unplugged, the twin's pty
closed) it reports the link down and retries forever with backoff from 0.1 s to 2 s; on success
it sends HELLO again. When the port stays open but the device falls silent (an MCU reset behind
a UART bridge ends the session), it re-sends HELLO every ``silence_s``. The daemon never
restarts.

**One session id per connection.** Every HELLO carries the connection's session id (drawn at
random each time the port is opened, protocol/spec.md §6.3). A device still in that session
answers a repeated HELLO without restarting anything, so a HELLO sent after a silence that was
only this host being slow (a busy machine, a twin starved of CPU) leaves the device's interlock,
telemetry schedule and IMU averaging as they were; a device that did reset has no session and
starts the new one.

**A session starts at the answer to its HELLO.** A device that streamed while nobody read its
port (a real USB CDC device's transmit buffer; the twin's 8 KiB queue behind its pty) still
holds frames of that time when a host opens the port, and they arrive after the host has
discarded its own input buffer. Until the INFO that answers this connection's HELLO, every
decoded frame is dropped and counted (:attr:`SerialTransport.stale_frames`), never handed on:
they belong to nobody's session, so they are neither decoded as measurements nor counted as
lost. Without an INFO, HELLO is sent again every ``silence_s`` and a ``silent`` event says so
(the daemon turns the first into ``no answer on PORT: ...``).

Writes come from the daemon's thread and never block: a write to a link that is down
is dropped and counted.

**Lockstep stall.** A twin in lockstep sends telemetry frame k+1 only after the host's HEARTBEAT
of frame k; a twin that stops (a stopped or killed process, or both ends waiting for each other)
leaves the host waiting for ever. With :attr:`SerialTransport.stall_s` set (the daemon sets it on
a twin's pty, :data:`STALL_S` by default) the link looks at the twin once the caller has waited
that long for a telemetry frame (only the time it spends waiting counts, not its work on a
frame): how long the twin takes says nothing on a busy machine, so it is judged by its liveness
(:mod:`jackson.common.liveness`: the processes holding the pty's master, or the twin's thread in
this process, :meth:`SerialTransport.twin_thread`). A twin whose CPU time advances is working and
is waited for; a ``stalled`` :class:`LinkEvent` is reported, once, only when the twin is gone or
stopped, or alive but idle while it says it waits too (:attr:`SerialTransport.peer_waiting`, a
twin in this process), or idle for the backstop (:data:`~jackson.common.liveness.BACKSTOP_S`).
The port is read once more after the verdict before the stall is declared, so a frame that
arrived while this process was kept from running is taken, not missed. Before the session (no
answer to the HELLO yet) there is no stall: a mute device is reported silent.
"""

from __future__ import annotations

import contextlib
import os
import queue
import select
import stat
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from termios import error as termios_error
from typing import Literal, Protocol

import serial

from jackson.common.errors import JacksonError, PortKind, port_open_message
from jackson.common.liveness import Peer, PeerWatch, ProcessPeer, ThreadPeer, Verdict, pty_peers
from jackson.common.spin import DEFAULT_SPIN_S, spin_poll
from jackson.common.threads import guard
from jackson.protocol import (
    Frame,
    FrameDecoder,
    Info,
    Message,
    Telemetry,
    encode_frame,
    hello,
    new_session_id,
)
from jackson.protocol.frame import CRC_SIZE, HEADER_SIZE

FIRST_BACKOFF_S = 0.1
MAX_BACKOFF_S = 2.0
READ_TIMEOUT_S = 0.005  # [s] the reader's longest block: the decoder is polled this often
SILENCE_S = 1.0  # [s] no frame for this long on an open port: send HELLO again
TELEMETRY_FRAME_SIZE = HEADER_SIZE + Telemetry.SIZE + CRC_SIZE  # [bytes] one frame on the wire
STALL_S = 10.0  # [s] of waiting without a telemetry frame before the twin's liveness is looked at
TWIN_REASONS: dict[Verdict, str] = {
    "gone": "the twin process is gone",
    "stopped": "the twin process is stopped",
    "idle": "the twin did no work",
}


class LinkError(JacksonError, RuntimeError):
    """The serial port cannot be used at all (missing, no permission): one line for the user."""


@dataclass(frozen=True)
class LinkEvent:
    """A change of the link's state, in the frame queue between frames."""

    kind: Literal["up", "down", "silent", "stalled"]
    rx_time_ns: int
    detail: str = ""


Item = tuple[int, Frame] | LinkEvent


MCU_PORT = PortKind(
    "serial port",
    "the robot",
    "/dev/ttyACM* or /dev/jackson-mcu",
    " (a running jackson daemon or monitor?)",
)


def open_error(port: str, exc: BaseException) -> LinkError:
    """A one-line explanation of why the MCU's ``port`` cannot be opened."""
    return LinkError(port_open_message(MCU_PORT, port, exc))


class Link(Protocol):
    """What the daemon needs of its link to the MCU. :class:`SerialTransport` (a USB serial
    port or the twin's pty) is the one the project ships; another link (a TCP bridge, a test's
    in-memory pair) implements these members."""

    port_name: str  # where it goes, for messages
    decoder: FrameDecoder  # the receive side's decoder (its counters; a version mismatch)
    silence_s: float  # an open link without a frame for this long gets HELLO again [s]
    stall_s: float | None  # lockstep: wall seconds without telemetry before a stall (None: off)
    link_up: bool  # the link is open
    silences: int  # times it fell silent for silence_s

    @property
    def reconnects(self) -> int:
        """Times the link was opened again after a loss."""
        ...

    @property
    def on_pty(self) -> bool:
        """The link is the twin's pseudo-terminal (lockstep may stall)."""
        ...

    def backlog_frames(self) -> int:
        """Telemetry frames' worth of what came and was not handed on yet: decoded and queued,
        or still unread on the port. After the caller was kept from running, a device that
        went on streaming left many; a twin in lockstep, which waited for the caller, one."""
        ...

    def heard_s(self) -> float:
        """Monotonic time [s] up to which everything received has been handed to the caller
        (:meth:`SerialTransport.heard_s`): commands' answers are awaited on it."""
        ...

    def encode(self, msg: Message) -> bytes:
        """The frame of ``msg`` with this link's next SEQ."""
        ...

    def send_raw(self, frame: bytes) -> bool:
        """Write one encoded frame; False when it could not be written."""
        ...

    def get(self, timeout_s: float) -> Item | None:
        """The next received frame (with its receive time [ns]) or link event, waiting at most
        ``timeout_s``; None when nothing came."""
        ...


class Reconnection:
    """When a lost port is tried again: :data:`FIRST_BACKOFF_S` after the loss, the wait
    doubling up to :data:`MAX_BACKOFF_S` while it fails, back to the first once it opens."""

    def __init__(self) -> None:
        self.count = 0  # times the port was opened again
        self._backoff_s = FIRST_BACKOFF_S
        self._at_s = 0.0  # the next attempt (monotonic s)

    def lost(self) -> None:
        """The port went away: the next attempt after the current backoff."""
        self._at_s = time.monotonic() + self._backoff_s

    def left_s(self) -> float:
        """Wall seconds to the next attempt (zero or less: due)."""
        return self._at_s - time.monotonic()

    def opened(self) -> None:
        """An attempt opened the port."""
        self.count += 1
        self._backoff_s = FIRST_BACKOFF_S

    def failed(self) -> None:
        """An attempt failed: the backoff doubles."""
        self._backoff_s = min(MAX_BACKOFF_S, self._backoff_s * 2)
        self._at_s = time.monotonic() + self._backoff_s


class Session:
    """This connection's session (the module's notes): it starts at the INFO that answers the
    connection's HELLO; the frames decoded before it are stale, dropped and counted."""

    def __init__(self) -> None:
        self.started = False  # this connection's INFO arrived
        self.stale_frames = 0  # frames dropped before the INFO (an earlier time's, buffered)
        self.hellos = 0  # HELLOs sent (first, after reconnects, after silence)
        self.hello_s = 0.0  # the last HELLO (monotonic s)
        self.wait_s = 0.0  # since when this connection waits for its INFO (monotonic s)
        self.id = new_session_id()  # this connection's session id, in each of its HELLOs

    def connected(self, now_s: float) -> None:
        """A new connection: no session yet, a new session id, its wait for an INFO starts
        ``now_s``."""
        self.started = False
        self.wait_s = now_s
        self.id = new_session_id()

    def hello_sent(self) -> None:
        """A HELLO goes out now."""
        self.hellos += 1
        self.hello_s = time.monotonic()
        if not self.started and self.hellos == 1:
            self.wait_s = self.hello_s  # the wait for an answer starts here

    def frames(self, frames: list[Frame]) -> list[Frame]:
        """The frames from this connection's INFO on; the ones before it are counted stale."""
        for i, frame in enumerate(frames):
            if frame.type == Info.TYPE:
                self.started = True
                return frames[i:]
            self.stale_frames += 1
        return []


class StallWatch:
    """A lockstep stall (the module's notes): the caller has waited :attr:`limit_s` for a
    telemetry frame (and the peer as long for the caller, when :attr:`peer_waiting` says), the
    twin was then judged gone, stopped or idle (:attr:`peer`), and a read after that found no
    telemetry frame."""

    def __init__(self) -> None:
        # wall seconds of waiting without a telemetry frame before the twin is looked at; None:
        # never (a device's port streams on its own clock)
        self.limit_s: float | None = None
        # a twin in this process: since when it waits for this host's HEARTBEAT (monotonic s),
        # None while it works; with it only the time both ends wait counts towards a stall
        self.peer_waiting: Callable[[], float | None] | None = None
        # since when the caller waits for a telemetry frame (monotonic s): from its first get()
        # and from each get() after a telemetry frame; None before and while it works on one
        self.waiting_since: float | None = None
        self.stalled = False  # the "stalled" event was sent
        self.telemetry_rx_s = 0.0  # the last telemetry frame decoded (monotonic s)
        self.peer = PeerWatch()  # the twin's liveness (its finder is set by the transport)
        self._restart_s = 0.0  # the twin was last seen working (monotonic s): the wait restarts
        self._reason: Verdict | None = None  # the verdict: one more read before the stall counts

    def waiting(self) -> None:
        """The caller is back for a frame: its wait starts now unless it already waits."""
        if self.waiting_since is None:  # back after a telemetry frame (or the first call)
            self.waiting_since = time.monotonic()

    def working(self) -> None:
        """The caller got a telemetry frame and works on it: progress, no wait."""
        self.waiting_since = None
        self._reason = None
        self.peer.reset()

    def check(self, now_ns: int, in_session: bool = True) -> LinkEvent | None:
        """The ``stalled`` event, once, when the wait reached the limit, the twin was judged
        gone, stopped or idle, and a read after that found no telemetry frame; else None.
        Never before the session (a device that does not answer its HELLO is silent, not
        stalled)."""
        since = self.waiting_since
        if self.limit_s is None or self.stalled or since is None or not in_session:
            return None
        began = since = max(since, self.telemetry_rx_s)
        since = max(since, self._restart_s)
        if self.peer_waiting is not None:
            peer = self.peer_waiting()
            if peer is None:  # the twin works on its next frame: slow, not stalled
                self._reason = None
                return None
            since = max(since, peer)
        now = now_ns / 1e9
        if now - since < self.limit_s:
            self._reason = None
        elif self._reason is not None:
            self.stalled = True
            return LinkEvent(
                "stalled",
                now_ns,
                f"the host waited {now - began:.1f} s for a telemetry frame: "
                f"{TWIN_REASONS[self._reason]}",
            )
        else:
            verdict = self.peer.verdict(now, peer_waits=self.peer_waiting is not None)
            if verdict == "working":
                self._restart_s = now  # slow, not stalled: the wait starts over
            elif verdict is not None:
                self._reason = verdict  # read the port once more before it counts
        return None


class SerialTransport:
    """One serial link to the MCU (or the twin's pty)."""

    def __init__(self, port: str, baudrate: int = 921600) -> None:
        self.port_name = port
        self.baudrate = baudrate
        self.items: queue.Queue[Item] = queue.Queue()
        self.decoder = FrameDecoder()
        self._port: serial.Serial | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._seq = 0
        self.link_up = False
        self.writes_dropped = 0
        self.silences = 0  # times the open port fell silent for silence_s
        self.silence_s = SILENCE_S
        self._last_rx_s = 0.0
        # silence is counted while the caller waits, not while it works on a frame: a
        # lockstep device (the twin) sends the next frame only after the HEARTBEAT the
        # caller sends once done with this one
        self._handed_frame = False  # get() returned a frame; the caller is busy with it
        self._back_s = 0.0  # when the caller last came back to get() after a frame
        self.spin_s = 0.0  # without the reader thread: poll this long before blocking [s]
        self._reconnection = Reconnection()
        self._session = Session()
        self._stall = StallWatch()
        self._stall.peer.peer = Peer(self._find_twin)
        self._twin_thread: int | None = None  # a twin in this process: its thread's native id
        # heard_s: the last read's mark (all the device sent before it is in :attr:`items`),
        # and the newest mark whose frames the caller has all taken
        self._read_mark_ns = 0
        self._heard_ns = 0

    # ------------------------------------------------------------------ state

    @property
    def reconnects(self) -> int:
        """Times the port was opened again after a loss."""
        return self._reconnection.count

    @property
    def hellos(self) -> int:
        """HELLOs sent (the first, after reconnects, after silences)."""
        return self._session.hellos

    @property
    def in_session(self) -> bool:
        """This connection's INFO arrived: its frames are handed on."""
        return self._session.started

    @property
    def stale_frames(self) -> int:
        """Frames dropped before a connection's INFO (an earlier time's, buffered)."""
        return self._session.stale_frames

    @property
    def stall_s(self) -> float | None:
        """Wall seconds of waiting without a telemetry frame before a ``stalled`` event
        (the module's notes); None: never (a device's port streams on its own clock)."""
        return self._stall.limit_s

    @stall_s.setter
    def stall_s(self, value: float | None) -> None:
        self._stall.limit_s = value

    @property
    def stall_backstop_s(self) -> float:
        """Wall seconds a twin that is alive but does no work (or one that cannot be looked
        at) is waited for before a ``stalled`` event (:data:`~jackson.common.liveness.
        BACKSTOP_S` by default)."""
        return self._stall.peer.backstop_s

    @stall_backstop_s.setter
    def stall_backstop_s(self, value: float) -> None:
        self._stall.peer.backstop_s = value

    @property
    def peer_waiting(self) -> Callable[[], float | None] | None:
        """A twin in this process: since when it waits for this host's HEARTBEAT (monotonic
        s), None while it works; with it only the time both ends wait counts towards a stall."""
        return self._stall.peer_waiting

    @peer_waiting.setter
    def peer_waiting(self, value: Callable[[], float | None] | None) -> None:
        self._stall.peer_waiting = value

    def twin_thread(self, native_id: int) -> None:
        """A twin in this process runs in the thread ``native_id``
        (``threading.get_native_id()``): its CPU time tells whether it works."""
        self._twin_thread = native_id

    def _find_twin(self) -> Sequence[ProcessPeer | ThreadPeer] | None:
        """Who the twin is, looked up when a wait first gets long: the thread
        :meth:`twin_thread` named, else the other processes that hold the pty's master (none:
        gone); unknown when this process holds it and named no thread."""
        if self._twin_thread is not None:
            return [ThreadPeer(self._twin_thread)]
        return pty_peers(self.port_name, master=True)

    @property
    def waiting_since(self) -> float | None:
        """Since when the caller waits for a telemetry frame (monotonic s); None before its
        first :meth:`get` and while it works on a telemetry frame."""
        return self._stall.waiting_since

    @property
    def stalled(self) -> bool:
        """The ``stalled`` event was sent."""
        return self._stall.stalled

    def heard_s(self) -> float:
        """Monotonic time [s] up to which the caller has taken everything the device sent.

        A frame is handled only after all that came before it, so an answer the device sent
        before this time has reached the caller by now (:mod:`jackson.host.commands` counts
        its timeouts on this clock). Behind the wall clock by one read while frames of that
        read are still queued, and by as much as the caller lags its input when a busy machine
        slows it; frozen while the port is down. Call it from the thread that calls
        :meth:`get`.
        """
        mark = self._read_mark_ns  # first: a read's frames are queued before its mark is set
        if self.items.empty():
            self._heard_ns = max(self._heard_ns, mark)
        return self._heard_ns / 1e9

    # ------------------------------------------------------------------ lifecycle

    def open(self, reader_thread: bool = True, hello: bool = True) -> None:
        """Open the port once (raises :class:`LinkError`) and send HELLO.

        Parameters
        ----------
        hello : bool
            Send HELLO now. False: the caller sends it (:meth:`send_hello`) once it is ready
            to read, so that a device's session (and a lockstep twin's clock) does not start
            while the host is still setting up.
        reader_thread : bool
            Start the reader thread, which reads, decodes and reconnects on its own and
            queues what it gets (:attr:`items`). False: the caller reads through :meth:`get`
            (the daemon's loop), with no thread and no hand-over between threads per frame;
            on a pty (the twin) :meth:`get` polls for :attr:`spin_s` before it blocks.
        """
        self._connect(hello)
        if not reader_thread:
            self.spin_s = DEFAULT_SPIN_S if _is_pty(self.port_name) else 0.0
            return
        self._thread = threading.Thread(
            target=guard(self._run, "jackson-serial"), name="jackson-serial", daemon=True
        )
        self._thread.start()

    @property
    def on_pty(self) -> bool:
        """Whether the port is a pseudo-terminal: the twin's, not a device's."""
        return _is_pty(self.port_name)

    def backlog_frames(self) -> int:
        """Telemetry frames' worth of what came and was not handed on yet (:class:`Link`)."""
        waiting = 0
        with self._lock:
            port = self._port
            if port is not None:
                with contextlib.suppress(serial.SerialException, OSError, termios_error):
                    waiting = port.in_waiting
        return self.items.qsize() + waiting // TELEMETRY_FRAME_SIZE

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        with self._lock:
            if self._port is not None:
                self._port.close()
                self._port = None

    def _connect(self, hello: bool = True) -> None:
        try:
            port = serial.Serial(
                self.port_name,
                self.baudrate,
                timeout=READ_TIMEOUT_S,
                write_timeout=0,
                exclusive=True,
            )
        except (serial.SerialException, OSError) as exc:
            raise open_error(self.port_name, exc) from exc
        try:
            port.reset_input_buffer()  # bytes of an earlier session are not this one's
        except (serial.SerialException, OSError, termios_error) as exc:
            port.close()
            raise open_error(self.port_name, exc) from exc
        with self._lock:
            self._port = port
        self.decoder = FrameDecoder()  # a new session starts a new stream
        self.decoder.seq_from_type = Info.TYPE  # frames before this session's INFO: not lost
        self.link_up = True
        self._last_rx_s = time.monotonic()
        self._session.connected(self._last_rx_s)
        self.items.put(LinkEvent("up", time.monotonic_ns()))
        if hello:
            self.send_hello()

    def send_hello(self) -> None:
        """HELLO with this connection's session id: starts the device's session, or resumes it
        unchanged when the device is still in it."""
        self._session.hello_sent()
        self.send(hello(self._session.id))

    def _drop(self, detail: str) -> None:
        with self._lock:
            if self._port is not None:
                with contextlib.suppress(OSError):
                    self._port.close()
                self._port = None
        self._reconnection.lost()
        if self.link_up:
            self.link_up = False
            self.items.put(LinkEvent("down", time.monotonic_ns(), detail))

    # ------------------------------------------------------------------ reader thread

    def _run(self) -> None:
        while not self._stop.is_set():
            self._step(MAX_BACKOFF_S)  # reads block for the port's timeout, retries for the backoff

    def _step(self, wait_s: float) -> None:
        """One turn of the reader: a reconnection attempt when the port is gone (after its
        backoff), else one read of what arrived within ``wait_s`` (at most
        :data:`READ_TIMEOUT_S`), decoded into :attr:`items`."""
        port = self._port
        if port is None:
            left = self._reconnection.left_s()
            if left > 0:
                self._stop.wait(min(left, max(wait_s, 0.0)))
                self._check_stall(time.monotonic_ns())
                return
            try:
                self._connect()
                self._reconnection.opened()
            except LinkError:
                self._reconnection.failed()
                self._check_stall(time.monotonic_ns())
            return
        try:
            if self._thread is None and not self._readable(port, wait_s):
                data = b""
            else:
                data = port.read(max(1, port.in_waiting))
            mark = time.monotonic_ns()  # what the device sent before this is read below
            if data:  # the rest of what arrived with the first byte: one decode per wake
                waiting = port.in_waiting
                if waiting:
                    data += port.read(waiting)
        except (serial.SerialException, OSError, TypeError, ValueError) as exc:
            self._drop(str(exc))
            return
        now = time.monotonic_ns()
        dec = self.decoder
        frames = dec.feed(data, now // 1000) if data else dec.poll(now // 1000)
        session = self._session
        if not session.started and frames:
            frames = session.frames(frames)
        for frame in frames:
            self.items.put((now, frame))
            if frame.type == Telemetry.TYPE:
                self._stall.telemetry_rx_s = now / 1e9
        self._read_mark_ns = mark  # after its frames are queued (heard_s reads it first)
        if frames:
            self._last_rx_s = now / 1e9
            return
        self._check_stall(now)
        if not session.started:
            if now / 1e9 - session.hello_s >= self.silence_s:
                # HELLO unanswered (a mute device, or one still busy with another session)
                self.silences += 1
                self._last_rx_s = now / 1e9
                waited = now / 1e9 - session.wait_s
                stale = (
                    f"; {session.stale_frames} frames from before it dropped"
                    if (session.stale_frames)
                    else ""
                )
                self.items.put(
                    LinkEvent("silent", now, f"no answer to HELLO for {waited:.1f} s{stale}")
                )
                self.send_hello()
            return
        if not self._handed_frame and now / 1e9 - max(self._last_rx_s, self._back_s) >= (
            self.silence_s
        ):
            # an open port and a silent device: its session ended (reset) or never began
            self.silences += 1
            self._last_rx_s = now / 1e9
            self.items.put(LinkEvent("silent", now, f"no frame for {self.silence_s:.2f} s"))
            self.send_hello()

    def _check_stall(self, now_ns: int) -> None:
        """Queue the ``stalled`` event (the module's notes) once the wait has reached
        :attr:`stall_s`."""
        event = self._stall.check(now_ns, self._session.started)
        if event is not None:
            self.items.put(event)

    def _readable(self, port: serial.Serial, wait_s: float) -> bool:
        """Without the reader thread: whether bytes wait on the port within ``wait_s``,
        polled first for :attr:`spin_s` (a pty: the twin answers within microseconds)."""
        fd = port.fileno()
        if spin_poll(lambda: select.select([fd], [], [], 0)[0], self.spin_s):
            return True
        return bool(select.select([fd], [], [], max(0.0, min(wait_s, READ_TIMEOUT_S)))[0])

    def get(self, timeout_s: float) -> Item | None:
        """The next frame or link event, waiting at most ``timeout_s``; None if none came.

        With the reader thread (:meth:`open`'s default) this waits on its queue. Without it
        (``open(reader_thread=False)``) the caller's thread reads the port itself, and a frame
        reaches it without a hand-over between threads.

        Parameters
        ----------
        timeout_s : float
            Longest wait [s].

        Returns
        -------
        Item or None
            ``(host receive time [ns], frame)``, a :class:`LinkEvent`, or None.
        """
        if self._handed_frame:  # back from working on a frame: the silence clock restarts
            self._handed_frame = False
            self._back_s = time.monotonic()
        self._stall.waiting()
        if self._thread is not None or self._stop.is_set():
            try:
                return self._hand(self.items.get(timeout=timeout_s))
            except queue.Empty:
                return None
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                return self._hand(self.items.get_nowait())
            except queue.Empty:
                pass
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            self._step(left)

    def _hand(self, item: Item) -> Item:
        if isinstance(item, tuple):
            self._handed_frame = True
            if item[1].type == Telemetry.TYPE:  # progress: the caller works on it now
                self._stall.working()
        return item

    # ------------------------------------------------------------------ writing

    def encode(self, msg: Message) -> bytes:
        """The frame of ``msg`` with this link's next SEQ."""
        frame = encode_frame(msg, self._seq)
        self._seq = (self._seq + 1) & 0xFF
        return frame

    def send(self, msg: Message) -> bool:
        """Send one message; False (dropped, counted) when the link is down or full."""
        return self.send_raw(self.encode(msg))

    def send_raw(self, frame: bytes) -> bool:
        with self._lock:
            port = self._port
            if port is None:
                self.writes_dropped += 1
                return False
            try:
                written = port.write(frame)
            except (serial.SerialException, OSError):
                self.writes_dropped += 1
                return False
        if written != len(frame):
            self.writes_dropped += 1
            return False
        return True


PTY_SLAVE_MAJORS = range(136, 144)  # Unix98 pty slaves (/dev/pts/N), Linux devices.txt


def _is_pty(port: str) -> bool:
    """Whether ``port`` is a pseudo-terminal (the twin's), not a device's serial port."""
    try:
        st = os.stat(port)
    except OSError:
        return False
    return stat.S_ISCHR(st.st_mode) and os.major(st.st_rdev) in PTY_SLAVE_MAJORS
