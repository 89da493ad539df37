"""Frame layer: hand-computed cases, independent of the golden vectors."""

from __future__ import annotations

import struct

import pytest

from jackson.protocol import (
    MAX_PAYLOAD,
    Ack,
    EncodeError,
    FrameDecoder,
    Log,
    MotorPwm,
    Telemetry,
    crc32c,
    decode_message,
    encode_frame,
)
from jackson.protocol.crc import CHECK_VALUE


def test_crc32c_check_value() -> None:
    assert crc32c(b"123456789") == CHECK_VALUE == 0xE3069283


def test_ack_frame_bytes_by_hand() -> None:
    # VER TYPE SEQ LEN payload (acked_type, acked_seq, acked_crc)
    body = bytes([0x01, 0x04, 0x09, 0x06, 0x83, 0x09, 0x44, 0x33, 0x22, 0x11])
    expected = b"\xa5\x5a" + body + struct.pack("<I", crc32c(body))
    assert encode_frame(Ack(acked_type=0x83, acked_seq=9, acked_crc=0x11223344), 9) == expected


def test_telemetry_frame_is_38_bytes_little_endian() -> None:
    frame = encode_frame(Telemetry(t_us=0x01020304, enc_left=-2, enc_right=5), 0)
    assert len(frame) == 38
    assert frame[6:10] == bytes([4, 3, 2, 1])
    assert frame[10:14] == b"\xfe\xff\xff\xff"


def test_garbage_is_counted_as_skipped_bytes() -> None:
    frame = encode_frame(Ack(acked_type=1, acked_seq=2), 0)
    dec = FrameDecoder()
    frames = dec.feed(b"\x00\x01\x02" + frame + b"\x03\x04")
    assert len(frames) == 1
    assert dec.counters.bytes_skipped == 5
    assert dec.counters.frames_ok == 1


def test_corrupt_frame_is_counted_and_next_frame_survives() -> None:
    a = bytearray(encode_frame(Telemetry(t_us=1), 0))
    a[20] ^= 0x10
    b = encode_frame(Telemetry(t_us=2), 1)
    dec = FrameDecoder()
    frames = dec.feed(bytes(a) + b)
    assert [decode_message(f) for f in frames] == [Telemetry(t_us=2)]
    assert dec.counters.crc_errors == 1
    assert dec.counters.bytes_skipped == 38


def test_oversize_length_is_rejected_without_waiting() -> None:
    dec = FrameDecoder()
    dec.feed(bytes([0xA5, 0x5A, 0x01, 0x01, 0x00, MAX_PAYLOAD + 1]))
    assert dec.counters.oversize == 1
    assert dec.pending == 0


def test_partial_frame_waits_then_times_out() -> None:
    frame = encode_frame(Telemetry(t_us=1), 0)
    dec = FrameDecoder()
    assert dec.feed(frame[:20], now_us=0) == []
    assert dec.pending == 20
    assert dec.poll(19_999) == []
    assert dec.pending == 20
    dec.poll(20_000)
    assert dec.pending == 0
    assert dec.counters.timeouts == 1
    assert dec.counters.bytes_skipped == 20


def test_frame_split_across_reads_is_reassembled() -> None:
    frame = encode_frame(MotorPwm(left=100, right=-100, timeout_ms=0), 3)
    dec = FrameDecoder()
    assert dec.feed(frame[:7], 0) == []
    frames = dec.feed(frame[7:], 1_000)
    assert [decode_message(f) for f in frames] == [MotorPwm(left=100, right=-100, timeout_ms=0)]


def test_memoryview_input_is_accepted() -> None:
    data = bytearray(encode_frame(Ack(acked_type=1, acked_seq=1), 0))
    assert len(FrameDecoder().feed(memoryview(data))) == 1


def test_encode_rejects_out_of_range_fields() -> None:
    with pytest.raises(EncodeError, match="motor_pwm"):
        encode_frame(MotorPwm(left=40_000), 0)
    with pytest.raises(EncodeError, match="seq"):
        encode_frame(Ack(), 256)
    with pytest.raises(EncodeError, match="at most 100"):
        encode_frame(Log(text="x" * 101), 0)


def test_lost_frames_show_as_a_sequence_gap() -> None:
    dec = FrameDecoder()
    data = b"".join(encode_frame(Ack(acked_seq=s), s) for s in (10, 11, 15))
    dec.feed(data)
    assert dec.counters.seq_gaps == 1
    assert dec.counters.seq_lost == 3
