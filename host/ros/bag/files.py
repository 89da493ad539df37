"""The MCAP files of one bag folder: their chunk compression, and the split into
``<name>_0.mcap``, ``<name>_1.mcap``... once a file exceeds a size, as ``ros2 bag record
--max-bag-size`` does."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import BinaryIO

from mcap.writer import CompressionType

from jackson.host.ros.bag.chunk_index import ChunkIndexFile
from jackson.host.ros.bag.errors import BagError
from jackson.host.ros.bag.metadata import BagFile
from jackson.host.ros.bag.topics import BagTopic
from jackson.host.ros.bag.writer import BagWriter

COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}
"""The chunk compressions a bag is written with, by name."""


class McapFiles:
    """The MCAP files of one bag folder, written one after the other.

    Each file registers the schema and channel of every topic when it starts, and is finished
    (its summary and footer written) when the next one starts or the bag closes; what each
    finished file holds (:attr:`done`) is what ``metadata.yaml`` lists.

    Parameters
    ----------
    folder : Path
        The bag folder (it exists before :meth:`open`).
    topics : sequence of BagTopic
        Every topic, in registration order.
    compression : str
        The chunk compression, a key of :data:`COMPRESSION`.
    max_bytes : int or None
        Start the next file once the open one exceeds this size [bytes] (checked by
        :meth:`rotate_if_full`); None: one file.

    Raises
    ------
    ValueError
        ``compression`` is none of :data:`COMPRESSION`.
    """

    def __init__(
        self,
        folder: Path,
        topics: Sequence[BagTopic],
        compression: str,
        max_bytes: int | None,
    ) -> None:
        if compression not in COMPRESSION:
            raise ValueError(f"bag compression {compression!r}: one of {', '.join(COMPRESSION)}")
        self.folder = folder
        self.topics = topics
        self.compression = COMPRESSION[compression]
        self.max_bytes = max_bytes
        self.paths: list[Path] = []  # every MCAP file written, in order
        self.done: list[BagFile] = []  # the finished files
        self.file: BinaryIO | None = None  # the open one

    def open(self) -> None:
        """Start the next MCAP file ``<name>_<k>.mcap`` with every schema and channel.

        Raises
        ------
        BagError
            The file cannot be created.
        """
        file = self.folder / f"{self.folder.name}_{len(self.paths)}.mcap"
        try:
            self.file = file.open("xb")
            self.writer = BagWriter(self.file, compression=self.compression)
            self.writer.start(profile="ros2", library="jackson")
            schema_ids: dict[str, int] = {}
            self._channels: dict[str, int] = {}
            for t in self.topics:
                if t.msgtype not in schema_ids:
                    schema_ids[t.msgtype] = self.writer.register_schema(
                        t.msgtype, "ros2msg", t.msgdef.encode()
                    )
                self._channels[t.name] = self.writer.register_channel(
                    t.name, "cdr", schema_ids[t.msgtype], t.channel_metadata()
                )
        except OSError as exc:
            raise BagError(f"{file}: cannot create the bag file: {exc}") from exc
        self.paths.append(file)
        self._counts: dict[str, int] = {}
        self._span_ns: tuple[int, int] | None = None
        ChunkIndexFile.attach(self.writer, self.folder)

    def add(self, topic: str, ns: int, data: bytes) -> None:
        """One serialised message of ``topic``, logged and published at ``ns`` [ns].

        Raises
        ------
        BagError
            The file cannot be written.
        """
        try:
            self.writer.add_message(self._channels[topic], ns, data, ns)
        except OSError as exc:
            raise BagError(f"{self.paths[-1]}: cannot write {topic}: {exc}") from exc
        self._counts[topic] = self._counts.get(topic, 0) + 1
        span = self._span_ns
        self._span_ns = (ns, ns) if span is None else (min(span[0], ns), max(span[1], ns))

    def flush(self) -> None:
        """Write the open chunk, then the file's buffer.

        Raises
        ------
        BagError
            The file cannot be written.
        """
        try:
            self.writer.flush()  # type: ignore[no-untyped-call]
        except OSError as exc:
            raise BagError(f"{self.paths[-1]}: cannot write: {exc}") from exc

    def finish(self) -> None:
        """Write the open file's summary and footer and close it."""
        file, self.file = self.file, None
        if file is None:
            return
        try:
            self.writer.finish()  # type: ignore[no-untyped-call]
            file.flush()
        finally:
            file.close()
        start, end = self._span_ns or (0, 0)
        self.done.append(BagFile(self.paths[-1].name, dict(self._counts), start, end))

    def rotate_if_full(self) -> None:
        """Finish the file and go on in the next one once it exceeds ``max_bytes``.

        Raises
        ------
        BagError
            The file cannot be finished, or the next one created.
        """
        if self.max_bytes is None or self.file is None or self.file.tell() < self.max_bytes:
            return
        try:
            self.finish()
        except OSError as exc:
            raise BagError(f"{self.paths[-1]}: cannot finish the file: {exc}") from exc
        self.open()

    def abandon(self) -> None:
        """Close the open file unfinished (finishing it failed; ``repair_bag`` recovers it)."""
        if self.file is not None:
            self.file.close()
            self.file = None
