"""Commands are matched to their ACK/NACK by TYPE, SEQ and CRC, retried, and refused loudly."""

from __future__ import annotations

import contextlib

import pytest

from jackson.host.commands import ANSWER_TIMEOUT_S, RETRIES, CommandError, CommandTracker
from jackson.protocol import (
    Ack,
    FrameDecoder,
    MotorPwm,
    Nack,
    NackError,
    SetConfig,
    SetRate,
    encode_frame,
)


class Link:
    """A host side with a stepped clock; what it sent, decoded as the device sees it."""

    def __init__(self) -> None:
        self.seq = 0
        self.now = 0.0
        self.sent: list[bytes] = []
        self.tracker = CommandTracker(self.encode, self.sent.append, lambda: self.now)

    def encode(self, msg: object) -> bytes:
        frame = encode_frame(msg, self.seq)  # type: ignore[arg-type]
        self.seq = (self.seq + 1) & 0xFF
        return frame

    def device_frames(self) -> list:
        return FrameDecoder(deliver_unknown=True).feed(b"".join(self.sent))

    def answer(self, msg: object) -> None:
        (frame,) = FrameDecoder().feed(encode_frame(msg, 0))  # type: ignore[arg-type]
        self.tracker.on_frame(frame)


def ack_of(frame: bytes) -> Ack:
    return Ack(
        acked_type=frame[3], acked_seq=frame[4], acked_crc=int.from_bytes(frame[-4:], "little")
    )


def test_an_ack_clears_its_command() -> None:
    link = Link()
    frame = link.tracker.send(SetRate(rate_hz=50))
    link.answer(ack_of(frame))
    assert not link.tracker.pending
    assert link.tracker.counters.acked == 1


def test_a_late_answer_to_an_old_command_never_matches_a_new_one_with_the_same_seq() -> None:
    link = Link()
    old = link.tracker.send(SetRate(rate_hz=50))
    link.tracker.pending.clear()  # the old command was given up
    link.seq = old[4]  # 256 frames later the SEQ comes round again
    new = link.tracker.send(SetRate(rate_hz=100))
    assert new[4] == old[4]
    link.answer(ack_of(old))  # the old command's ACK arrives late
    assert link.tracker.pending  # the new command still waits for its own answer
    assert link.tracker.counters.unmatched == 1
    link.answer(ack_of(new))
    assert not link.tracker.pending


def test_a_command_without_answer_is_sent_again_then_reported() -> None:
    link = Link()
    link.tracker.send(SetConfig(failsafe_ms=600))
    for k in range(RETRIES):
        link.now += ANSWER_TIMEOUT_S
        link.tracker.poll()
        assert len(link.sent) == 2 + k
    assert link.sent[1] == link.sent[0]  # the same frame: the same SEQ and CRC
    link.now += ANSWER_TIMEOUT_S
    with pytest.raises(CommandError, match=r"never answered SET_CONFIG\(.*failsafe_ms=600"):
        link.tracker.poll()


def test_a_host_behind_its_input_waits_for_what_it_has_not_heard() -> None:
    """A busy machine keeps the host 2 s behind its input: the answer may be in what it has
    not read yet, so no retry and no error until what it heard passes the timeout."""
    link = Link()
    heard = [0.0]
    link.tracker = CommandTracker(link.encode, link.sent.append, lambda: link.now, lambda: heard[0])
    frame = link.tracker.send(SetRate(rate_hz=50))
    for _ in range(20):
        link.now += 0.1  # two seconds of wall time; nothing heard after the send
        link.tracker.poll()
    assert len(link.sent) == 1 and link.tracker.counters.retried == 0
    heard[0] = link.now  # it catches up: the ACK was in what it had not read
    link.answer(ack_of(frame))
    link.tracker.poll()
    assert not link.tracker.pending and link.tracker.counters.retried == 0


def test_a_mute_device_is_still_reported_on_the_heard_clock() -> None:
    link = Link()
    link.tracker = CommandTracker(link.encode, link.sent.append, lambda: link.now, lambda: link.now)
    link.tracker.send(SetRate(rate_hz=50))
    with pytest.raises(CommandError, match="never answered SET_RATE"):
        for _ in range(RETRIES + 1):
            link.now += ANSWER_TIMEOUT_S
            link.tracker.poll()
    assert len(link.sent) == 1 + RETRIES


def test_an_answer_to_a_retry_clears_the_command() -> None:
    link = Link()
    link.tracker.send(SetRate(rate_hz=20))
    link.now += ANSWER_TIMEOUT_S
    link.tracker.poll()
    link.answer(ack_of(link.sent[-1]))
    assert not link.tracker.pending


def test_a_nack_names_the_command_and_the_firmware_reason() -> None:
    link = Link()
    frame = link.tracker.send(SetRate(rate_hz=0))
    nack = Nack(
        acked_type=frame[3],
        acked_seq=frame[4],
        error=NackError.BAD_VALUE,
        acked_crc=ack_of(frame).acked_crc,
    )
    with pytest.raises(CommandError, match=r"refused SET_RATE\(rate_hz=0\): NACK BAD_VALUE"):
        link.answer(nack)


def test_a_refused_motor_command_is_an_error_and_a_missing_ack_only_counts() -> None:
    link = Link()
    link.tracker.send(MotorPwm(left=100, right=100))
    link.now += ANSWER_TIMEOUT_S
    link.tracker.poll()
    assert link.tracker.counters.motor_unacked == 1
    assert len(link.sent) == 1  # never retried
    frame = link.tracker.send(MotorPwm(left=100, right=100))
    a = ack_of(frame)
    with pytest.raises(CommandError, match=r"MOTOR_PWM.*NOT_SUPPORTED"):
        link.answer(Nack(a.acked_type, a.acked_seq, NackError.NOT_SUPPORTED, a.acked_crc))


def test_a_nack_with_another_crc_is_still_that_commands_answer_and_quoted() -> None:
    """The device NACKs a frame it saw damaged: same TYPE and SEQ, another CRC. The operator
    is told the device refused it (with the NACK), not that it never answered."""
    link = Link()
    frame = link.tracker.send(SetRate(rate_hz=0))
    nack = Nack(acked_type=frame[3], acked_seq=frame[4], error=NackError.BAD_LENGTH, acked_crc=7)
    with pytest.raises(
        CommandError,
        match=r"refused SET_RATE\(rate_hz=0\): NACK BAD_LENGTH.*echoed CRC 0x00000007",
    ):
        link.answer(nack)


def test_a_command_never_answered_quotes_a_stray_nack_of_its_type() -> None:
    link = Link()
    frame = link.tracker.send(SetConfig(failsafe_ms=600))
    other_seq = (frame[4] + 9) & 0xFF  # a NACK for a SET_CONFIG frame nobody sent
    link.answer(
        Nack(acked_type=frame[3], acked_seq=other_seq, error=NackError.BAD_VALUE, acked_crc=1)
    )
    assert link.tracker.counters.unmatched == 1
    for _ in range(RETRIES + 1):
        link.now += ANSWER_TIMEOUT_S
        with contextlib.suppress(CommandError):
            link.tracker.poll()
    errors = link.tracker.counters.errors
    assert errors and "never answered SET_CONFIG" in errors[-1]
    assert "it sent NACK BAD_VALUE" in errors[-1] and f"SEQ {other_seq}" in errors[-1]
