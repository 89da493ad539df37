"""A core's snapshot: the state a run folder's replay starts from when the folder began in the
middle of a daemon's life (a split, docs/recording.md).

The daemon pickles its :class:`~jackson.host.core.HostCore` between two telemetry frames: every
stage with its state (odometry pose, EKF, gyro bias, health monitor, the mission with its
particle filter and RNG, costmaps, navigator, limiter...), without its I/O (the motor output,
the ``send`` callable, the listeners), which are named in the pickle and given anew when it is
loaded (:func:`pickle_state`, :func:`unpickle_state`). The folder's ``core.snapshot`` is

- the 8-byte magic ``b"JSNAP001"`` (the format's version in its last three digits),
- a u32 little-endian length and a UTF-8 JSON header: the writer's Python and NumPy versions,
  the telemetry frames handled and the MCU time of the last one, the pickle's size,
- the pickle (protocol 5), one zstd frame with its content size and checksum.

A pickle holds class and attribute names, not code: a snapshot loads in the version of jackson
that wrote it (a later one may have renamed a stage's attribute). :func:`read_snapshot` says in
one line why a snapshot does not load; the replay compares its outputs bit for bit anyway.
"""

from __future__ import annotations

import io
import json
import os
import pickle
import platform
import struct
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import zstandard

from jackson.host.recording import RecordingError

SNAPSHOT_NAME = "core.snapshot"
MAGIC = b"JSNAP001"
LEVEL = 3  # zstd level: a service's 4.7 MB pickle becomes ~0.1 MB in ~2 ms
_LENGTH = struct.Struct("<I")


class _Pickler(pickle.Pickler):
    """Names the objects in ``external`` (by identity) instead of pickling them."""

    def __init__(self, file: io.BytesIO, external: Mapping[int, str]) -> None:
        super().__init__(file, protocol=5)
        self.external = external

    def persistent_id(self, obj: object) -> str | None:
        return self.external.get(id(obj))


class _Unpickler(pickle.Unpickler):
    """Puts the objects of ``external`` where their names were pickled."""

    def __init__(self, file: io.BytesIO, external: Mapping[str, object]) -> None:
        super().__init__(file)
        self.external = external

    def persistent_load(self, pid: Any) -> object:
        try:
            return self.external[pid]
        except (KeyError, TypeError):
            raise pickle.UnpicklingError(f"the snapshot names {pid!r}, not given") from None


def pickle_state(obj: object, external: Mapping[str, object]) -> bytes:
    """``obj`` pickled, each object of ``external`` (its I/O) pickled as its name only."""
    buf = io.BytesIO()
    _Pickler(buf, {id(v): k for k, v in external.items()}).dump(obj)
    return buf.getvalue()


def unpickle_state(data: bytes, external: Mapping[str, object]) -> object:
    """The object :func:`pickle_state` pickled, with ``external``'s objects in place of the
    names. Raises whatever unpickling raises (the caller names the file)."""
    return _Unpickler(io.BytesIO(data), external).load()


def encode_snapshot(pickled: bytes, header: Mapping[str, Any]) -> bytes:
    """The bytes of a ``core.snapshot`` file (module docstring)."""
    head = json.dumps(
        {
            **header,
            "format": 1,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "pickled_bytes": len(pickled),
        },
        separators=(",", ":"),
    ).encode()
    body = zstandard.ZstdCompressor(level=LEVEL, write_checksum=True).compress(pickled)
    return MAGIC + _LENGTH.pack(len(head)) + head + body


def write_snapshot(path: Path, data: bytes) -> None:
    """Write ``data`` (:func:`encode_snapshot`) to ``path`` whole or not at all (a kill leaves
    no half snapshot: the folder then says its snapshot is missing)."""
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def read_snapshot(path: Path) -> tuple[dict[str, Any], bytes]:
    """The header and the pickle of a ``core.snapshot`` file.

    Raises
    ------
    RecordingError
        The file is missing, not a snapshot, of another format, or damaged (one line).
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise RecordingError(
            f"{path}: cannot read the core's snapshot ({exc.strerror}); the folder began at a "
            "split and cannot be replayed without it"
        ) from exc
    if not data.startswith(MAGIC[:5]):
        raise RecordingError(f"{path}: not a core snapshot (bad magic)")
    if not data.startswith(MAGIC):
        raise RecordingError(
            f"{path}: a core snapshot of format {data[5:8].decode('ascii', 'replace')}, this "
            f"jackson reads {MAGIC[5:].decode()}"
        )
    pos = len(MAGIC) + _LENGTH.size
    try:
        (n,) = _LENGTH.unpack_from(data, len(MAGIC))
        header = json.loads(data[pos : pos + n].decode())
        if not isinstance(header, dict):
            raise ValueError("the header is not a JSON object")
        pickled = zstandard.ZstdDecompressor().decompress(data[pos + n :])
    except (struct.error, ValueError, UnicodeDecodeError, zstandard.ZstdError) as exc:
        raise RecordingError(f"{path}: the core's snapshot is damaged ({exc})") from exc
    if len(pickled) != header.get("pickled_bytes"):
        raise RecordingError(f"{path}: the core's snapshot is damaged (cut short)")
    return header, pickled


def load_error(path: Path, header: Mapping[str, Any], exc: BaseException) -> RecordingError:
    """The one line for a snapshot whose pickle does not load here."""
    wrote = f"Python {header.get('python', '?')}, NumPy {header.get('numpy', '?')}"
    here = f"Python {platform.python_version()}, NumPy {np.__version__}"
    return RecordingError(
        f"{path}: the core's snapshot does not load ({type(exc).__name__}: {exc}); it was "
        f"written by another version of jackson ({wrote}; here {here}): replay it with that one"
    )
