"""The bag's MCAP writer appends a message in one write: the same file, byte for byte, as
``mcap``'s own writer given the same messages (chunks of any size, every compression, log times
out of order, chunking off), and readable by ``mcap``'s reader."""

from __future__ import annotations

import io

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from jackson.host.ros.bag.writer import BagWriter


def _write(cls: type[Writer], seed: int, **options: object) -> bytes:
    rng = np.random.default_rng(seed)
    out = io.BytesIO()
    writer = cls(out, **options)  # type: ignore[arg-type]
    writer.start(profile="ros2", library="jackson")
    schema = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
    channels = [writer.register_channel(f"/topic{k}", "cdr", schema) for k in range(5)]
    t = 1_000_000_000
    for k in range(3000):
        t += int(rng.integers(0, 20_000_000))
        log = t - int(rng.integers(0, 50_000_000)) if k % 7 == 0 else t  # some out of order
        data = rng.integers(0, 256, int(rng.integers(0, 700)), dtype=np.uint8).tobytes()
        channel = channels[int(rng.integers(0, len(channels)))]
        if k == 1500:  # a channel registered between messages
            channels.append(writer.register_channel("/late", "cdr", schema))
        writer.add_message(channel, log, data, t, sequence=k % 3)
    writer.finish()
    return out.getvalue()


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"compression": CompressionType.ZSTD},
        {"compression": CompressionType.LZ4, "chunk_size": 4096},
        {"compression": CompressionType.NONE, "chunk_size": 100},
        {"use_chunking": False},
    ],
    ids=["default", "zstd", "lz4-small-chunks", "uncompressed-tiny-chunks", "no-chunks"],
)
@pytest.mark.parametrize("seed", range(2))
def test_the_file_is_mcaps_byte_for_byte(options: dict[str, object], seed: int) -> None:
    ours = _write(BagWriter, seed, **options)
    theirs = _write(Writer, seed, **options)
    assert ours == theirs
    summary = make_reader(io.BytesIO(ours)).get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == 3000


def test_a_writer_without_mcaps_private_state_appends_as_mcap_does() -> None:
    """Another ``mcap`` version: its own append, the same file."""

    class Foreign(BagWriter):
        def __init__(self, *args: object, **kwargs: object) -> None:
            super().__init__(*args, **kwargs)
            self._lean = False

    assert _write(Foreign, 3) == _write(Writer, 3)
    assert BagWriter(io.BytesIO())._lean  # mcap 1.6 (the pinned version): the lean append
