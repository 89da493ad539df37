"""Property tests of the Python codec (bounded: a few seconds in make test)."""

from __future__ import annotations

from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jackson.protocol import MESSAGES, FrameDecoder, Message, crc32c, decode_message, encode_frame
from jackson.protocol.codegen import SCALARS, load_schema

SCHEMA = load_schema()
FAST = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])

_INT_RANGES = {
    "u8": (0, 2**8 - 1),
    "i8": (-(2**7), 2**7 - 1),
    "u16": (0, 2**16 - 1),
    "i16": (-(2**15), 2**15 - 1),
    "u32": (0, 2**32 - 1),
    "i32": (-(2**31), 2**31 - 1),
}


def _scalar(base: str) -> st.SearchStrategy[Any]:
    assert base in SCALARS
    if base == "f32":
        return st.floats(width=32, allow_nan=False)
    lo, hi = _INT_RANGES[base]
    return st.integers(lo, hi)


def _message(spec: Any) -> st.SearchStrategy[Message]:
    cls = MESSAGES[spec.type_id]
    kwargs: dict[str, st.SearchStrategy[Any]] = {}
    for f in spec.fields:
        if f.base == "text":
            kwargs[f.name] = st.text(max_size=f.count // 4)
        elif f.is_array:
            kwargs[f.name] = st.tuples(*[_scalar(f.base)] * f.count)
        else:
            kwargs[f.name] = _scalar(f.base)
    return st.builds(cls, **kwargs)


any_message = st.one_of([_message(m) for m in SCHEMA.messages])
stream_bytes = st.binary(max_size=400) | st.lists(
    st.sampled_from([0xA5, 0x5A, 0x01, 0x00, 0x04, 0x1C, 0xFF]), max_size=300
).map(bytes)


@FAST
@given(any_message, st.integers(0, 255))
def test_every_message_round_trips(msg: Message, seq: int) -> None:
    frames = FrameDecoder().feed(encode_frame(msg, seq))
    assert len(frames) == 1
    assert frames[0].seq == seq
    assert decode_message(frames[0]) == msg


@FAST
@given(stream_bytes, st.integers(1, 64))
def test_any_bytes_never_raise_and_never_yield_a_bad_frame(data: bytes, chunk: int) -> None:
    dec = FrameDecoder()
    delivered = 0
    for i in range(0, len(data), chunk):
        for f in dec.feed(data[i : i + chunk]):
            body = bytes((1, f.type, f.seq, len(f.payload))) + f.payload
            raw = b"\xa5\x5a" + body + crc32c(body).to_bytes(4, "little")
            assert raw in data  # the whole frame, with a matching CRC, came off the wire
            assert f.type in MESSAGES
            decode_message(f)
            delivered += 6 + len(f.payload) + 4
    assert dec.counters.bytes_skipped + delivered + dec.pending == len(data)
    dec.flush()
    assert dec.pending == 0


@FAST
@given(stream_bytes, any_message, st.integers(0, 255), stream_bytes, st.integers(1, 64))
def test_a_valid_frame_anywhere_in_noise_is_found(
    before: bytes, msg: Message, seq: int, after: bytes, chunk: int
) -> None:
    data = before + encode_frame(msg, seq) + after
    dec = FrameDecoder()
    found = []
    for i in range(0, len(data), chunk):
        found += dec.feed(data[i : i + chunk])
    found += dec.flush()
    assert any(f.seq == seq and decode_message(f) == msg for f in found)
