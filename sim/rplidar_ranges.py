"""Where the twin's RPLIDAR reads a revolution's ranges: at any heading between its beams
(:func:`ranges_at`), and for an ultra sample where a decoder will place it, its raw angle less
the parallax offset of the distance it reads (:func:`parallax_ranged`, docs/lidar.md).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view

from jackson.protocol import native as protocol_native
from jackson.protocol.rplidar import (
    ultra_angle_offset_q16,
    varbitscale_decode,
    varbitscale_encode,
)
from jackson.sim.lidar import LidarSpec

F64Array = npt.NDArray[np.float64]
I64Array = npt.NDArray[np.int64]

EDGE_FRACTION = 0.1
"""Two neighbouring beams that differ by more than this fraction of the nearer one are an edge:
a sample between them takes the nearer beam's range instead of interpolating."""
PARALLAX_ITERATIONS = 3
ULTRA_OFFSET_START_DEG = 7.5  # the parallax model's offset below 50 mm: where iterating starts
ULTRA_OFFSET_MIN_DEG = -20.6  # below the model's smallest offset (-20.53 deg at 50 mm)
ULTRA_OFFSET_MAX_DEG = 8.0  # its largest (7.9995 deg, far away)


def ranges_at(spec: LidarSpec, ranges_m: F64Array, heading_deg: F64Array) -> F64Array:
    """A revolution's ranges [m] at clockwise headings [deg], from its beams.

    Each heading falls between two beams (the last and the first bridge the gap of an
    incomplete turn); the range is linear between theirs unless they differ by more than
    :data:`EDGE_FRACTION` of the nearer or one has no return, and then it is the nearer beam's
    (an edge stays an edge, a no return stays one).

    Parameters
    ----------
    spec : LidarSpec
        The beams' geometry.
    ranges_m : ndarray
        The revolution's ``spec.beams`` ranges [m] in beam order; ``inf``, NaN or <= 0 for no
        return.
    heading_deg : ndarray
        Headings [deg], clockwise seen from above, any value (wrapped).

    Returns
    -------
    ndarray
        Ranges [m], ``inf`` for no return.
    """
    beams, inc = spec.beams, spec.angle_increment_rad
    r = np.where(np.isfinite(ranges_m) & (ranges_m > 0.0), ranges_m, np.inf)
    alpha, i0 = _beam_position(spec, heading_deg)
    gap = max(2.0 * math.pi - (beams - 1) * inc, inc)  # last beam to the first, one turn on
    width = np.where(i0 == beams - 1, gap, inc)
    f = np.clip((alpha - i0 * inc) / width, 0.0, 1.0)
    r0, r1 = r[i0], r[(i0 + 1) % beams]
    with np.errstate(invalid="ignore"):
        smooth = np.isfinite(r0) & np.isfinite(r1)
        smooth &= np.abs(r1 - r0) <= EDGE_FRACTION * np.minimum(r0, r1)
        lin = r0 + f * (r1 - r0)
    out: F64Array = np.where(smooth, lin, np.where(f < 0.5, r0, r1))
    return out


def _beam_position(spec: LidarSpec, heading_deg: F64Array) -> tuple[F64Array, I64Array]:
    """Where each clockwise heading [deg] falls among the beams: its counter-clockwise angle
    from the first beam in [0, 2 pi) [rad], and the beam at or before it."""
    alpha: F64Array = np.mod(-np.radians(heading_deg) - spec.angle_min_rad, 2.0 * math.pi)
    i0: I64Array = np.minimum(
        np.floor(alpha / spec.angle_increment_rad).astype(np.int64), spec.beams - 1
    )
    return alpha, i0


def _decoded_heading(raw_deg: F64Array, mm: I64Array) -> F64Array:
    """The heading [deg] a decoder gives a sample of raw angle ``raw_deg`` sent with the
    distance ``mm`` [mm]: the raw angle less the parallax offset of the distance as the
    variable bit scale quantises it."""
    decoded_mm, _ = varbitscale_decode(varbitscale_encode(mm))
    out: F64Array = raw_deg - ultra_angle_offset_q16(4 * decoded_mm) / 65536.0
    return out


def _window_beams(spec: LidarSpec) -> int:
    """How many beams, from the one at heading ``raw - ULTRA_OFFSET_MIN_DEG`` on, hold every
    heading a raw angle's laser line can cross (the parallax model's offsets)."""
    span = math.radians(ULTRA_OFFSET_MAX_DEG - ULTRA_OFFSET_MIN_DEG)
    return math.ceil(span / spec.angle_increment_rad) + 2


def millimetres(ranges_m: F64Array, top: int) -> I64Array:
    """Ranges [m] as whole millimetres for the wire, 0 for no return."""
    ok = np.isfinite(ranges_m) & (ranges_m > 0.0)
    mm = np.zeros(len(ranges_m), dtype=np.int64)
    mm[ok] = np.clip(np.rint(ranges_m[ok] * 1000.0), 1, top)
    return mm


def parallax_ranged(spec: LidarSpec, ranges_m: F64Array, raw_deg: F64Array) -> tuple[I64Array, int]:
    """Distances [mm] of ultra samples, each ranged where a decoder will place it: its raw
    angle less the parallax model's offset for the distance it will decode (quantised
    as the variable bit scale quantises it), found by iterating.

    The laser's line at one raw angle passes different headings at different distances,
    and it returns the nearest obstacle on it. Next to an edge two distances can fit (the
    near side's offset is the smaller): the search runs twice, from the far field's offset
    and from the offset of the nearest beam the line can cross, and the nearer distance
    that fits wins (searching only from the far field would read the wall behind an edge
    and leave the last few degrees of the near object unseen, where a robot passing it
    can touch it). A raw angle that fits neither side's offset has no such distance: that
    sample is sent as no return.

    Returns
    -------
    tuple
        (the distances [mm], 0 for no return; how many samples with a return from the far
        field's search went out as none: the emulator's ``edge_dropouts``).
    """
    if protocol_native.LIB is not None:  # the same distances, compiled
        ranged, dropouts = protocol_native.ultra_ranged(
            (spec.beams, spec.angle_increment_rad, spec.angle_min_rad, EDGE_FRACTION),
            ranges_m, raw_deg, PARALLAX_ITERATIONS, ULTRA_OFFSET_START_DEG,
            (-ULTRA_OFFSET_MIN_DEG, _window_beams(spec)),
        )  # fmt: skip
        return ranged, dropouts
    far_start = raw_deg - ULTRA_OFFSET_START_DEG
    far_mm, far_fits = _parallax_search(spec, ranges_m, raw_deg, far_start)
    far = np.where(far_fits, far_mm, 0)
    # the nearest beam the line can cross: headings from raw - 8 deg to raw + 20.6 deg
    r = np.where(np.isfinite(ranges_m) & (ranges_m > 0.0), ranges_m, np.inf)
    w = _window_beams(spec)
    nearest_from = sliding_window_view(np.concatenate((r, r[np.arange(w - 1) % spec.beams])), w)
    _, first = _beam_position(spec, raw_deg + -ULTRA_OFFSET_MIN_DEG)
    nearest_mm = millimetres(nearest_from.min(axis=1)[first], 0xFFFF)
    ask = np.flatnonzero((far == 0) | (nearest_mm < far))  # else nothing crossed is nearer
    near_start = _decoded_heading(raw_deg[ask], nearest_mm[ask])
    near_mm, near_fits = _parallax_search(spec, ranges_m, raw_deg[ask], near_start)
    near = near_fits & (near_mm > 0) & ((far[ask] == 0) | (near_mm < far[ask]))
    out: I64Array = far.copy()
    out[ask[near]] = near_mm[near]
    return out, int(np.count_nonzero((out == 0) & ~far_fits & (far_mm > 0)))


def _parallax_search(
    spec: LidarSpec, ranges_m: F64Array, raw_deg: F64Array, heading: F64Array
) -> tuple[I64Array, npt.NDArray[np.bool_]]:
    """The search of :func:`parallax_ranged` from ``heading`` [deg]: (distances [mm],
    whether each fits the range at the heading it decodes to)."""
    mm: I64Array = np.zeros(len(raw_deg), np.int64)
    for _ in range(PARALLAX_ITERATIONS):
        mm = millimetres(ranges_at(spec, ranges_m, heading), 0xFFFF)
        heading = _decoded_heading(raw_deg, mm)
    there = millimetres(ranges_at(spec, ranges_m, heading), 0xFFFF)
    fits = np.abs(there - mm) <= EDGE_FRACTION * np.minimum(there, mm)
    return mm, fits
