"""Making a bag whose writer died readable again (``jackson bag repair``, ``ros2 bag reindex``):
the messages of every record that reached the disk whole, a summary and ``metadata.yaml``."""

from __future__ import annotations

import os
import struct
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import BinaryIO

from mcap.exceptions import InvalidMagic, McapError
from mcap.reader import SeekingReader
from mcap.records import Channel as McapChannel
from mcap.records import Chunk as McapChunk
from mcap.records import Message as McapMessage
from mcap.records import Schema as McapSchema
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.summary import Summary
from mcap.writer import CompressionType
from mcap.writer import Writer as McapFileWriter
from zstandard import ZstdError

from jackson.host.ros.bag.errors import BagError
from jackson.host.ros.bag.metadata import BagFile, fsync_replace, write_metadata
from jackson.host.ros.bag.reader import bag_folders, bag_info, needs_repair
from jackson.host.ros.bag.topics import BagTopic


def _split_index(file: Path) -> tuple[int, str]:
    """Sort key of a bag's files: ``bag_2.mcap`` before ``bag_10.mcap``."""
    _, _, k = file.stem.rpartition("_")
    return (int(k) if k.isdigit() else -1, file.name)


# what the mcap readers raise where a file ends inside a record or holds garbage
_CUT = (McapError, EOFError, ValueError, struct.error, RuntimeError)
# and what a damaged compressed chunk raises when it is opened (lz4's errors are RuntimeErrors)
_DAMAGED_CHUNK = (*_CUT, ZstdError)


def whole_records(file: Path) -> Iterator[object]:
    """Every whole record of ``file`` in order, chunks opened, read with the mcap library's
    stream reader: it stops at the first record cut by the kill; a chunk that is whole but
    damaged (a power loss can leave zeros where data should be) fails its CRC, or its
    decompression, and is skipped.

    Raises
    ------
    BagError
        The file does not start with the MCAP magic.
    """
    with file.open("rb") as f:
        records = StreamReader(f, emit_chunks=True, record_size_limit=1 << 30).records
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            except InvalidMagic as exc:
                raise BagError(f"{file}: not an MCAP file") from exc
            except _CUT:
                return  # the end of what reached the disk (a cut magic: nothing)
            if isinstance(record, McapChunk):
                try:
                    yield from breakup_chunk(record, validate_crc=True)
                except _DAMAGED_CHUNK:
                    continue
            else:
                yield record


def _summary(file: Path) -> Summary | None:
    """The summary of a finished MCAP file (its footer points at one with statistics)."""
    try:
        with file.open("rb") as f:
            summary = SeekingReader(f, record_size_limit=1 << 30).get_summary()
    except (*_CUT, OSError):
        return None
    return summary if summary is not None and summary.statistics is not None else None


def _topic(channel: McapChannel, schema: McapSchema | None) -> BagTopic:
    return BagTopic(
        channel.topic,
        schema.name if schema is not None else "",
        channel.metadata.get("offered_qos_profiles", ""),
        channel.metadata.get("topic_type_hash", ""),
        schema.data.decode(errors="replace") if schema is not None else "",
    )


def _finished_file(file: Path, summary: Summary) -> tuple[BagFile, list[BagTopic]]:
    stats = summary.statistics
    assert stats is not None
    counts: dict[str, int] = {}
    topics = []
    for cid, channel in summary.channels.items():
        topics.append(_topic(channel, summary.schemas.get(channel.schema_id)))
        counts[channel.topic] = counts.get(channel.topic, 0) + stats.channel_message_counts.get(
            cid, 0
        )
    n = stats.message_count
    span = (stats.message_start_time, stats.message_end_time) if n else (0, 0)
    return BagFile(file.name, counts, *span), topics


def _repair_file(file: Path) -> tuple[BagFile, list[BagTopic]]:
    """Rewrite an unfinished MCAP file with the messages of its whole records and a summary,
    written beside it and moved over it (``os.replace``) only when complete."""
    tmp = file.with_name(f"{file.name}.repair")
    try:
        with tmp.open("wb") as f:
            found = _rewrite(whole_records(file), f)
            f.flush()
            os.fsync(f.fileno())
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    fsync_replace(tmp, file)
    counts, span, topics = found
    return BagFile(file.name, counts, *span), topics


def _rewrite(
    records: Iterable[object], out: BinaryIO
) -> tuple[dict[str, int], tuple[int, int], list[BagTopic]]:
    """Copy schemas, channels and messages to ``out`` as a finished MCAP file, one record at
    a time; the messages per topic, their span ((0, 0) without any) and the topics kept."""
    writer = McapFileWriter(out, compression=CompressionType.ZSTD)
    writer.start(profile="ros2", library="jackson")
    schemas: dict[int, tuple[int, McapSchema]] = {}  # old id -> new id, record
    channels: dict[int, tuple[int, str]] = {}  # old id -> new id, topic
    topics = []
    counts: dict[str, int] = {}
    start, end = 2**64, -1
    for r in records:
        if isinstance(r, McapSchema) and r.id not in schemas:
            schemas[r.id] = (writer.register_schema(r.name, r.encoding, r.data), r)
        elif isinstance(r, McapChannel) and r.id not in channels:
            if r.schema_id and r.schema_id not in schemas:
                continue  # its type was cut off: its messages cannot be decoded
            new_sid, schema = schemas[r.schema_id] if r.schema_id else (0, None)
            new_cid = writer.register_channel(r.topic, r.message_encoding, new_sid, r.metadata)
            channels[r.id] = (new_cid, r.topic)
            topics.append(_topic(r, schema))
        elif isinstance(r, McapMessage) and r.channel_id in channels:
            cid, topic = channels[r.channel_id]
            writer.add_message(cid, r.log_time, r.data, r.publish_time, r.sequence)
            counts[topic] = counts.get(topic, 0) + 1
            start, end = min(start, r.log_time), max(end, r.log_time)
    writer.finish()  # type: ignore[no-untyped-call]
    return counts, ((start, end) if counts else (0, 0)), topics


def repair_bag(path: Path | str) -> int:
    """Make a bag whose writer died before :meth:`~jackson.host.ros.bag.BagRecorder.close`
    readable (like ``ros2 bag reindex``).

    Every file of the bag that has no summary (the one open when the writer died) is rewritten
    with the messages of its records that reached the disk whole (chunks are written every
    ``flush_interval_s`` of message time), same topics, types, offered QoS and timestamps; the
    rewrite goes beside the file and replaces it (``os.replace``) only when complete, so a
    failure leaves the original's bytes. Finished files are kept as they are. Then
    ``metadata.yaml`` lists them all. A bag that already has ``metadata.yaml`` is left alone.

    Parameters
    ----------
    path : Path or str
        The bag folder.

    Returns
    -------
    int
        The number of messages in the (repaired) bag.

    Raises
    ------
    BagError
        The folder holds no MCAP file, or one that is not MCAP.
    """
    path = Path(path)
    if (path / "metadata.yaml").exists():
        return bag_info(path).message_count
    files = sorted(path.glob("*.mcap"), key=_split_index)
    if not files:
        raise BagError(f"{path}: no .mcap file to repair")
    done: list[BagFile] = []
    topics: dict[tuple[str, str], BagTopic] = {}
    for file in files:
        summary = _summary(file)
        try:
            info, found = (
                _finished_file(file, summary) if summary is not None else _repair_file(file)
            )
        except OSError as exc:
            raise BagError(f"{file}: cannot repair: {exc}") from exc
        done.append(info)
        for t in found:
            topics.setdefault((t.name, t.msgtype), t)
    try:
        write_metadata(path, list(topics.values()), done)
    except OSError as exc:
        raise BagError(f"{path}: cannot write metadata.yaml: {exc}") from exc
    return sum(f.message_count for f in done)


def repair_run(run: Path | str) -> list[tuple[Path, int]]:
    """Repair every unfinished bag folder of a run folder; ``(folder, messages)`` of each."""
    return [(p, repair_bag(p)) for p in bag_folders(run) if needs_repair(p)]
