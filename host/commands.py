"""Commands to the MCU and their answers: every command is matched to its ACK or NACK.

The device answers every command but HEARTBEAT with exactly one ACK or NACK echoing the
command's TYPE, SEQ and frame CRC (protocol/spec.md §8.4). :class:`CommandTracker` keeps the
commands still waiting for their answer, keyed by all three, so a late answer to an old command
never matches a newer one that reuses the SEQ (one SEQ counter serves every message and wraps
in 1.3 s at 200 Hz). A configuration command without an answer within :data:`ANSWER_TIMEOUT_S`
is sent again (commands are idempotent), :data:`RETRIES` times; a NACK, or a command still
unanswered after its retries, is a :class:`CommandError` naming the command and the reason.

The timeout is counted on what the host has *heard*, not on the wall clock alone: an answer is
late only when the host has read and handled everything the device sent for
:data:`ANSWER_TIMEOUT_S` after the command, and the answer was not in it
(:meth:`~jackson.host.transport.SerialTransport.heard_s`). A host that a busy machine keeps
behind its own input (an ACK queued behind frames it has not handled yet) therefore never
calls a command unanswered; a mute device still is, after about a second.

MOTOR_PWM is tracked for its NACK only: it is sent at every telemetry frame, so a missing ACK is
not retried (the next frame's command replaces it) but counted.
"""

from __future__ import annotations

import dataclasses
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from jackson.common.errors import JacksonError
from jackson.protocol import Ack, Frame, Message, MotorPwm, Nack, NackError, decode_message

ANSWER_TIMEOUT_S = 0.25  # [s] heard time for an ACK/NACK before the command is sent again
RETRIES = 3  # sends after the first one

NACK_REASONS = {
    NackError.BAD_LENGTH: "the payload is shorter than the message (host and firmware disagree)",
    NackError.BAD_VALUE: "a field is outside its documented range",
    NackError.UNKNOWN_TYPE: "the firmware does not know this command",
    NackError.VERSION_MISMATCH: "the firmware speaks another protocol version or schema",
    NackError.NOT_SUPPORTED: "this firmware build cannot do it",
    NackError.STORAGE: "writing to the device's non-volatile storage failed",
}


class CommandError(JacksonError, RuntimeError):
    """The device refused a command, or never answered it: one line for the operator."""


def describe(msg: Message) -> str:
    """``SET_RATE(rate_hz=200)``: the command as an operator reads it."""
    text = ", ".join(f"{f.name}={getattr(msg, f.name)!r}" for f in dataclasses.fields(msg))
    return f"{msg.NAME.upper()}({text})"


def nack_reason(error: int) -> str:
    try:
        code = NackError(error)
    except ValueError:
        return f"unknown error code {error}"
    return f"{code.name}: {NACK_REASONS.get(code, '')}".rstrip(": ")


@dataclass
class _Pending:
    msg: Message
    frame: bytes
    sent_s: float
    tries: int = 1


@dataclass
class CommandCounters:
    """What the tracker saw, for diagnostics and the run folder."""

    acked: int = 0
    nacked: int = 0
    retried: int = 0
    unmatched: int = 0  # answers that matched no waiting command (late, or duplicates)
    motor_unacked: int = 0  # MOTOR_PWM whose ACK never came (not retried)
    errors: list[str] = field(default_factory=list)


def frame_key(frame: bytes) -> tuple[int, int, int]:
    """(TYPE, SEQ, CRC) of an encoded frame: what its ACK or NACK echoes."""
    return frame[3], frame[4], int.from_bytes(frame[-4:], "little")


class CommandTracker:
    """Sends commands through ``send_frame`` and matches the device's answers to them.

    Parameters
    ----------
    encode : callable
        Message to a frame with the link's next SEQ.
    send_frame : callable
        Writes a frame to the link (may drop it when the link is down: the retry covers it).
    clock : callable
        Wall time [s]; ``time.monotonic`` unless a test steps it. Commands are stamped with it.
    heard : callable, optional
        The time [s, on ``clock``] up to which everything the device sent has been read and
        handled (:meth:`~jackson.host.transport.SerialTransport.heard_s`); an answer is
        awaited until this is :data:`ANSWER_TIMEOUT_S` past the send. None: ``clock``.
    """

    def __init__(
        self,
        encode: Callable[[Message], bytes],
        send_frame: Callable[[bytes], object],
        clock: Callable[[], float] = time.monotonic,
        heard: Callable[[], float] | None = None,
    ) -> None:
        self.encode = encode
        self.send_frame = send_frame
        self.clock = clock
        self.heard = clock if heard is None else heard
        self.pending: dict[tuple[int, int, int], _Pending] = {}
        self.counters = CommandCounters()
        self._motor: dict[tuple[int, int, int], float] = {}
        self._stray_nacks: deque[Nack] = deque(maxlen=8)  # NACKs that matched no command

    def send(self, msg: Message) -> bytes:
        """Send ``msg``; its answer is awaited (configuration) or only checked (MOTOR_PWM)."""
        frame = self.encode(msg)
        now = self.clock()
        if isinstance(msg, MotorPwm):
            self._motor[frame_key(frame)] = now
            self._expire_motor(self.heard())
        else:
            self.pending[frame_key(frame)] = _Pending(msg, frame, now)
        self.send_frame(frame)
        return frame

    def on_frame(self, frame: Frame) -> None:
        """An ACK or NACK from the device (other frames are ignored).

        Raises
        ------
        CommandError
            The device refused a command.
        """
        if frame.type not in (Ack.TYPE, Nack.TYPE):
            return
        answer = decode_message(frame)
        assert isinstance(answer, Ack | Nack)
        key = (answer.acked_type, answer.acked_seq, answer.acked_crc)
        p = self.pending.pop(key, None)
        motor = self._motor.pop(key, None) if p is None else None
        echo = ""
        if p is None and motor is None and isinstance(answer, Nack):
            # a NACK that echoes a command's type and SEQ but another CRC (the device saw the
            # frame damaged, or computes it otherwise): still that command's answer, quoted
            near = [k for k in self.pending if k[:2] == key[:2]]
            if len(near) == 1:
                p = self.pending.pop(near[0])
                echo = f" (the NACK echoed CRC {answer.acked_crc:#010x}, sent {near[0][2]:#010x})"
        if p is None and motor is None:
            self.counters.unmatched += 1
            if isinstance(answer, Nack):
                self._stray_nacks.append(answer)
            return
        if isinstance(answer, Ack):
            self.counters.acked += 1
            return
        self.counters.nacked += 1
        what = describe(p.msg) if p is not None else "MOTOR_PWM"
        text = f"the device refused {what}: NACK {nack_reason(answer.error)}{echo}"
        self.counters.errors.append(text)
        raise CommandError(text)

    def poll(self) -> None:
        """Send again what waited too long; raise for what has run out of retries.

        Raises
        ------
        CommandError
            A command got no answer after :data:`RETRIES` retries.
        """
        heard = self.heard()
        for key, p in list(self.pending.items()):
            if heard - p.sent_s < ANSWER_TIMEOUT_S:
                continue  # what came after it is not all read yet: its answer may be in it
            if p.tries > RETRIES:
                del self.pending[key]
                text = (
                    f"the device never answered {describe(p.msg)} "
                    f"({p.tries} tries, {ANSWER_TIMEOUT_S:.2f} s each)"
                )
                stray = [n for n in self._stray_nacks if n.acked_type == key[0]]
                if stray:  # it did answer something: quote it
                    n = stray[-1]
                    text += (
                        f"; it sent NACK {nack_reason(n.error)} for a frame of that type "
                        f"(SEQ {n.acked_seq}, CRC {n.acked_crc:#010x}) that matched no command"
                    )
                self.counters.errors.append(text)
                raise CommandError(text)
            # the same frame again: same SEQ and CRC, so either answer matches it
            p.tries += 1
            p.sent_s = self.clock()
            self.counters.retried += 1
            self.send_frame(p.frame)
        self._expire_motor(heard)

    def forget(self) -> None:
        """Drop every waiting command (a new session: the device has forgotten them)."""
        self.pending.clear()
        self._motor.clear()

    def _expire_motor(self, heard: float) -> None:
        for key, sent in list(self._motor.items()):
            if heard - sent >= ANSWER_TIMEOUT_S:
                del self._motor[key]
                self.counters.motor_unacked += 1
