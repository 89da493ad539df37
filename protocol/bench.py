"""Benchmarks of the Python codec (run by ``jackson bench``).

Decoding is measured on a stream of telemetry frames in which 1 % of the bytes are
replaced by random values, fed in 4 KiB chunks as a serial reader delivers them, and
counts full decoding into message objects. Target: 9.2 MB/s, 100 times the byte rate
of a 921600-baud link (92.16 kB/s), so one Jetson core spends well under 1 % on it.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable

from jackson.common.bench import BenchResult
from jackson.protocol.frame import FrameDecoder, decode_message, encode_frame
from jackson.protocol.messages import Telemetry

LINK_BYTES_PER_S = 921_600 / 10  # 8N1: 10 bits per byte
DECODE_TARGET_MB_S = 100 * LINK_BYTES_PER_S / 1e6  # 9.216
ENCODE_TARGET_FRAMES_S = 20_000  # 100 x the 200 Hz maximum command rate
CHUNK = 4096


def telemetry_stream(n_frames: int, corrupt_fraction: float, seed: int = 1) -> bytes:
    """``n_frames`` telemetry frames with ``corrupt_fraction`` of their bytes randomised."""
    rng = random.Random(seed)
    out = bytearray()
    for k in range(n_frames):
        msg = Telemetry(
            t_us=k * 50_000,
            enc_left=k * 31,
            enc_right=k * 30,
            flags=1,
            accel=(rng.randint(-300, 300), rng.randint(-300, 300), 16384),
            temp=-1500,
            gyro=(rng.randint(-50, 50), rng.randint(-50, 50), rng.randint(-500, 500)),
        )
        out += encode_frame(msg, k & 0xFF)
    for i in rng.sample(range(len(out)), int(len(out) * corrupt_fraction)):
        out[i] = rng.randrange(256)
    return bytes(out)


def _best_of(repeats: int, fn: Callable[[], object]) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def run(quick: bool = False) -> list[BenchResult]:
    n = 5_000 if quick else 40_000
    stream = telemetry_stream(n, 0.01)
    chunks = [stream[i : i + CHUNK] for i in range(0, len(stream), CHUNK)]

    def decode_messages() -> None:
        dec = FrameDecoder()
        for chunk in chunks:
            for frame in dec.feed(chunk):
                decode_message(frame)

    def decode_frames() -> None:
        dec = FrameDecoder()
        for chunk in chunks:
            dec.feed(chunk)

    repeats = 3 if quick else 5
    t_msg = _best_of(repeats, decode_messages)
    t_frame = _best_of(repeats, decode_frames)

    msgs = [Telemetry(t_us=k, enc_left=k, enc_right=-k) for k in range(2_000)]

    def encode() -> None:
        for k, m in enumerate(msgs):
            encode_frame(m, k & 0xFF)

    t_enc = _best_of(repeats, encode)
    mb = len(stream) / 1e6
    return [
        BenchResult("protocol.py.decode_MBps", mb / t_msg, "MB/s", DECODE_TARGET_MB_S, "higher"),
        BenchResult(
            "protocol.py.decode_stream_frames_per_s",
            n / t_msg,
            "frames/s",
            DECODE_TARGET_MB_S * 1e6 / 38,
            "higher",
        ),
        BenchResult(
            "protocol.py.frame_layer_MBps", mb / t_frame, "MB/s", DECODE_TARGET_MB_S, "higher"
        ),
        BenchResult(
            "protocol.py.encode_frames_per_s",
            len(msgs) / t_enc,
            "frames/s",
            ENCODE_TARGET_FRAMES_S,
            "higher",
        ),
    ]
