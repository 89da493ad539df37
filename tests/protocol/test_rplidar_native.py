"""The compiled capsule decoding (jackson.protocol.native) against numpy's: the same samples,
counts, held capsule and sync state, bit for bit, on streams of every format that are clean,
damaged, chunked at random, or made of capsules whose bodies are random bytes (every
prediction, borrow, no-return code and angle the fields can hold)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from jackson.host.lidar.rplidar import RevolutionAssembler
from jackson.protocol import native
from jackson.protocol.rplidar import CapsuleDecoder, express
from tests.protocol.test_rplidar_capsule_stream import _damaged, _stream

pytestmark = pytest.mark.skipif(native.LIB is None, reason=f"no compiled build: {native.REASON}")

FORMATS = {0x82: (84, 32), 0x84: (132, 96), 0x85: (84, 40)}


def _random_capsules(answer_type: int, rng: np.random.Generator, count: int, step_q6: int) -> bytes:
    """Capsules with random bodies and start angles ``step_q6`` apart (with jitter, wrapping,
    the S bit now and then), each with its sync nibbles and checksum right."""
    n = FORMATS[answer_type][0]
    out = []
    angle = int(rng.integers(0, 23040))
    for _ in range(count):
        body = rng.integers(0, 256, n - 4, dtype=np.uint8)
        angle = (angle + step_q6 + int(rng.integers(-3, 4))) % 0x8000
        word = angle | (0x8000 if rng.random() < 0.03 else 0)
        capsule = bytearray(n)
        capsule[2], capsule[3] = word & 0xFF, word >> 8
        capsule[4:] = body.tobytes()
        x = int(np.bitwise_xor.reduce(np.frombuffer(bytes(capsule[2:]), np.uint8)))
        capsule[0] = 0xA0 | (x & 0xF)
        capsule[1] = 0x50 | (x >> 4)
        out.append(bytes(capsule))
    return b"".join(out)


def _chunks(stream: bytes, rng: np.random.Generator, cuts: int) -> list[bytes]:
    at = sorted(rng.integers(0, len(stream), cuts).tolist())
    return [stream[i:j] for i, j in zip([0, *at], [*at, len(stream)], strict=True)]


def _run(
    chunks: list[bytes], answer_type: int
) -> tuple[list[tuple[bytes, str]], tuple[object, ...]]:
    dec = CapsuleDecoder(answer_type)
    out = []
    for c in chunks:
        b = dec.feed(c)
        out.append(
            (b.start.tobytes() + b.angle_q6.tobytes() + b.distance_q2.tobytes(),
             f"{b.start.dtype} {b.angle_q6.dtype} {b.distance_q2.dtype} {len(b)}")
        )  # fmt: skip
    state = (
        dec.capsules,
        dec.starts,
        dec.malformed_bytes,
        dec._held,
        dec._last_sync,
        bytes(dec._buf),
    )
    return out, state


def _both(
    chunks: list[bytes], answer_type: int, monkeypatch: pytest.MonkeyPatch
) -> tuple[object, object]:
    compiled = _run(chunks, answer_type)
    with monkeypatch.context() as m:
        m.setattr(native, "LIB", None)
        interpreted = _run(chunks, answer_type)
    return compiled, interpreted


@pytest.mark.parametrize("answer_type", sorted(FORMATS))
@pytest.mark.parametrize("seed", range(6))
def test_encoded_streams_decode_alike(
    answer_type: int, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(100 + seed)
    stream = _stream(answer_type, rng, 80)
    if seed % 2:
        stream = _damaged(stream, rng)
    compiled, interpreted = _both(_chunks(stream, rng, 50), answer_type, monkeypatch)
    assert compiled == interpreted
    assert compiled[1][0] > 40


@pytest.mark.parametrize("answer_type", sorted(FORMATS))
@pytest.mark.parametrize("step_q6", [0, 1, 90, 2086, 11520, 23039, 30000])
def test_random_capsule_bodies_decode_alike(
    answer_type: int, step_q6: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Random bodies: ultra predictions of -512 and 0x1FF, borrows, negative distances
    (a prediction below its base), angles wrapping past a turn, steps of none to most of a
    turn, and start angles beyond 360 deg (15 bits)."""
    rng = np.random.default_rng(step_q6 + answer_type)
    stream = _random_capsules(answer_type, rng, 200, step_q6)
    compiled, interpreted = _both(_chunks(stream, rng, 120), answer_type, monkeypatch)
    assert compiled == interpreted
    whole = b"".join(s for s, _ in compiled[0])
    assert len(whole) > 150 * FORMATS[answer_type][1] * 17
    if answer_type == 0x84:  # some distances came out negative: the shifts of negatives agree
        dec = CapsuleDecoder(answer_type)
        assert (dec.feed(stream).distance_q2 < 0).any()


@pytest.mark.parametrize("answer_type", sorted(FORMATS))
def test_garbage_only_and_byte_at_a_time(answer_type: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(answer_type)
    garbage = bytes(rng.integers(0, 256, 3000, dtype=np.uint8))
    stream = _stream(answer_type, rng, 12)
    chunks = [garbage[:1500], b"", garbage[1500:], *(stream[i : i + 1] for i in range(len(stream)))]
    compiled, interpreted = _both(chunks, answer_type, monkeypatch)
    assert compiled == interpreted
    assert compiled[1][2] > 0 and compiled[1][0] >= 12


def test_a_snapshot_decodes_on_alike(monkeypatch: pytest.MonkeyPatch) -> None:
    """A decoder pickled mid-capsule (a core's snapshot) goes on the same either way, and an
    assembler's revolutions are the same."""
    rng = np.random.default_rng(7)
    stream = _stream(0x84, rng, 60)
    dec = CapsuleDecoder(0x84)
    dec.feed(stream[:1000])
    copy = pickle.dumps(dec)
    a = pickle.loads(copy).feed(stream[1000:])
    with monkeypatch.context() as m:
        m.setattr(native, "LIB", None)
        b = pickle.loads(copy).feed(stream[1000:])
    assert a.start.tobytes() + a.angle_q6.tobytes() == b.start.tobytes() + b.angle_q6.tobytes()
    assert np.array_equal(a.distance_q2, b.distance_q2)
    revs = []
    for lib in (native.LIB, None):
        m2 = pytest.MonkeyPatch()
        m2.setattr(native, "LIB", lib)
        asm = RevolutionAssembler(answer_type=0x84)
        got = [r for c in _chunks(stream, rng, 30) for r in asm.feed(c)]
        m2.undo()
        revs.append([(r.angles_rad.tobytes(), r.ranges_m.tobytes()) for r in got])
    assert revs[0] == revs[1] and len(revs[0]) >= 4


def test_a_held_capsule_of_another_size_is_refused() -> None:
    with pytest.raises(ValueError, match="held capsule of 3 bytes"):
        native.capsules_feed(0x84, 132, 96, b"\xa0" * 200, b"abc", False)


@pytest.mark.parametrize("dtype", [np.int64, np.uint16, np.int32])
def test_a_turn_is_numpys_bit_for_bit(dtype: type, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every heading of two turns either way (each wrap, the seam at 180 deg), many repeated
    (the stable sort keeps their order: the ranges tell), no returns and ranges at and past the
    cap."""
    rng = np.random.default_rng(3)
    lo = 0 if dtype is np.uint16 else -23040
    q6 = np.concatenate((np.arange(lo, 46080), rng.integers(max(lo, 0), 23040, 5000)))
    q2 = rng.integers(0, 40000, q6.size)
    q2[::7] = 0
    q2[::11] = 32000  # exactly the 8 m cap
    revs = []
    for lib in (native.LIB, None):
        monkeypatch.setattr(native, "LIB", lib)
        asm = RevolutionAssembler(range_cap_m=8.0)
        asm._angle_parts = [q6[:30000].astype(dtype), q6[30000:].astype(dtype)]
        asm._distance_parts = [q2[:30000].astype(dtype), q2[30000:].astype(dtype)]
        r = asm._finish_turn()
        revs.append((r.angles_rad.tobytes(), r.ranges_m.tobytes(), r.nodes, asm.revolutions))
    assert revs[0] == revs[1]
    angles = np.frombuffer(revs[0][0])
    assert angles.min() >= -np.pi and angles.max() < np.pi and np.all(np.diff(angles) >= 0)
    ranges = np.frombuffer(revs[0][1])
    assert np.isinf(ranges).sum() >= q6.size // 7 and (ranges == 8.0).any()


def test_ultra_capsules_are_encoded_as_numpy_encodes_them() -> None:
    """Random distances and, at every scale level, predictions on each side of the 10-bit
    range (-511 and 510 steps from their base, and one beyond), borrows from a zero major,
    no returns; the S bit on the first capsule only."""
    rng = np.random.default_rng(11)
    rows = [rng.integers(0, 30000, 97) for _ in range(20)]
    for base in (300, 2000, 3000, 9000, 20000):
        _, level = express.varbitscale_decode(express.varbitscale_encode(np.array([base])))
        step = 1 << int(level[0])
        d = np.full(97, base)
        for j, k in enumerate(range(-514, -508)):
            d[3 * j + 1] = max(base + k * step, 0)
            d[3 * j + 2] = base + (k + 1021) * step  # -> 507 .. 512 steps
        d[30:36] = 0  # no return, and a zero major borrowing the next one's
        d[36] = 700
        rows.append(d)
    d = np.array(rows, np.int64)
    q6 = rng.integers(0, 0x8000, len(rows))
    data, dropouts = native.ultra_capsules(d, q6, True)
    want = b"".join(
        express.encode_ultra_capsule(int(q6[c]), c == 0, d[c]) for c in range(len(rows))
    )
    assert data == want
    decoded = np.array([express.encode_ultra_cabins(row)[1] for row in d])
    assert dropouts == int(np.count_nonzero((decoded == 0) & (d[:, :96] > 0))) > 0
    with pytest.raises(ValueError, match="out of range"):
        native.ultra_capsules(d - 40000, q6, False)
