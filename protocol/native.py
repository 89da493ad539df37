"""EXPRESS_SCAN capsule decoding compiled (``protocol/native/capsules.cpp``), used when
current.

:class:`~jackson.protocol.rplidar.CapsuleDecoder` turns the capsules of an RPLIDAR's stream
into samples with numpy, some forty array operations per chunk, which a navigating daemon
paid on every revolution. ``make setup`` compiles the same walk over the bytes and the same
fixed-point arithmetic (Slamtec's SDK's) with the system's C++ compiler
(``tools/build_compiled.py``, ``-ffp-contract=off``) into
``build/compiled-protocol/<digest>/libjackson_protocol.so``, named by the digest of the source,
and this module loads it with :mod:`ctypes` only while the source still has that digest. The
samples, counts and held capsule are the interpreted decoder's bit for bit
(``tests/protocol/test_rplidar_native.py``). Without a build, or with
``JACKSON_PROTOCOL_INTERPRETED=1``, the decoder uses numpy.

``python -m jackson.protocol.native`` prints which one is in use.

Attributes
----------
LIB : ctypes.CDLL or None
    The loaded library (None: numpy).
REASON : str
    Why, one line.
"""

from __future__ import annotations

import ctypes
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from jackson.common import native_lib

ENV_INTERPRETED = "JACKSON_PROTOCOL_INTERPRETED"
LIBRARY = "libjackson_protocol.so"

_P = ctypes.c_void_p  # an array's address (jackson.common.native_lib.pointer, address)
_N = ctypes.c_int64
_D = ctypes.c_double
pointer, address = native_lib.pointer, native_lib.address


def source_path() -> Path:
    """``protocol/native/capsules.cpp`` of this checkout (links resolved)."""
    return Path(__file__).resolve().parent / "native" / "capsules.cpp"


def source_digest(source: bytes) -> str:
    """A build's name (:func:`jackson.common.native_lib.source_digest`)."""
    return native_lib.source_digest(source)


def builds_dir(source: Path) -> Path:
    """``build/compiled-protocol`` of the checkout that holds ``source``."""
    return source.parents[2] / "build" / "compiled-protocol"


def build_path(builds: Path, digest: str) -> Path:
    """``<builds>/<digest>/libjackson_protocol.so``."""
    return builds / digest / LIBRARY


def load_library(path: Path) -> ctypes.CDLL:
    """Load a build and declare its functions' arguments.

    Raises
    ------
    OSError
        It does not load or lacks a function.
    """
    lib = ctypes.CDLL(str(path))
    try:
        feed = lib.jackson_capsules_feed
        turn = lib.jackson_rplidar_turn
        ranged = lib.jackson_ultra_ranged
        ultra = lib.jackson_ultra_capsules
    except AttributeError as e:
        raise OSError(f"{path}: {e}") from e
    feed.restype = _N
    feed.argtypes = [_N, _N, _N, ctypes.c_char_p, _N, ctypes.c_char_p, _P, _P, _P, _P, _P]
    turn.restype = None
    turn.argtypes = [_N, _P, _P, _D, _D, _D, _D, _P, _P, _P]
    ranged.restype = _N
    ranged.argtypes = [_N, _D, _D, _D, _P, _N, _P, _N, _D, _D, _N, _P]
    ultra.restype = _N
    ultra.argtypes = [_N, _P, _P, ctypes.c_uint8, _P]
    return lib


LIB, REASON = native_lib.select(
    source_path(),
    lambda digest: build_path(builds_dir(source_path()), digest),
    load_library,
    ENV_INTERPRETED,
)


class Fed(NamedTuple):
    """What one :func:`capsules_feed` call did.

    Attributes
    ----------
    consumed : int
        Bytes of the buffer used up (the rest waits for the next chunk).
    capsules, starts, malformed : int
        Capsules taken, of them with the S bit, and bytes skipped.
    held : bytes or None
        The capsule held now.
    last_sync : bool
        The dense format's last sync flag.
    start : ndarray of bool
    angle_q6, distance_q2 : ndarray of int64
        The samples, as :class:`~jackson.protocol.rplidar.SampleBatch` holds them.
    """

    consumed: int
    capsules: int
    starts: int
    malformed: int
    held: bytes | None
    last_sync: bool
    start: npt.NDArray[np.bool_]
    angle_q6: npt.NDArray[np.int64]
    distance_q2: npt.NDArray[np.int64]


def capsules_feed(
    answer_type: int,
    capsule_bytes: int,
    samples: int,
    buf: bytes,
    held: bytes | None,
    last_sync: bool,
) -> Fed:
    """:meth:`CapsuleDecoder.feed`'s walk over ``buf`` and its decoding, compiled.

    Parameters
    ----------
    answer_type : int
        The capsule format's answer type (0x82, 0x84 or 0x85).
    capsule_bytes, samples : int
        The format's capsule size and samples per capsule.
    buf : bytes
        The bytes not yet used: what was left over, then the new chunk.
    held : bytes or None
        The capsule held from before (``capsule_bytes`` long), waiting for the next.
    last_sync : bool
        The dense format's last sync flag.

    Returns
    -------
    Fed
        The counts, the state to keep, and the samples.
    """
    assert LIB is not None
    if held is not None and len(held) != capsule_bytes:
        raise ValueError(f"a held capsule of {len(held)} bytes, not {capsule_bytes}")
    room = max(len(buf) // capsule_bytes, 1) * samples
    start = np.empty(room, np.uint8)
    angle = np.empty(room, np.int64)
    distance = np.empty(room, np.int64)
    state = np.array((held is not None, last_sync), np.uint8)
    counts = np.empty(5, np.int64)
    out = LIB.jackson_capsules_feed(
        answer_type, capsule_bytes, samples, buf, len(buf), held, address(state),
        address(counts), address(start), address(angle), address(distance),
    )  # fmt: skip
    consumed, capsules, starts, malformed, held_at = counts.tolist()
    if held_at >= 0:
        held = buf[held_at : held_at + capsule_bytes]
    return Fed(
        consumed, capsules, starts, malformed, held, bool(state[1]),
        start[:out].view(np.bool_), angle[:out], distance[:out],
    )  # fmt: skip


def rplidar_turn(
    angle_q6: npt.NDArray[np.int64],
    distance_q2: npt.NDArray[np.int64],
    q6_to_rad: float,
    q2_to_m: float,
    cap_m: float,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """A turn's samples as angles counter-clockwise in [-pi, pi) [rad] and ranges [m] (0 or
    beyond ``cap_m``: inf), sorted by angle (stable), compiled: the same numbers as
    :meth:`jackson.host.lidar.rplidar.RevolutionAssembler`'s numpy, bit for bit.

    Parameters
    ----------
    angle_q6, distance_q2 : ndarray of int64
        Headings [deg * 64] clockwise and distances [mm * 4], one per sample.
    q6_to_rad, q2_to_m : float
        The units' factors.
    cap_m : float
        The range cap [m].
    """
    assert LIB is not None
    a = np.ascontiguousarray(angle_q6, np.int64)
    d = np.ascontiguousarray(distance_q2, np.int64)
    n = a.size
    if d.size != n:
        raise ValueError(f"{n} angles but {d.size} distances")
    angles = np.empty(n)
    ranges = np.empty(n)
    if n == 0:
        return angles, ranges
    order = np.empty(n, np.int64)
    LIB.jackson_rplidar_turn(
        n, pointer(a, np.int64), pointer(d, np.int64), q6_to_rad, q2_to_m, cap_m, math.pi,
        address(angles), address(ranges), address(order),
    )  # fmt: skip
    return angles, ranges


def ultra_ranged(
    beams: tuple[int, float, float, float],
    ranges_m: npt.NDArray[np.float64],
    raw_deg: npt.NDArray[np.float64],
    iterations: int,
    start_deg: float,
    window: tuple[float, int],
) -> tuple[npt.NDArray[np.int64], int]:
    """The twin's ultra samples ranged where a decoder will place them
    (:func:`jackson.sim.rplidar_ranges.parallax_ranged`), compiled: the same
    distances bit for bit.

    Parameters
    ----------
    beams : tuple
        (beams, angle increment [rad], first beam's angle [rad], edge fraction).
    ranges_m : ndarray
        The revolution's ranges [m], one per beam.
    raw_deg : ndarray
        The samples' raw angles [deg], clockwise.
    iterations : int
        Steps of the search for each sample's offset (at least 1).
    start_deg : float
        The offset the first search starts from [deg].
    window : tuple
        (shift [deg], beams): the second search starts from the offset of the nearest of
        ``beams`` beams from the one at heading raw + shift on.

    Returns
    -------
    tuple
        (distances [mm], 0 for no return; samples with a return sent as none at an edge).
    """
    assert LIB is not None
    count, inc, angle_min, edge = beams
    r = np.ascontiguousarray(ranges_m, np.float64)
    raw = np.ascontiguousarray(raw_deg, np.float64)
    if r.size != count or count < 1 or iterations < 1:
        raise ValueError(f"{r.size} ranges for {count} beams, {iterations} iterations")
    out = np.empty(raw.size, np.int64)
    if raw.size == 0:
        return out, 0
    dropouts = LIB.jackson_ultra_ranged(
        count, inc, angle_min, edge, pointer(r, np.float64), raw.size,
        pointer(raw, np.float64), iterations, start_deg, window[0], window[1], address(out),
    )  # fmt: skip
    return out, int(dropouts)


def ultra_capsules(
    distance_mm: npt.NDArray[np.int64], start_q6: npt.NDArray[np.int64], start: bool
) -> tuple[bytes, int]:
    """Ultra capsules from their distances, compiled: ``encode_ultra_cabins`` and
    ``ultra_capsule_of_cabins`` of each row, the same bytes.

    Parameters
    ----------
    distance_mm : ndarray of int64, shape (C, 97)
        Each capsule's 96 distances [mm] and the next one's first, >= 0.
    start_q6 : ndarray of int64, shape (C,)
        Each capsule's start angle [deg * 64], 0 to 0x7FFF.
    start : bool
        The first capsule starts a stream (its S bit).

    Returns
    -------
    tuple
        (the capsules' bytes, samples with a distance that decode as no return).
    """
    assert LIB is not None
    d = np.ascontiguousarray(distance_mm, np.int64)
    q6 = np.ascontiguousarray(start_q6, np.int64)
    count = q6.size
    if d.shape != (count, 97) or (count and (d.min() < 0 or q6.min() < 0 or q6.max() > 0x7FFF)):
        raise ValueError(
            f"ultra capsules: distances {d.shape}, start angles {q6.shape} out of range"
        )
    if count == 0:
        return b"", 0
    out = np.empty(count * 132, np.uint8)
    dropouts = LIB.jackson_ultra_capsules(
        count, pointer(d, np.int64), pointer(q6, np.int64), int(start), address(out)
    )
    return out.tobytes(), int(dropouts)


def main() -> None:
    """``python -m jackson.protocol.native``: print which capsule decoder is in use."""
    print(f"jackson.protocol capsule decoding: {REASON}")


if __name__ == "__main__":
    main()
