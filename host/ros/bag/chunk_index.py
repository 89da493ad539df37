"""The MCAP writer's chunk indexes, kept in a file until the summary is written."""

from __future__ import annotations

import struct
import tempfile
from collections.abc import Iterator
from pathlib import Path

from mcap.data_stream import RecordBuilder
from mcap.records import ChunkIndex as McapChunkIndex
from mcap.writer import Writer as McapFileWriter


class ChunkIndexFile:
    """The chunk indexes of one MCAP file kept on disk until its summary is written.

    mcap's writer keeps a ``ChunkIndex`` object (with a dict of the chunk's channels) for every
    chunk it has finished, to write them all in the summary at the end. The bag finishes a
    chunk every second of MCU time (each flush makes the bag readable up to it), so a
    navigating robot-hour left 3600 of them, about 2 MB, in the daemon's memory. This list
    takes their place in the writer: each index is serialized as it comes (the record the
    summary will hold) into an unnamed temporary file beside the bag, and read back once, when
    the summary is written. Memory stays flat however long the run.
    """

    def __init__(self, folder: Path) -> None:
        # closed once read back (__iter__), or with the process
        self._file = tempfile.TemporaryFile(dir=folder, prefix=".chunk-index-")  # noqa: SIM115
        self._count = 0

    @classmethod
    def attach(cls, writer: McapFileWriter, folder: Path) -> None:
        """Replace ``writer``'s in-memory list (mcap 1.6's ``Writer.__chunk_indices``); a writer
        without one (another mcap version) keeps its own."""
        name = "_Writer__chunk_indices"
        if isinstance(getattr(writer, name, None), list):
            setattr(writer, name, cls(folder))

    def append(self, index: McapChunkIndex) -> None:
        """Serialize one chunk index to the file."""
        rb = RecordBuilder()
        index.write(rb)
        data = rb.end()  # type: ignore[no-untyped-call]
        self._file.write(struct.pack("<I", len(data)) + data)
        self._count += 1

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[_RawRecord]:
        """The records in order (each written as it was serialized), then the file is closed."""
        self._file.seek(0)
        try:
            for _ in range(self._count):
                (n,) = struct.unpack("<I", self._file.read(4))
                yield _RawRecord(self._file.read(n))
        finally:
            self._file.close()


class _RawRecord:
    """A serialized MCAP record, written as it is."""

    def __init__(self, data: bytes) -> None:
        self.data = data

    def write(self, stream: RecordBuilder) -> None:
        stream.write(self.data)
