"""Benchmarks of the Python codec against pymavlink's MAVLink v2 parser (run by ``jackson bench``).

Both codecs decode, in the same process, a stream of the same number of frames of the same
size: our telemetry frames (38 bytes) and MAVLink v2 RAW_IMU messages (38 bytes: a 10-byte
header, 26 bytes of payload, 2 bytes of CRC; pymavlink checks the CRC with fastcrc), in each of
which 1 % of the bytes are then replaced by random values at the same places, fed in 4 KiB
chunks as a serial reader delivers them. Both count full decoding into message objects. Our
frame layer alone (sync, length, CRC, no message objects) is timed beside them as the floor.
The work is interleaved chunk by chunk (our decoding of chunk i, our frame layer's, pymavlink's,
then chunk i + 1; encoding likewise by blocks of 100 messages), best of N rounds. Figures:

- decoding and encoding speed as a multiple of pymavlink's (target: above 1, we beat it);
- full decoding's time over the frame layer's (how far above the floor the message layer is);
- the CPU share decoding a 921600-baud link's bytes takes (target: 1 %).
"""

from __future__ import annotations

import functools
import importlib
import random
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from jackson.common.bench import BenchResult, interleaved_slices
from jackson.protocol.frame import FrameDecoder, decode_message, encode_frame
from jackson.protocol.messages import Telemetry

LINK_BYTES_PER_S = 921_600 / 10  # 8N1: 10 bits per byte
LINK_CPU_SHARE_TARGET = 0.01  # decoding the link's bytes takes at most 1 % of one core
MESSAGE_OVER_FRAME_TARGET = 2.5  # full decoding within 2.5x of the frame layer alone
CHUNK = 4096
ENCODE_BLOCK = 100  # messages encoded per slice


def _corrupt(stream: bytearray, fraction: float, rng: random.Random) -> bytes:
    for i in rng.sample(range(len(stream)), int(len(stream) * fraction)):
        stream[i] = rng.randrange(256)
    return bytes(stream)


def _telemetry(rng: random.Random, k: int) -> Telemetry:
    return Telemetry(
        t_us=k * 50_000,
        enc_left=k * 31,
        enc_right=k * 30,
        flags=1,
        accel=(rng.randint(-300, 300), rng.randint(-300, 300), 16384),
        temp=-1500,
        gyro=(rng.randint(-50, 50), rng.randint(-50, 50), rng.randint(-500, 500)),
    )


def telemetry_stream(n_frames: int, corrupt_fraction: float, seed: int = 1) -> bytes:
    """``n_frames`` telemetry frames with ``corrupt_fraction`` of their bytes randomised.

    Parameters
    ----------
    n_frames : int
        Number of frames.
    corrupt_fraction : float
        Share of the stream's bytes replaced by random values.
    seed : int
        Seed of the values and of the corrupted places.

    Returns
    -------
    bytes
        The stream.
    """
    rng = random.Random(seed)
    out = bytearray()
    for k in range(n_frames):
        out += encode_frame(_telemetry(rng, k), k & 0xFF)
    return _corrupt(out, corrupt_fraction, rng)


def _mavlink() -> Any:
    """pymavlink's generated MAVLink v2 ``common`` dialect (a dev dependency, untyped)."""
    return importlib.import_module("pymavlink.dialects.v20.common")


def _raw_imu(mav: Any, rng: random.Random, k: int) -> Any:
    """The MAVLink v2 RAW_IMU message carrying what our k-th telemetry frame carries."""
    t = _telemetry(rng, k)
    return _mavlink().MAVLink_raw_imu_message(
        t.t_us, *t.accel, *t.gyro, t.enc_left & 0x7FFF, t.enc_right & 0x7FFF, t.temp, 0, 0
    )


def mavlink_stream(n_frames: int, corrupt_fraction: float, seed: int = 1) -> bytes:
    """The pymavlink peer of :func:`telemetry_stream`: as many RAW_IMU frames of the same size.

    Parameters
    ----------
    n_frames : int
        Number of frames.
    corrupt_fraction : float
        Share of the stream's bytes replaced by random values (at the same places).
    seed : int
        Seed of the values and of the corrupted places.

    Returns
    -------
    bytes
        The stream of MAVLink v2 frames, 38 bytes each before corruption.
    """
    rng = random.Random(seed)
    mav = _mavlink().MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    for k in range(n_frames):
        out += _raw_imu(mav, rng, k).pack(mav)
    return _corrupt(out, corrupt_fraction, rng)


@dataclass(frozen=True)
class Workload:
    """What both codecs work on: the two streams in 4 KiB chunks and the messages to encode.

    Attributes
    ----------
    n : int
        Frames in each stream.
    stream_bytes : int
        The length of each stream (the same for both).
    chunks, peer_chunks : list of bytes
        Our stream and pymavlink's, as a serial reader delivers them.
    msgs, peer_msgs : list
        Our telemetry messages and pymavlink's RAW_IMU messages of the same values.
    peer : Any
        pymavlink's encoder of :attr:`peer_msgs`.
    """

    n: int
    stream_bytes: int
    chunks: list[bytes]
    peer_chunks: list[bytes]
    msgs: list[Telemetry]
    peer_msgs: list[Any]
    peer: Any


def workload(n: int) -> Workload:
    """``n`` frames of each stream, 1 % corrupted, and 2000 messages of each codec.

    Raises
    ------
    RuntimeError
        When the two streams differ in size (the comparison would not be fair).
    """
    stream = telemetry_stream(n, 0.01)
    peer_stream = mavlink_stream(n, 0.01)
    if len(stream) != len(peer_stream):
        raise RuntimeError("the two streams differ in size")
    chunks = [stream[i : i + CHUNK] for i in range(0, len(stream), CHUNK)]
    peer_chunks = [peer_stream[i : i + CHUNK] for i in range(0, len(peer_stream), CHUNK)]
    mavlink = _mavlink()
    rng = random.Random(3)
    msgs = [_telemetry(rng, k) for k in range(2_000)]
    peer = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    rng = random.Random(3)
    peer_msgs = [_raw_imu(peer, rng, k) for k in range(2_000)]
    return Workload(n, len(stream), chunks, peer_chunks, msgs, peer_msgs, peer)


def make_round(w: Workload) -> dict[str, list[Callable[[], object]]]:
    """Fresh decoders; one slice per 4 KiB chunk, one per block of messages to encode."""
    mavlink = _mavlink()
    chunks, peer_chunks, msgs, peer_msgs = w.chunks, w.peer_chunks, w.msgs, w.peer_msgs
    blocks = range(0, len(msgs), ENCODE_BLOCK)
    ours, frames, theirs = FrameDecoder(), FrameDecoder(), mavlink.MAVLink(None)
    theirs.robust_parsing = True

    def decode_messages(chunk: bytes) -> Callable[[], object]:
        return lambda: [decode_message(f) for f in ours.feed(chunk)]

    def encode(k0: int) -> Callable[[], object]:
        return lambda: [
            encode_frame(m, k & 0xFF) for k, m in enumerate(msgs[k0 : k0 + ENCODE_BLOCK])
        ]

    def pymavlink_encode(k0: int) -> Callable[[], object]:
        return lambda: [m.pack(w.peer) for m in peer_msgs[k0 : k0 + ENCODE_BLOCK]]

    pad = max(len(chunks), len(blocks))
    idle: Callable[[], object] = lambda: None  # noqa: E731
    return {
        "ours": [decode_messages(c) for c in chunks] + [idle] * (pad - len(chunks)),
        "frames": [functools.partial(frames.feed, c) for c in chunks]
        + [idle] * (pad - len(chunks)),
        "pymavlink": [functools.partial(theirs.parse_buffer, c) for c in peer_chunks]
        + [idle] * (pad - len(chunks)),
        "encode": [encode(k0) for k0 in blocks] + [idle] * (pad - len(blocks)),
        "pymavlink_encode": [pymavlink_encode(k0) for k0 in blocks] + [idle] * (pad - len(blocks)),
    }


def _figure(
    name: str,
    value: float,
    unit: str,
    target: float,
    better: str,
    reference: str,
    ours: float,
    theirs: float | None,
    abs_unit: str,
    loop_us: float,
) -> BenchResult:
    """A judged figure, ``better`` ``"higher"`` or ``"lower"``."""
    return BenchResult(
        name,
        value,
        unit,
        target,
        "higher" if better == "higher" else "lower",
        reference,
        ours,
        abs_unit,
        theirs,
        loop_us,
    )


def figures(w: Workload, best: dict[str, float], loop_us: float) -> list[BenchResult]:
    """The codec's figures from each side's best time [s] over the rounds.

    Parameters
    ----------
    w : Workload
        What was timed.
    best : dict[str, float]
        Each side's time, by the names :func:`make_round` gives them.
    loop_us : float
        The machine's reference loop in the same run [us].

    Returns
    -------
    list[BenchResult]
        Decoding and encoding against pymavlink, full decoding against the frame layer, and
        decoding's share of a link's bytes.
    """
    n = w.n
    mb = w.stream_bytes / 1e6
    peer_mb_s = mb / best["pymavlink"]
    return [
        _figure(
            "protocol.decode_vs_pymavlink",
            best["pymavlink"] / best["ours"],
            "x pymavlink's speed",
            1.0,
            "higher",
            "pymavlink 2.4 MAVLink v2 parse_buffer, same frame count and sizes, 1 % corrupted",
            mb / best["ours"],
            peer_mb_s,
            "MB/s",
            loop_us,
        ),
        _figure(
            "protocol.frame_layer_vs_pymavlink",
            best["pymavlink"] / best["frames"],
            "x pymavlink's speed",
            1.0,
            "higher",
            "pymavlink's full decoding (our frame layer alone: the floor)",
            mb / best["frames"],
            peer_mb_s,
            "MB/s",
            loop_us,
        ),
        _figure(
            "protocol.decode_over_frame_layer",
            best["ours"] / best["frames"],
            "x the frame layer's time",
            MESSAGE_OVER_FRAME_TARGET,
            "lower",
            "our frame layer alone on the same stream",
            1e6 * best["ours"] / n,
            1e6 * best["frames"] / n,
            "us/frame",
            loop_us,
        ),
        _figure(
            "protocol.encode_vs_pymavlink",
            best["pymavlink_encode"] / best["encode"],
            "x pymavlink's speed",
            1.0,
            "higher",
            "pymavlink 2.4 MAVLink.pack of RAW_IMU (38-byte frames)",
            len(w.msgs) / best["encode"],
            len(w.peer_msgs) / best["pymavlink_encode"],
            "frames/s",
            loop_us,
        ),
        _figure(
            "protocol.decode_cpu_share_of_link",
            LINK_BYTES_PER_S * best["ours"] / w.stream_bytes,
            "of one core",
            LINK_CPU_SHARE_TARGET,
            "lower",
            "the byte rate of a 921600-baud link (92.16 kB/s)",
            1e6 * best["ours"] / n,
            None,
            "us/frame",
            loop_us,
        ),
    ]


def run(quick: bool = False) -> list[BenchResult]:
    """The codec's figures for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        A smaller stream and fewer rounds.

    Returns
    -------
    list[BenchResult]
        Decoding and encoding against pymavlink, full decoding against the frame layer, and
        decoding's share of a link's bytes.
    """
    w = workload(5_000 if quick else 40_000)
    best, loop_us = interleaved_slices(lambda: make_round(w), 9 if quick else 15)
    return figures(w, best, loop_us)
