"""Express scans: the EXPRESS_SCAN request and the capsule formats of its stream (legacy,
ultra and dense capsules), both directions."""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.protocol import native
from jackson.protocol.errors import EncodeError
from jackson.protocol.rplidar.conf import _U16
from jackson.protocol.rplidar.packets import ANGLE_Q6_MAX, BoolArray, DataType, Descriptor, SendMode
from jackson.protocol.rplidar.responses import _byte, encode_descriptor

_EXPRESS_SCAN = struct.Struct("<BHH")


@dataclass(frozen=True)
class ExpressScanRequest:
    """The 5-byte payload of EXPRESS_SCAN.

    Attributes
    ----------
    working_mode : int
        0: the legacy express scan (capsules, 0x82); else the id of the scan mode to run.
    working_flags : int
        u16 (boost, sunlight rejection on some models); 0 from Slamtec's SDK.
    param : int
        u16, reserved: 0.
    """

    working_mode: int = 0
    working_flags: int = 0
    param: int = 0


def encode_express_scan(request: ExpressScanRequest) -> bytes:
    """The 5-byte payload of an EXPRESS_SCAN request.

    Raises
    ------
    EncodeError
        A field out of its width.
    """
    return _EXPRESS_SCAN.pack(
        _byte(request.working_mode, "working mode"),
        _byte(request.working_flags, "working flags", 0xFFFF),
        _byte(request.param, "param", 0xFFFF),
    )


def decode_express_scan(payload: bytes) -> ExpressScanRequest:
    """An EXPRESS_SCAN payload; a shorter one is read as if padded with zeros."""
    working_mode, flags, param = _EXPRESS_SCAN.unpack(
        bytes(payload[: _EXPRESS_SCAN.size]).ljust(_EXPRESS_SCAN.size, b"\x00")
    )
    return ExpressScanRequest(working_mode, flags, param)


CAPSULE_SYNC_1 = 0xA
"""High nibble of a capsule's byte 0 (its low nibble: checksum bits 0-3)."""
CAPSULE_SYNC_2 = 0x5
"""High nibble of a capsule's byte 1 (its low nibble: checksum bits 4-7)."""
CAPSULE_START_BIT = 0x8000
"""Bit 15 of a capsule's start angle word: the first capsule of a stream (after EXPRESS_SCAN,
or after a gap): a decoder drops the capsule it holds and starts afresh."""
CAPSULE_HEADER_BYTES = 4
ANGLE_Q6_TURN = 360 * 64
"""A turn in angle_q6 units."""
ANGLE_Q16_TURN = 360 << 16
CAPSULE_DISTANCE_MM_MAX = 0x3FFF  # 14 bits in a legacy capsule
CAPSULE_DTHETA_Q3_MAX = 0x3F  # 6 bits, 1/8 deg


@dataclass(frozen=True)
class CapsuleFormat:
    """One capsule format of EXPRESS_SCAN streams.

    Every capsule is ``sync/checksum (2 bytes), start angle (u16 LE: angle_q6 | S << 15),
    samples``; the checksum is the XOR of every byte after the first two, its low nibble in
    byte 0 and its high nibble in byte 1 (under the sync nibbles 0xA and 0x5). A capsule's
    samples are spread evenly from its start angle to the next capsule's, so a decoder
    turns a capsule into samples when the next one arrives.

    Attributes
    ----------
    answer_type : int
        :class:`DataType` of the descriptor and of GET_LIDAR_CONF's SCAN_MODE_ANS_TYPE.
    capsule_bytes : int
        Bytes of one capsule (the descriptor's length).
    samples : int
        Samples in one capsule.
    """

    answer_type: int
    capsule_bytes: int
    samples: int

    def __reduce__(self) -> tuple[Callable[[int], CapsuleFormat], tuple[int]]:
        """Pickled as its answer type, so a copy is the module's own format (the decoder tells
        the formats apart by identity): a core's snapshot (docs/recording.md) decodes on."""
        return capsule_format, (int(self.answer_type),)

    @property
    def descriptor(self) -> bytes:
        """The response descriptor of EXPRESS_SCAN in this format (multiple)."""
        return encode_descriptor(
            Descriptor(self.capsule_bytes, SendMode.MULTIPLE, self.answer_type)
        )


CAPSULED = CapsuleFormat(DataType.MEASUREMENT_CAPSULED, 84, 32)
"""Legacy express capsules: 16 cabins of 5 bytes, two samples each: distance [mm] u14 and an
angle correction dtheta [1/8 deg] u6 (``A5 5A 54 00 00 40 82``)."""
ULTRA_CAPSULED = CapsuleFormat(DataType.MEASUREMENT_ULTRA_CAPSULED, 132, 96)
"""Ultra capsules: 32 cabins of a u32, three samples each: a major distance (12-bit
variable-bit-scale code) and two 10-bit signed predictions (``A5 5A 84 00 00 40 84``)."""
DENSE_CAPSULED = CapsuleFormat(DataType.MEASUREMENT_DENSE_CAPSULED, 84, 40)
"""Dense capsules: 40 distances [mm] u16 (``A5 5A 54 00 00 40 85``)."""
CAPSULE_FORMATS: dict[int, CapsuleFormat] = {
    f.answer_type: f for f in (CAPSULED, ULTRA_CAPSULED, DENSE_CAPSULED)
}


def capsule_format(answer_type: int) -> CapsuleFormat:
    """The capsule format of ``answer_type`` (a key of :data:`CAPSULE_FORMATS`)."""
    return CAPSULE_FORMATS[answer_type]


I64Array = npt.NDArray[np.int64]


def _xor(data: bytes) -> int:
    return int(np.bitwise_xor.reduce(np.frombuffer(data, dtype=np.uint8))) if data else 0


def _pack_capsule(start_angle_q6: int, start: bool, body: bytes) -> bytes:
    word = _byte(start_angle_q6, "capsule start angle_q6", ANGLE_Q6_MAX) | (
        CAPSULE_START_BIT if start else 0
    )
    rest = _U16.pack(word) + body
    checksum = _xor(rest)
    return (
        bytes(((CAPSULE_SYNC_1 << 4) | (checksum & 0xF), (CAPSULE_SYNC_2 << 4) | (checksum >> 4)))
        + rest
    )


def _samples(values: npt.ArrayLike, n: int, top: int, what: str) -> I64Array:
    a = np.broadcast_to(np.asarray(values, dtype=np.int64), (n,))
    if a.min() < 0 or a.max() > top:
        raise EncodeError(f"RPLIDAR capsule {what} must be in 0..{top}")
    return np.ascontiguousarray(a)


def encode_capsule(
    start_angle_q6: int, start: bool, distance_mm: npt.ArrayLike, dtheta_q3: npt.ArrayLike = 0
) -> bytes:
    """A legacy express capsule (84 bytes, answer type 0x82).

    Cabin ``j`` carries samples ``2j`` and ``2j + 1``: two u16 words ``distance_mm << 2 |
    dtheta bits 4-5`` and a byte ``dtheta_2j bits 0-3 | dtheta_2j+1 bits 0-3 << 4``. A
    decoder places sample ``k`` at ``start + k (next_start - start) / 32 - dtheta_k / 8``
    [deg].

    Parameters
    ----------
    start_angle_q6 : int
        Angle of sample 0 before its correction [deg] * 64.
    start : bool
        S: the first capsule of the stream.
    distance_mm : array_like of int
        32 distances [mm], 0..16383 (0: no return).
    dtheta_q3 : array_like of int
        32 angle corrections [deg] * 8, 0..63 (broadcast).

    Raises
    ------
    EncodeError
        A value out of its field.
    """
    n = CAPSULED.samples
    d = _samples(distance_mm, n, CAPSULE_DISTANCE_MM_MAX, "distance_mm")
    t = _samples(dtheta_q3, n, CAPSULE_DTHETA_Q3_MAX, "dtheta_q3")
    w1 = (d[0::2] << 2) | (t[0::2] >> 4)
    w2 = (d[1::2] << 2) | (t[1::2] >> 4)
    cabins = np.empty((n // 2, 5), dtype=np.uint8)
    cabins[:, 0], cabins[:, 1] = w1 & 0xFF, w1 >> 8
    cabins[:, 2], cabins[:, 3] = w2 & 0xFF, w2 >> 8
    cabins[:, 4] = (t[0::2] & 0xF) | ((t[1::2] & 0xF) << 4)
    return _pack_capsule(start_angle_q6, start, cabins.tobytes())


# the variable bit scale of ultra capsules' 12-bit major distances:
# (first code, distance [mm] of that code, log2 of the step [mm]), from the far end down
_VBS_LEVELS = ((3328, 1 << 14, 4), (1792, 1 << 12, 3), (1280, 1 << 11, 2), (512, 1 << 9, 1))
VBS_CODE_MAX = 0xFFF
PREDICT_NONE = 0x1FF
"""A 10-bit prediction meaning "no return" (0x200, i.e. -512, means the same)."""
PREDICT_MIN, PREDICT_MAX = -511, 510  # the predictions that carry a distance


def varbitscale_decode(code: npt.ArrayLike) -> tuple[I64Array, I64Array]:
    """Distances [mm] and scale levels of 12-bit variable-bit-scale codes.

    Codes 0-511 are millimetres; above, each range of codes steps 2, 4, 8, 16 mm from 512,
    2048, 4096 and 16384 mm (codes 512, 1280, 1792, 3328): the largest, 4095, is 28656 mm.
    """
    c = np.asarray(code, dtype=np.int64)
    if c.size and 0 <= c.min() and c.max() <= VBS_CODE_MAX:  # a 12-bit code: the tables
        return _VBS_DISTANCE_MM[c], _VBS_LEVEL[c]
    return _varbitscale_levels(c)


def _varbitscale_levels(c: I64Array) -> tuple[I64Array, I64Array]:
    """:func:`varbitscale_decode` level by level (any integers; the tables are made with it)."""
    distance = c.copy()
    level = np.zeros_like(c)
    done = np.zeros(c.shape, dtype=bool)
    for first, base_mm, lvl in _VBS_LEVELS:
        here = ~done & (c >= first)
        distance[here] = base_mm + ((c[here] - first) << lvl)
        level[here] = lvl
        done |= here
    return distance, level


# every 12-bit code's distance [mm] and level, looked up instead of computed per capsule
_VBS_DISTANCE_MM, _VBS_LEVEL = _varbitscale_levels(np.arange(VBS_CODE_MAX + 1, dtype=np.int64))


def varbitscale_encode(distance_mm: npt.ArrayLike) -> I64Array:
    """The 12-bit variable-bit-scale codes nearest to distances [mm] (beyond 28656 mm: 4095)."""
    d = np.asarray(distance_mm, dtype=np.int64)
    code = d.copy()
    done = np.zeros(d.shape, dtype=bool)
    for first, base_mm, lvl in _VBS_LEVELS:
        here = ~done & (d >= base_mm)
        code[here] = first + ((d[here] - base_mm + (1 << (lvl - 1))) >> lvl)
        done |= here
    out: I64Array = np.clip(code, 0, VBS_CODE_MAX)
    return out


def _predict(target_mm: I64Array, base_mm: I64Array, level: I64Array) -> tuple[I64Array, I64Array]:
    """10-bit predictions of ``target`` from ``base`` in steps of ``2**level`` mm, and the
    distances a decoder gets back (0 where the target is no return or out of reach)."""
    step = np.left_shift(1, level)
    p = np.floor_divide(target_mm - base_mm + (step >> 1), step)
    ok = (target_mm > 0) & (p >= PREDICT_MIN) & (p <= PREDICT_MAX)
    return np.where(ok, p, PREDICT_NONE), np.where(ok, base_mm + p * step, 0)


def encode_ultra_cabins(distance_mm: npt.ArrayLike) -> tuple[npt.NDArray[np.uint32], I64Array]:
    """The 32 cabins of an ultra capsule, and the 96 distances a decoder gets back.

    Cabin ``j`` carries samples ``3j .. 3j + 2`` in a u32: bits 0-11 the major, sample ``3j``
    as a variable-bit-scale code (:func:`varbitscale_decode`); bits 12-21 and 22-31 signed
    predictions ``p`` of samples ``3j + 1`` and ``3j + 2``, which decode as ``base + p <<
    level``, the base being the major of cabin ``j`` (of cabin ``j + 1`` if cabin ``j``'s is 0
    and the next one's is not) for the first and the major of cabin ``j + 1`` for the second,
    each with its scale level. The last cabin's second prediction uses the next capsule's
    first major, hence the 97th distance. A sample the prediction cannot reach (a jump past
    511 steps) decodes as no return, as does one with no return.

    Parameters
    ----------
    distance_mm : array_like of int, shape (..., 97)
        97 distances [mm]: this capsule's 96 samples, then the next capsule's first; any
        number of capsules at once along the leading axes (each encoded alone).

    Returns
    -------
    words : ndarray of uint32, shape (..., 32)
        The 32 cabins.
    decoded_mm : ndarray of int64, shape (..., 96)
        The 96 distances [mm] they decode to (quantised; 0 for no return).
    """
    n = ULTRA_CAPSULED.samples
    d = np.asarray(distance_mm, dtype=np.int64)
    if d.ndim < 1 or d.shape[-1] != n + 1:
        raise ValueError(f"an ultra capsule needs {n + 1} distances, got shape {d.shape}")
    if d.size and d.min() < 0:
        raise EncodeError("RPLIDAR capsule distance_mm must be >= 0")
    codes = varbitscale_encode(d[..., 0::3])  # 33 majors: this capsule's 32 and the next one's
    major_mm, level = varbitscale_decode(codes)
    this_mm, this_lvl = major_mm[..., :-1], level[..., :-1]
    next_mm, next_lvl = major_mm[..., 1:], level[..., 1:]
    borrow = (this_mm == 0) & (next_mm != 0)
    p1, got1 = _predict(
        d[..., 1:n:3], np.where(borrow, next_mm, this_mm), np.where(borrow, next_lvl, this_lvl)
    )
    p2, got2 = _predict(d[..., 2:n:3], next_mm, next_lvl)
    words = codes[..., :-1] | ((p1 & 0x3FF) << 12) | ((p2 & 0x3FF) << 22)
    decoded: I64Array = np.stack((this_mm, got1, got2), axis=-1).reshape(*d.shape[:-1], n)
    return words.astype(np.uint32), decoded


def encode_ultra_capsule(start_angle_q6: int, start: bool, distance_mm: npt.ArrayLike) -> bytes:
    """An ultra capsule (132 bytes, answer type 0x84) from 97 distances [mm]: this capsule's 96
    and the next one's first (:func:`encode_ultra_cabins`).

    Raises
    ------
    EncodeError
        A start angle out of 15 bits or a negative distance.
    """
    words, _ = encode_ultra_cabins(distance_mm)
    return ultra_capsule_of_cabins(start_angle_q6, start, words)


def ultra_capsule_of_cabins(
    start_angle_q6: int, start: bool, words: npt.NDArray[np.uint32]
) -> bytes:
    """An ultra capsule (132 bytes) from its 32 cabins (:func:`encode_ultra_cabins`'s words:
    a revolution's capsules encoded at once, each packed with its own start angle).

    Raises
    ------
    EncodeError
        A start angle out of 15 bits.
    """
    if np.shape(words) != (ULTRA_CAPSULED.samples // 3,):
        raise ValueError(f"an ultra capsule has 32 cabins, got shape {np.shape(words)}")
    return _pack_capsule(start_angle_q6, start, np.asarray(words).astype("<u4").tobytes())


def encode_dense_capsule(start_angle_q6: int, start: bool, distance_mm: npt.ArrayLike) -> bytes:
    """A dense capsule (84 bytes, answer type 0x85): 40 distances [mm] u16 LE, no corrections.

    Raises
    ------
    EncodeError
        A value out of its field.
    """
    d = _samples(distance_mm, DENSE_CAPSULED.samples, 0xFFFF, "distance_mm")
    return _pack_capsule(start_angle_q6, start, d.astype("<u2").tobytes())


ULTRA_OFFSET_NEAR_RAD_Q16 = 8578  # 7.5 deg [rad] * 2**16, below 50 mm
ULTRA_OFFSET_FAR_RAD_Q16 = 9150  # 8 deg [rad] * 2**16
ULTRA_OFFSET_NEAR_Q2 = 200  # 50 mm * 4
ULTRA_OFFSET_K1 = 98361
ULTRA_OFFSET_K3 = 98304
ULTRA_OFFSET_PI = 3.14159265  # the pi of the radian-to-degree conversion (bit-exact decoding)


def ultra_angle_offset_q16(distance_q2: npt.ArrayLike) -> I64Array:
    """The angle a decoder subtracts from an ultra-capsuled sample [deg * 2**16].

    Ultra capsules carry no per-sample correction: the decoder models the parallax of the
    A-series' triangulating head from the distance alone, as Slamtec's SDK (and pyrplidar)
    do: with ``k = 98361 // distance_q2``, ``8 deg - (k << 6) - k**3 // 98304`` [rad * 2**16]
    from 50 mm on and 7.5 deg below, turned into degrees with pi = 3.14159265 and truncated.
    About 7.3 deg at 2 m, 7.9 deg at 12 m.
    """
    q = np.asarray(distance_q2, dtype=np.int64)
    k = ULTRA_OFFSET_K1 // np.maximum(q, 1)
    rad_q16 = np.where(
        q >= ULTRA_OFFSET_NEAR_Q2,
        ULTRA_OFFSET_FAR_RAD_Q16 - (k << 6) - (k * k * k) // ULTRA_OFFSET_K3,
        ULTRA_OFFSET_NEAR_RAD_Q16,
    )
    out: I64Array = (rad_q16 * 180 / ULTRA_OFFSET_PI).astype(np.int64)  # toward zero, as C's
    return out


@dataclass(frozen=True)
class SampleBatch:
    """Samples decoded from capsules, as Slamtec's SDK hands them out (its HQ nodes).

    Attributes
    ----------
    start : ndarray of bool
        The SDK's sync flag, on the last sample before the raw angle passes 0 deg: the SDK
        starts a new turn with it, so a turn runs from one flagged sample to the next.
    angle_q6 : ndarray of int64
        Headings [deg] * 64, clockwise, in [0, 23040).
    distance_q2 : ndarray of int64
        Distances [mm] * 4; 0 is no return.
    """

    start: BoolArray
    angle_q6: I64Array
    distance_q2: I64Array

    def __len__(self) -> int:
        return len(self.start)

    @property
    def angle_deg(self) -> npt.NDArray[np.float64]:
        out: npt.NDArray[np.float64] = self.angle_q6 / 64.0
        return out

    @property
    def distance_mm(self) -> npt.NDArray[np.float64]:
        out: npt.NDArray[np.float64] = self.distance_q2 / 4.0
        return out

    @staticmethod
    def concat(batches: list[SampleBatch]) -> SampleBatch:
        """The batches back to back (an empty batch for none)."""
        if not batches:
            return SampleBatch(
                np.zeros(0, dtype=np.bool_), np.zeros(0, np.int64), np.zeros(0, np.int64)
            )
        return SampleBatch(
            np.concatenate([b.start for b in batches]),
            np.concatenate([b.angle_q6 for b in batches]),
            np.concatenate([b.distance_q2 for b in batches]),
        )


def _signed10(x: I64Array) -> I64Array:
    out: I64Array = np.where(x >= 0x200, x - 0x400, x)
    return out


class CapsuleDecoder:
    """The host's side of an EXPRESS_SCAN stream (the bytes after its descriptor).

    A capsule is recognised by its sync nibbles and checksum; bytes that start none are skipped
    one at a time and counted. Each capsule becomes samples when the next arrives, reconstructed
    with Slamtec's SDK's fixed-point arithmetic (so both agree to the bit): sample ``k`` of
    ``N`` at raw angle ``start + k * diff / N`` (``diff`` the start angles' difference, wrapped
    into [0, 360) deg, in Q16 with the SDK's truncations), less ``dtheta`` (legacy capsules) or
    :func:`ultra_angle_offset_q16` (ultra capsules); dense capsules carry no correction. A
    capsule with the S bit drops the one held (a new stream).

    Parameters
    ----------
    answer_type : int
        The descriptor's data type: 0x82, 0x84 or 0x85.

    Attributes
    ----------
    capsules : int
        Capsules received whole (checksum good).
    starts : int
        Capsules with the S bit.
    malformed_bytes : int
        Bytes skipped.
    """

    def __init__(self, answer_type: int) -> None:
        if answer_type not in CAPSULE_FORMATS:
            raise ValueError(f"no capsule format has answer type {answer_type:#04x}")
        self.format = CAPSULE_FORMATS[answer_type]
        self._buf = bytearray()
        self._held: bytes | None = None
        self._last_sync = False  # dense capsules: a sync flag is raised once per turn
        self.capsules = 0
        self.starts = 0
        self.malformed_bytes = 0

    def feed(self, data: bytes) -> SampleBatch:
        """Decode what ``data`` completes; a partial capsule waits for the next chunk.

        Returns
        -------
        SampleBatch
            The samples of every capsule that the next one completed, in stream order.
        """
        buf = self._buf
        buf += data
        if native.LIB is not None and buf:
            return self._feed_compiled()
        n = self.format.capsule_bytes
        pairs: list[tuple[bytes, bytes]] = []  # (capsule, the one that completes it)
        pos, end = self._whole_capsules(pairs), len(buf)
        while pos < end:
            if buf[pos] >> 4 != CAPSULE_SYNC_1 or (
                end - pos > 1 and buf[pos + 1] >> 4 != CAPSULE_SYNC_2
            ):
                self.malformed_bytes += 1
                pos += 1
                continue
            if end - pos < n:
                break
            capsule = bytes(buf[pos : pos + n])
            if _xor(capsule[2:]) != (capsule[0] & 0xF) | ((capsule[1] & 0xF) << 4):
                self.malformed_bytes += 1
                pos += 1
                continue
            pos += n
            self._take(capsule, pairs)
        del buf[:pos]
        return self._decode(pairs) if pairs else SampleBatch.concat([])

    def _feed_compiled(self) -> SampleBatch:
        """:meth:`feed` past appending the chunk, in one compiled call
        (:func:`jackson.protocol.native.capsules_feed`): the same samples, counts and
        held capsule."""
        fmt = self.format
        fed = native.capsules_feed(
            fmt.answer_type, fmt.capsule_bytes, fmt.samples, bytes(self._buf), self._held,
            self._last_sync,
        )  # fmt: skip
        del self._buf[: fed.consumed]
        self.capsules += fed.capsules
        self.starts += fed.starts
        self.malformed_bytes += fed.malformed
        self._held = fed.held
        self._last_sync = fed.last_sync
        return SampleBatch(fed.start, fed.angle_q6, fed.distance_q2)

    def _whole_capsules(self, pairs: list[tuple[bytes, bytes]]) -> int:
        """The capsules at the head of the buffer whose sync nibbles and checksums are good,
        checked all at once and taken as :meth:`feed`'s loop takes them one by one (a stream
        without garbage is nothing else); the bytes they fill (where the loop goes on)."""
        buf = self._buf
        n = self.format.capsule_bytes
        k = len(buf) // n
        if k == 0:
            return 0
        rows = np.frombuffer(buf, dtype=np.uint8, count=k * n).reshape(k, n)
        good = (
            ((rows[:, 0] >> 4) == CAPSULE_SYNC_1)
            & ((rows[:, 1] >> 4) == CAPSULE_SYNC_2)
            & (
                np.bitwise_xor.reduce(rows[:, 2:], axis=1)
                == (rows[:, 0] & 0xF) | ((rows[:, 1] & 0xF) << 4)
            )
        )
        taken = k if good.all() else int(np.argmin(good))
        del rows  # the buffer is resized below: no view of it may remain
        for i in range(taken):
            self._take(bytes(buf[i * n : (i + 1) * n]), pairs)
        return taken * n

    def _take(self, capsule: bytes, pairs: list[tuple[bytes, bytes]]) -> None:
        """A whole capsule: counted, a start dropping the one held, else completing it."""
        self.capsules += 1
        if _U16.unpack_from(capsule, 2)[0] & CAPSULE_START_BIT:
            self.starts += 1
            self._held = None
        if self._held is not None:
            pairs.append((self._held, capsule))
        self._held = capsule

    def _decode(self, pairs: list[tuple[bytes, bytes]]) -> SampleBatch:
        """The samples of capsules, each with the capsule that followed it: all at once, one
        array per field and a row per capsule (a turn's capsules cost about what one does)."""
        fmt = self.format
        c = len(pairs)
        held = np.frombuffer(b"".join(h for h, _ in pairs), dtype=np.uint8).reshape(c, -1)
        follow = np.frombuffer(b"".join(f for _, f in pairs), dtype=np.uint8).reshape(c, -1)
        wide = held.astype(np.int64)
        first_q8 = ((wide[:, 2] | (wide[:, 3] << 8)) & ANGLE_Q6_MAX) << 2
        next_q8 = ((follow[:, 2].astype(np.int64) | (follow[:, 3].astype(np.int64) << 8))
                   & ANGLE_Q6_MAX) << 2  # fmt: skip
        diff_q8 = next_q8 - first_q8 + np.where(first_q8 > next_q8, 360 << 8, 0)
        if fmt is CAPSULED:
            inc_q16 = diff_q8 << 3
        elif fmt is ULTRA_CAPSULED:
            inc_q16 = (diff_q8 << 3) // 3
        else:
            inc_q16 = (diff_q8 << 8) // 40
        raw_q16 = (first_q8 << 8)[:, None] + np.arange(fmt.samples, dtype=np.int64) * inc_q16[
            :, None
        ]
        dist_q2: I64Array
        angle_q6: I64Array
        body = wide[:, CAPSULE_HEADER_BYTES:]
        if fmt is CAPSULED:
            cab = body.reshape(c, -1, 5)
            w1 = cab[:, :, 0] | (cab[:, :, 1] << 8)
            w2 = cab[:, :, 2] | (cab[:, :, 3] << 8)
            dist_q2 = np.stack((w1 & 0xFFFC, w2 & 0xFFFC), axis=2).reshape(c, -1)
            dtheta_q3 = np.stack(
                ((cab[:, :, 4] & 0xF) | ((w1 & 3) << 4), (cab[:, :, 4] >> 4) | ((w2 & 3) << 4)),
                axis=2,
            ).reshape(c, -1)
            angle_q6 = (raw_q16 - (dtheta_q3 << 13)) >> 10
        elif fmt is ULTRA_CAPSULED:
            words = (
                np.ascontiguousarray(held[:, CAPSULE_HEADER_BYTES:]).view("<u4").astype(np.int64)
            )
            next_word = np.ascontiguousarray(
                follow[:, CAPSULE_HEADER_BYTES : CAPSULE_HEADER_BYTES + 4]
            ).view("<u4")
            codes = np.concatenate((words & 0xFFF, next_word.astype(np.int64) & 0xFFF), axis=1)
            major_mm, level = varbitscale_decode(codes)
            this_mm, this_lvl = major_mm[:, :-1], level[:, :-1]
            next_mm, next_lvl = major_mm[:, 1:], level[:, 1:]
            borrow = (this_mm == 0) & (next_mm != 0)
            base1 = np.where(borrow, next_mm, this_mm)
            lvl1 = np.where(borrow, next_lvl, this_lvl)
            p1, p2 = _signed10((words >> 12) & 0x3FF), _signed10((words >> 22) & 0x3FF)
            none1 = (p1 == -512) | (p1 == PREDICT_NONE)
            none2 = (p2 == -512) | (p2 == PREDICT_NONE)
            d1 = np.where(none1, 0, (p1 << lvl1) + base1)
            d2 = np.where(none2, 0, (p2 << next_lvl) + next_mm)
            dist_q2 = np.stack((this_mm, d1, d2), axis=2).reshape(c, -1) << 2
            angle_q6 = (raw_q16 - ultra_angle_offset_q16(dist_q2)) >> 10
        else:
            dist_q2 = (
                np.ascontiguousarray(held[:, CAPSULE_HEADER_BYTES:]).view("<u2").astype(np.int64)
                << 2
            )
            angle_q6 = raw_q16 >> 10
        if fmt is DENSE_CAPSULED:  # a sync flag is raised once per turn, along the stream
            wrapped = (raw_q16 + inc_q16[:, None]) % ANGLE_Q16_TURN
            sync = np.zeros(wrapped.shape, dtype=bool)
            flat = sync.reshape(-1)
            for k, near in enumerate((wrapped < 2 * inc_q16[:, None]).ravel().tolist()):
                flat[k] = near and not self._last_sync
                self._last_sync = bool(flat[k])
        else:
            # the SDK's test, (raw + inc) mod 360 deg < inc, but with the next capsule's own
            # start angle after a capsule's last sample: inc is truncated, so a capsule that
            # starts at exactly 0 deg left its turn unflagged and two turns merged
            nxt = raw_q16 + inc_q16[:, None]
            nxt[:, -1] = (first_q8 + diff_q8) << 8
            sync = (raw_q16 < ANGLE_Q16_TURN) & (nxt >= ANGLE_Q16_TURN)
        angle_q6 = np.where(angle_q6 < 0, angle_q6 + ANGLE_Q6_TURN, angle_q6)
        angle_q6 = np.where(angle_q6 >= ANGLE_Q6_TURN, angle_q6 - ANGLE_Q6_TURN, angle_q6)
        return SampleBatch(sync.ravel(), angle_q6.ravel(), dist_q2.ravel())
