"""Standard measurement nodes (5 bytes each), one at a time and as numpy batches."""

from __future__ import annotations

import struct

import numpy as np
import numpy.typing as npt

from jackson.protocol.errors import EncodeError
from jackson.protocol.rplidar.packets import (
    ANGLE_Q6_MAX,
    DISTANCE_Q2_MAX,
    NODE_BYTES,
    QUALITY_MAX,
    BoolArray,
    MeasurementNode,
    NodeBatch,
    U8Array,
)
from jackson.protocol.rplidar.responses import _byte


def encode_node(node: MeasurementNode) -> bytes:
    """The 5 bytes of one measurement node (C = 1, !S = not S).

    Raises
    ------
    EncodeError
        A quality above 6 bits, an angle above 15 bits or a distance above 16 bits.
    """
    q = _byte(node.quality, "quality", QUALITY_MAX)
    a = _byte(node.angle_q6, "angle_q6", ANGLE_Q6_MAX)
    d = _byte(node.distance_q2, "distance_q2", DISTANCE_Q2_MAX)
    flags = 0b01 if node.start else 0b10
    return struct.pack("<BHH", (q << 2) | flags, (a << 1) | 1, d)


def decode_node(data: bytes) -> MeasurementNode | None:
    """The node in the first 5 bytes of ``data``; None when its check bits are wrong
    (S and !S equal, or C = 0) or fewer than 5 bytes are given."""
    if len(data) < NODE_BYTES:
        return None
    b0, angle, distance = struct.unpack_from("<BHH", data)
    if not ((b0 ^ (b0 >> 1)) & 1) or not angle & 1:
        return None
    return MeasurementNode(b0 >> 2, bool(b0 & 1), angle >> 1, distance)


def encode_nodes(
    start: npt.ArrayLike,
    quality: npt.ArrayLike,
    angle_q6: npt.ArrayLike,
    distance_q2: npt.ArrayLike,
) -> bytes:
    """Many nodes at once (the arrays broadcast to one length): their bytes back to back.

    Parameters
    ----------
    start : array_like of bool
        S flags.
    quality : array_like of int
        Qualities, 0..63.
    angle_q6 : array_like of int
        Headings [deg] * 64, 0..32767.
    distance_q2 : array_like of int
        Distances [mm] * 4, 0..65535.

    Returns
    -------
    bytes
        ``5 * n`` bytes.

    Raises
    ------
    EncodeError
        A value out of its field.
    """
    s, q, a, d = np.broadcast_arrays(
        np.asarray(start, dtype=bool),
        np.asarray(quality, dtype=np.int64),
        np.asarray(angle_q6, dtype=np.int64),
        np.asarray(distance_q2, dtype=np.int64),
    )
    for values, top, what in ((q, QUALITY_MAX, "quality"), (a, ANGLE_Q6_MAX, "angle_q6")):
        if values.size and (values.min() < 0 or values.max() > top):
            raise EncodeError(f"RPLIDAR {what} must be in 0..{top}")
    if d.size and (d.min() < 0 or d.max() > DISTANCE_Q2_MAX):
        raise EncodeError(f"RPLIDAR distance_q2 must be in 0..{DISTANCE_Q2_MAX}")
    out = np.empty((s.size, NODE_BYTES), dtype=np.uint8)
    out[:, 0] = (q.ravel() << 2) | np.where(s.ravel(), 0b01, 0b10)
    word = (a.ravel() << 1) | 1
    out[:, 1] = word & 0xFF
    out[:, 2] = word >> 8
    out[:, 3] = d.ravel() & 0xFF
    out[:, 4] = d.ravel() >> 8
    return out.tobytes()


def _valid_nodes(rows: U8Array) -> BoolArray:
    """Which ``(n, 5)`` rows pass the check bits (S != !S and C = 1)."""
    b0, b1 = rows[:, 0], rows[:, 1]
    valid: BoolArray = (((b0 ^ (b0 >> 1)) & b1 & 1) == 1).astype(np.bool_)
    return valid


def _batch(rows: U8Array) -> NodeBatch:
    rows16 = rows.astype(np.uint16)
    return NodeBatch(
        start=(rows[:, 0] & 1).astype(np.bool_),
        quality=(rows[:, 0] >> 2).astype(np.uint8),
        angle_q6=((rows16[:, 1] | (rows16[:, 2] << 8)) >> 1).astype(np.uint16),
        distance_q2=(rows16[:, 3] | (rows16[:, 4] << 8)).astype(np.uint16),
    )


def decode_nodes(data: bytes) -> NodeBatch:
    """Whole nodes in ``data`` (a multiple of 5 bytes) with no check: use
    :class:`ResponseDecoder` for a stream, which checks and resynchronises.

    Raises
    ------
    ValueError
        ``data`` is not a multiple of 5 bytes.
    """
    if len(data) % NODE_BYTES:
        raise ValueError(f"nodes are 5 bytes each, got {len(data)} bytes")
    rows = np.frombuffer(data, dtype=np.uint8).reshape(-1, NODE_BYTES)
    return _batch(rows)
