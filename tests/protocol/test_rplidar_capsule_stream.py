"""A capsule stream decoded in bulk: the whole capsules at the head of the buffer checked at once
(sync nibbles, checksums) give what the byte-by-byte loop gives, with garbage, corrupted bytes
and any chunking; the variable-bit-scale codes looked up in tables as computed level by level."""

from __future__ import annotations

import numpy as np
import pytest

from jackson.protocol import native
from jackson.protocol.rplidar import (
    CapsuleDecoder,
    encode_capsule,
    encode_dense_capsule,
    encode_ultra_capsule,
    express,
    varbitscale_decode,
)


def _stream(answer_type: int, rng: np.random.Generator, capsules: int) -> bytes:
    """Capsules of one format, a turn about every 11, random distances."""
    out = []
    for k in range(capsules):
        start_q6 = (k * 2086) % (360 * 64)
        first = k == 0
        if answer_type == 0x82:
            out.append(
                encode_capsule(start_q6, first, rng.integers(0, 16000, 32), rng.integers(0, 63, 32))
            )
        elif answer_type == 0x84:
            out.append(encode_ultra_capsule(start_q6, first, rng.integers(0, 12000, 97)))
        else:
            out.append(encode_dense_capsule(start_q6, first, rng.integers(0, 40000, 40)))
    return b"".join(out)


def _damaged(stream: bytes, rng: np.random.Generator) -> bytes:
    """Garbage inserted, bytes flipped and runs cut out here and there."""
    b = bytearray(stream)
    for _ in range(25):
        at = int(rng.integers(0, len(b)))
        kind = int(rng.integers(0, 3))
        if kind == 0:
            b[at:at] = bytes(rng.integers(0, 256, int(rng.integers(1, 150)), dtype=np.uint8))
        elif kind == 1:
            b[at] ^= int(rng.integers(1, 256))
        else:
            del b[at : at + int(rng.integers(1, 40))]
    return bytes(b)


def _decode(chunks: list[bytes], answer_type: int) -> tuple[list[bytes], tuple[int, int, int]]:
    dec = CapsuleDecoder(answer_type)
    batches = [dec.feed(c) for c in chunks]
    fields = [b.start.tobytes() + b.angle_q6.tobytes() + b.distance_q2.tobytes() for b in batches]
    return fields, (dec.capsules, dec.starts, dec.malformed_bytes)


@pytest.mark.parametrize("answer_type", [0x82, 0x84, 0x85])
@pytest.mark.parametrize("seed", range(4))
def test_capsules_checked_at_once_decode_as_one_by_one(
    answer_type: int, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(seed)
    stream = _stream(answer_type, rng, 60)
    if seed:  # seed 0: a clean stream
        stream = _damaged(stream, rng)
    cuts = sorted(rng.integers(0, len(stream), 40).tolist())
    chunks = [stream[i:j] for i, j in zip([0, *cuts], [*cuts, len(stream)], strict=True)]
    monkeypatch.setattr(native, "LIB", None)  # numpy's bulk check against its byte loop
    fast = _decode(chunks, answer_type)
    monkeypatch.setattr(CapsuleDecoder, "_whole_capsules", lambda self, pairs: 0)
    slow = _decode(chunks, answer_type)
    assert fast == slow
    capsules, starts, malformed = fast[1]
    assert capsules > 30
    assert (malformed > 0) == (seed > 0)
    if seed == 0:
        assert capsules == 60 and starts == 1


@pytest.mark.parametrize("answer_type", [0x82, 0x84, 0x85])
@pytest.mark.parametrize("byte", [0, 1])
def test_a_capsule_with_a_bad_sync_nibble_and_a_good_checksum_is_skipped_in_bulk_too(
    answer_type: int, byte: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sync nibble changed (the checksum's halves beside it untouched) in the first capsule
    the bulk check sees wrong."""
    stream = bytearray(_stream(answer_type, np.random.default_rng(9), 20))
    stream[5 * (len(stream) // 20) + byte] ^= 0x30
    monkeypatch.setattr(native, "LIB", None)
    fast = _decode([bytes(stream)], answer_type)
    monkeypatch.setattr(CapsuleDecoder, "_whole_capsules", lambda self, pairs: 0)
    assert fast == _decode([bytes(stream)], answer_type)
    assert fast[1][0] == 19 and fast[1][2] > 0


def test_every_12_bit_code_reads_its_tables_as_its_levels() -> None:
    codes = np.arange(4096, dtype=np.int64)
    distance, level = varbitscale_decode(codes)
    want_d, want_l = express._varbitscale_levels(codes)
    assert np.array_equal(distance, want_d) and np.array_equal(level, want_l)
    assert distance[4095] == 28656 and level[4095] == 4 and distance[511] == 511
    # beyond 12 bits the levels are computed as before
    wide = np.array([5000, 4096, -1], dtype=np.int64)
    assert [a.tolist() for a in varbitscale_decode(wide)] == [
        a.tolist() for a in express._varbitscale_levels(wide)
    ]
