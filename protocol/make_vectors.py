"""Write the shared golden vectors under ``protocol/vectors/``.

Both codecs are tested against these files: the Python suite (tests/protocol) and
the C++ suite (protocol/cpp). ``messages.json`` holds one or more encodings of
every message; ``streams.json`` holds byte streams with garbage, truncation,
corruption, unknown versions and types, sequence gaps and silences, with the
frames and counters a receiver must produce. The expected values were produced
by the Python codec and are checked independently by hand-computed cases in
tests/protocol and by the C++ decoder; ``--check`` fails when the files differ
from what this script produces.

Usage::

    python -m jackson.protocol.make_vectors [--check]
"""

from __future__ import annotations

import argparse
import json
import random
import struct
import sys
from dataclasses import fields as dc_fields
from pathlib import Path
from typing import Any

from jackson.protocol.frame import FrameDecoder, decode_message, encode_frame
from jackson.protocol.messages import (
    MESSAGES,
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    Ack,
    Heartbeat,
    Hello,
    Info,
    Log,
    Message,
    MotorPwm,
    Nack,
    RequestInfo,
    SetConfig,
    SetImuCalibration,
    SetRate,
    Status,
    Telemetry,
    ZeroCounters,
)

VECTORS_DIR = Path(__file__).resolve().parent / "vectors"


def f32(x: float) -> float:
    """The float32 nearest to x, as a Python float (exact in JSON)."""
    value: float = struct.unpack("<f", struct.pack("<f", x))[0]
    return value


def fields_of(msg: Message) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for f in dc_fields(msg):
        value = getattr(msg, f.name)
        out[f.name] = list(value) if isinstance(value, tuple) else value
    return out


def sample_messages() -> list[tuple[str, Message, int]]:
    """(vector name, message, seq): every message type, typical values and limits."""
    rot = (0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    return [
        (
            "telemetry_typical",
            Telemetry(
                t_us=1_234_567,
                enc_left=6210,
                enc_right=-6195,
                flags=0x0003,
                accel=(-120, 85, 15_542),
                temp=-2_100,
                gyro=(3, -7, 1_310),
            ),
            7,
        ),
        (
            "telemetry_limits",
            Telemetry(
                t_us=0xFFFFFFFF,
                enc_left=-(2**31),
                enc_right=2**31 - 1,
                flags=0xFFFF,
                accel=(-32768, 32767, 0),
                temp=32767,
                gyro=(-32768, 0, 32767),
            ),
            255,
        ),
        (
            "status_typical",
            Status(
                t_us=60_000_000,
                rx_frames_ok=1200,
                rx_crc_errors=2,
                rx_bad_commands=1,
                tx_dropped=0,
                i2c_errors=5,
                pcnt_overflows=3,
                telemetry_rate_hz=20,
                flags=0x0001,
            ),
            0,
        ),
        (
            "info_typical",
            Info(
                protocol_version=PROTOCOL_VERSION,
                schema_hash=SCHEMA_HASH,
                firmware_version=(0, 1, 0),
                telemetry_rate_hz=20,
                failsafe_ms=600,
                accel_fs=0,
                gyro_fs=0,
                direction_flags=0b10,
                capabilities=0b011,
                imu_rotation=rot,
                gyro_bias=(f32(0.0012), f32(-0.0031), f32(0.01)),
                accel_scale=f32(9.81 / 9.299),
                boot_id=0x5EED1235,
            ),
            1,
        ),
        ("ack_typical", Ack(acked_type=0x82, acked_seq=17, acked_crc=0x1A2B3C4D), 2),
        ("nack_typical", Nack(acked_type=0x86, acked_seq=18, error=5, acked_crc=0xDEADBEEF), 3),
        ("log_text", Log(level=2, text="IMU: WHO_AM_I 0x00, retry in 400 ms"), 4),
        ("log_empty", Log(level=0, text=""), 5),
        ("log_utf8_full", Log(level=3, text="°" * 50), 6),
        (
            "hello_typical",
            Hello(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH, session=0x5E55_1011),
            0,
        ),
        ("heartbeat_typical", Heartbeat(ack_seq=7, host_state=1), 1),
        ("set_rate_200", SetRate(rate_hz=200), 2),
        ("zero_counters_both", ZeroCounters(mask=0b11), 3),
        (
            "set_imu_calibration_typical",
            SetImuCalibration(
                imu_rotation=rot,
                gyro_bias=(f32(0.0012), f32(-0.0031), f32(0.01)),
                accel_scale=f32(1.054),
                persist=1,
            ),
            4,
        ),
        ("request_info", RequestInfo(), 5),
        ("motor_pwm_typical", MotorPwm(left=4500, right=-10000, timeout_ms=0), 6),
        (
            "set_config_typical",
            SetConfig(accel_fs=1, gyro_fs=0, direction_flags=1, failsafe_ms=600, persist=0),
            7,
        ),
    ]


def _raw_frame(version: int, ftype: int, seq: int, payload: bytes) -> bytes:
    """A frame with any header values and a correct CRC (for unknown versions and types)."""
    from jackson.protocol.crc import crc32c

    body = bytes((version, ftype, seq, len(payload))) + payload
    return b"\xa5\x5a" + body + struct.pack("<I", crc32c(body))


BOGUS_LONG = b"\xa5\x5a\x01\x01\x00\x64"  # a header of LEN 100: swallows what follows
Stream = tuple[str, str, list[tuple[int, bytes]], int | None]  # name, doc, chunks, poll time


def _flip(frame: bytes, byte: int, bit: int) -> bytes:
    b = bytearray(frame)
    b[byte] ^= 1 << bit
    return bytes(b)


def _damaged_streams(t: list[bytes]) -> list[Stream]:
    """Frames with garbage around or inside them, cut short, or with a bit flipped, and
    frames of an unknown version or type."""
    garbage = bytes([0x00, 0xA5, 0x11, 0xA5, 0x5A, 0x7F, 0xFF, 0x5A, 0xA5])
    flip = _flip
    return [
        (
            "garbage_around_frames",
            "garbage (with stray SYNC bytes) before, between and after two frames",
            [(0, garbage + t[0] + garbage + t[1] + garbage[:4])],
            None,
        ),
        (
            "garbage_inside_frame",
            "three bytes inserted into a frame: it is lost, the next one is found",
            [(0, t[0][:10] + b"\x01\x02\x03" + t[0][10:] + t[1])],
            None,
        ),
        (
            "truncated_frame",
            "the first 20 bytes of a frame, then two whole frames",
            [(0, t[0][:20] + t[1] + t[2])],
            None,
        ),
        (
            "frame_inside_corrupt_one",
            "a header claiming 100 bytes whose span holds two real frames",
            [(0, BOGUS_LONG + t[0] + t[1] + t[2] + t[3] + t[4])],
            None,
        ),
        (
            "flipped_payload_bit",
            "one bit flipped in a payload: CRC error, the neighbours survive",
            [(0, t[0] + flip(t[1], 12, 3) + t[2])],
            None,
        ),
        (
            "flipped_crc_bit",
            "one bit flipped in the CRC itself",
            [(0, t[0] + flip(t[1], len(t[1]) - 1, 7) + t[2])],
            None,
        ),
        (
            "flipped_length_bit",
            "one bit flipped in LEN (28 -> 92): the candidate waits, fails, and is rescanned",
            [(0, t[0] + flip(t[1], 5, 6) + t[2] + t[3] + t[4] + t[5])],
            None,
        ),
        (
            "unknown_version",
            "a CRC-valid frame of protocol version 2 between two version-1 frames",
            [(0, t[0] + _raw_frame(2, Telemetry.TYPE, 2, t[1][6:-4]) + t[2])],
            None,
        ),
        (
            "unknown_type",
            "a CRC-valid frame of type 0x7E, skipped whole; its SEQ still counts",
            [(0, t[0] + _raw_frame(PROTOCOL_VERSION, 0x7E, 2, b"\x01\x02\x03") + t[2])],
            None,
        ),
        (
            "oversize_length",
            "a header with LEN 200, above the largest payload",
            [(0, b"\xa5\x5a\x01\x01\x00\xc8" + t[0])],
            None,
        ),
    ]


def _timing_streams(t: list[bytes], rng: random.Random) -> list[Stream]:
    """Sequence gaps and wraps, silences inside a frame, short and long payloads, byte-by-byte
    delivery, noise, and one frame of every message."""
    ack = encode_frame(Ack(acked_type=0x83, acked_seq=9), seq=40)
    short_tel = _raw_frame(PROTOCOL_VERSION, Telemetry.TYPE, 60, Telemetry(t_us=7).pack()[:12])
    long_ack = _raw_frame(PROTOCOL_VERSION, Ack.TYPE, 61, Ack(1, 2).pack() + b"\x99\x98")
    return [
        (
            "sequence_gap",
            "SEQ 1, 2, 5, 6: one gap of two frames",
            [(0, t[0] + t[1] + t[4] + t[5])],
            None,
        ),
        (
            "sequence_wrap",
            "SEQ 254, 255, 0, 1: a wrap is not a gap",
            [
                (
                    0,
                    b"".join(
                        encode_frame(Ack(acked_type=1, acked_seq=s), s) for s in (254, 255, 0, 1)
                    ),
                )
            ],
            None,
        ),
        (
            "partial_then_silence",
            "half a frame, 25 ms of silence, then a whole frame",
            [(0, t[0][:15]), (25_000, t[1])],
            None,
        ),
        (
            "partial_short_silence",
            "half a frame, 5 ms, then the rest: still one frame",
            [(0, t[0][:15]), (5_000, t[0][15:])],
            None,
        ),
        (
            "timeout_rescues_inner_frame",
            "a header claiming 100 bytes holding one whole frame, then silence (poll)",
            [(0, BOGUS_LONG + ack)],
            30_000,
        ),
        (
            "short_payload_zero_filled",
            "a telemetry frame with only 12 payload bytes: the rest reads as zero",
            [(0, short_tel)],
            None,
        ),
        (
            "extended_payload_ignored",
            "an ACK with two extra trailing bytes (a later minor revision): they are ignored",
            [(0, long_ack)],
            None,
        ),
        (
            "byte_by_byte",
            "two frames delivered one byte per chunk",
            [(0, bytes([b])) for b in t[0] + t[1]],
            None,
        ),
        (
            "random_noise",
            "400 random bytes then a frame",
            [(0, bytes(rng.randrange(256) for _ in range(400)) + t[0])],
            None,
        ),
        (
            "every_message",
            "one frame of every message, back to back",
            [(0, b"".join(encode_frame(m, k) for k, (_, m, _) in enumerate(sample_messages())))],
            None,
        ),
    ]


def _decoded(
    name: str, doc: str, chunks: list[tuple[int, bytes]], poll_at: int | None
) -> dict[str, Any]:
    """A stream and what the decoder makes of it: frames, counters, pending bytes."""
    dec = FrameDecoder()
    frames = []
    for at_us, data in chunks:
        frames += dec.feed(data, at_us)
    if poll_at is not None:
        frames += dec.poll(poll_at)
    return {
        "name": name,
        "doc": doc,
        "chunks": [{"at_us": at, "hex": data.hex()} for at, data in chunks],
        "poll_at_us": poll_at,
        "frames": [
            {
                "message": MESSAGES[f.type].NAME,
                "seq": f.seq,
                "fields": fields_of(decode_message(f)),
            }
            for f in frames
        ],
        "counters": dec.counters.as_dict(),
        "pending": dec.pending,
    }


def sample_streams() -> list[dict[str, Any]]:
    """Named streams: (doc, chunks of (at_us, bytes), optional poll time)."""
    rng = random.Random(2024)
    t = [
        encode_frame(
            Telemetry(t_us=50_000 * k, enc_left=31 * k, enc_right=30 * k, flags=1), seq=k + 1
        )
        for k in range(6)
    ]
    streams = _damaged_streams(t) + _timing_streams(t, rng)
    return [_decoded(*stream) for stream in streams]


def render() -> dict[str, str]:
    messages = [
        {
            "name": name,
            "message": msg.NAME,
            "seq": seq,
            "fields": fields_of(msg),
            "hex": encode_frame(msg, seq).hex(),
        }
        for name, msg, seq in sample_messages()
    ]
    covered = {m["message"] for m in messages}
    missing = {cls.NAME for cls in MESSAGES.values()} - covered
    if missing:
        raise SystemExit(f"make_vectors: no vector for {sorted(missing)}")
    header = {"protocol_version": PROTOCOL_VERSION, "schema_hash": f"{SCHEMA_HASH:#010x}"}
    return {
        "messages.json": json.dumps({**header, "vectors": messages}, indent=1) + "\n",
        "streams.json": json.dumps({**header, "vectors": sample_streams()}, indent=1) + "\n",
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="write the shared protocol test vectors")
    parser.add_argument("--check", action="store_true", help="fail if the files are stale")
    args = parser.parse_args(argv)
    stale = []
    for name, text in render().items():
        path = VECTORS_DIR / name
        if path.exists() and path.read_text(encoding="utf-8") == text:
            continue
        if args.check:
            stale.append(name)
        else:
            VECTORS_DIR.mkdir(exist_ok=True)
            path.write_text(text, encoding="utf-8")
            print(f"make_vectors: wrote protocol/vectors/{name}")
    if stale:
        print(
            f"make_vectors: protocol/vectors/{', '.join(stale)} out of date; "
            "run `python -m jackson.protocol.make_vectors` and review the diff",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
