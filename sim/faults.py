"""Sensor and link faults of the twin: seeded, bit-reproducible, on a schedule.

A fault is a :class:`FaultSpec`: a kind (:data:`FAULT_KINDS`), an onset ``at_s`` on the twin's
MCU time [s], an optional duration (default: to the end of the run), a wheel for the kinds that
act on one, and the kind's parameters. Robot files list them under ``faults:``
(:func:`jackson.sim.config.load_robot`); the command line gives them as
``KIND@AT_S[+DURATION_S][:key=value,...]`` (:func:`parse_fault`, :func:`format_fault`).

At run time a :class:`FaultInjector` applies them where the fault lives:

- **IMU and encoders** in the sensor values the MCU reads (``Twin.sensors``), so the MCU in
  process and the POSIX firmware process see the same fault: ``imu_dead`` clears the sample's
  ``imu_ok`` (the chip stops answering on the I2C bus), ``imu_stuck`` repeats the registers of
  the last reading before onset, ``imu_spike`` and ``imu_bias_step`` add to the gyro's z rate
  before quantisation, ``encoder_dropout`` holds one wheel's count;
- **wheel slip** in the physics (``DiffDriveRobot.mu_scale``), from the first physics step at or
  after onset to the last one before the end;
- **the link** on the line between the emulated MCU and its pty (``TwinRunner``): a telemetry
  frame is lost or has one bit flipped;
- **the LiDAR** in each scan the twin takes (extra range noise, a revolution lost).

A sensor fault acts on every reading at ``t`` with ``at_s <= t < at_s + duration_s`` (readings
are the telemetry instants, the frames' MCU time); a link fault on every telemetry frame sent in
its window; a LiDAR fault on every scan taken in it.

Randomness: each fault draws from a stream of its own, ``default_rng([seed, FAULT_STREAM, crc32
of its canonical text, n])`` (``n`` counts identical faults before it), so adding, removing or
reordering faults leaves the other faults' draws and the twin's own noise as they were, and a
twin without faults draws exactly what it drew before faults existed.
"""

from __future__ import annotations

import math
import re
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jackson.common.errors import JacksonError
from jackson.sim.mcu import SensorSample

__all__ = [
    "FAULT_KINDS",
    "FaultError",
    "FaultInjector",
    "FaultSpec",
    "fault_window",
    "format_fault",
    "parse_fault",
    "schedule",
    "summary",
]

FAULT_KINDS = (
    "imu_dead",
    "imu_stuck",
    "imu_spike",
    "imu_bias_step",
    "encoder_dropout",
    "wheel_slip",
    "frame_loss",
    "corrupt_bytes",
    "lidar_noise",
    "lidar_dropout",
    "lidar_garbage",
    "lidar_closed",
)
"""Every fault the twin can inject."""

SIDES = ("left", "right")
SIDED_KINDS = frozenset({"encoder_dropout", "wheel_slip"})
"""Kinds that act on one wheel and need ``side``."""
LINK_KINDS = frozenset({"frame_loss", "corrupt_bytes"})
"""Kinds on the line between the MCU and its pty (the emulated MCU only)."""
LIDAR_KINDS = frozenset({"lidar_noise", "lidar_dropout", "lidar_garbage", "lidar_closed"})
LIDAR_LINE_KINDS = frozenset({"lidar_garbage", "lidar_closed"})
"""Kinds on the RPLIDAR's line (its pty) rather than in its scans."""
DEFAULT_DURATION_S = {"wheel_slip": 2.0}  # [s] the others last to the end of the run
FAULT_STREAM = 0x6661_756C  # keys the faults' streams apart from the twin's other streams
TIME_EPS_S = 1e-9  # [s] an instant this close to a window's edge counts as at the edge


@dataclass(frozen=True)
class _Param:
    """A kind's parameter: its default and the closed (or open) interval it must lie in."""

    default: float
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False

    def check(self, value: float) -> bool:
        if not math.isfinite(value):
            return False
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        return self.hi is None or value <= self.hi

    def describe(self) -> str:
        if self.lo is not None and self.hi is not None:
            return f"a number in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"
        if self.lo is not None:
            return f"a number {'>' if self.lo_open else '>='} {self.lo:g}"
        return "a finite number"


PARAMS: dict[str, dict[str, _Param]] = {
    "imu_dead": {},
    "imu_stuck": {},
    "imu_spike": {
        "rate_hz": _Param(0.5, 0.0, lo_open=True),  # Poisson rate of spikes [1/s]
        "magnitude_rad_s": _Param(2.0, 0.0, lo_open=True),  # added to gyro z, random sign
    },
    "imu_bias_step": {"magnitude_rad_s": _Param(0.05)},  # [rad/s] added to gyro z
    "encoder_dropout": {},
    "wheel_slip": {"mu_scale": _Param(0.1, 0.0, 1.0)},  # factor on the floor's mu_s, mu_d
    "frame_loss": {"probability": _Param(0.05, 0.0, 1.0)},  # per telemetry frame
    "corrupt_bytes": {"probability": _Param(0.05, 0.0, 1.0)},  # per telemetry frame
    "lidar_noise": {"sigma_m": _Param(0.05, 0.0)},  # [m] extra Gaussian range noise
    "lidar_dropout": {"probability": _Param(0.3, 0.0, 1.0)},  # per revolution
    # random bytes on the line, this many per revolution's bytes, before each revolution (a
    # loose cable, a wrong baud rate, another device's chatter)
    "lidar_garbage": {"ratio": _Param(1.0, 0.0, 10.0, lo_open=True)},
    "lidar_closed": {},  # the LiDAR's port disappears (its USB cable pulled)
}
"""Each kind's parameters with their defaults and ranges."""


class FaultError(JacksonError, ValueError):
    """A fault that cannot be: unknown kind or key, a bad number, a missing side (one line)."""


def _keys(kind: str) -> list[str]:
    return (["side"] if kind in SIDED_KINDS else []) + list(PARAMS[kind])


def _valid_keys(kind: str) -> str:
    keys = _keys(kind)
    return f"valid keys: {', '.join(keys)}" if keys else f"{kind} takes no keys"


def _kinds() -> str:
    return f"valid kinds: {', '.join(FAULT_KINDS)}"


@dataclass(frozen=True)
class FaultSpec:
    """One fault on the twin's schedule.

    Construction checks it and fills in the kind's defaults, so two specs of the same fault
    compare equal however they were written.

    Attributes
    ----------
    kind : str
        One of :data:`FAULT_KINDS`.
    at_s : float
        Onset on the twin's MCU time (0 at the twin's start; the clock runs from the host's
        HELLO) [s].
    duration_s : float or None
        How long it lasts [s]; None: to the end of the run (``wheel_slip``: 2 s by default).
    side : str or None
        ``left`` or ``right`` for ``encoder_dropout`` and ``wheel_slip``; None for the others.
    params : Mapping[str, float]
        The kind's parameters (:data:`PARAMS`), every one present.

    Raises
    ------
    FaultError
        An unknown kind or key, a number out of range, a missing or needless side.
    """

    kind: str
    at_s: float
    duration_s: float | None = None
    side: str | None = None
    params: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        name = f"fault {self.kind}"
        if self.kind not in PARAMS:
            raise FaultError(f"fault: unknown kind {self.kind!r} ({_kinds()})")
        at = self.at_s
        if isinstance(at, bool) or not isinstance(at, (int, float)) or not 0 <= at < math.inf:
            raise FaultError(f"{name}: at_s: expected a number >= 0, got {self.at_s!r}")
        object.__setattr__(self, "at_s", float(self.at_s))
        duration = self.duration_s
        if duration is None:
            duration = DEFAULT_DURATION_S.get(self.kind)
        elif (
            isinstance(duration, bool)
            or not isinstance(duration, (int, float))
            or not 0 < duration < math.inf
        ):
            raise FaultError(f"{name}: duration_s: expected a number > 0, got {duration!r}")
        object.__setattr__(self, "duration_s", None if duration is None else float(duration))
        if self.kind in SIDED_KINDS:
            if self.side not in SIDES:
                got = "nothing" if self.side is None else repr(self.side)
                raise FaultError(f"{name}: side: expected left or right, got {got}")
        elif self.side is not None:
            raise FaultError(f"{name}: side: unknown key ({_valid_keys(self.kind)})")
        spec = PARAMS[self.kind]
        params: dict[str, float] = {}
        for key, value in self.params.items():
            if key not in spec:
                raise FaultError(f"{name}: {key}: unknown key ({_valid_keys(self.kind)})")
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not ok or not spec[key].check(float(value)):
                raise FaultError(f"{name}: {key}: expected {spec[key].describe()}, got {value!r}")
            params[key] = float(value)
        full = {key: params.get(key, p.default) for key, p in spec.items()}
        object.__setattr__(self, "params", full)

    def __hash__(self) -> int:
        return hash(
            (self.kind, self.at_s, self.duration_s, self.side, tuple(sorted(self.params.items())))
        )

    def param(self, key: str) -> float:
        """The parameter ``key`` (every one of the kind's is present)."""
        return self.params[key]


def fault_window(spec: FaultSpec) -> tuple[float, float]:
    """When a fault acts: ``(start_s, end_s)``, ``end_s`` inf for a fault to the end.

    Parameters
    ----------
    spec : FaultSpec
        The fault.

    Returns
    -------
    tuple of float
        ``(at_s, at_s + duration_s)`` [s]; it acts at ``start_s <= t < end_s``.
    """
    end = math.inf if spec.duration_s is None else spec.at_s + spec.duration_s
    return spec.at_s, end


_NUMBER = r"(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
_SYNTAX = "KIND@AT_S[+DURATION_S][:key=value,key=value]"
_WHEN = re.compile(rf"({_NUMBER})(?:\+({_NUMBER}))?")


def parse_fault(text: str) -> FaultSpec:
    """A fault from its command-line text, ``KIND@AT_S[+DURATION_S][:key=value,...]``.

    Examples: ``imu_bias_step@20:magnitude_rad_s=0.05`` (from 20 s to the end),
    ``encoder_dropout@15+5:side=left`` (15 s to 20 s), ``frame_loss@0:probability=0.05``.

    Parameters
    ----------
    text : str
        The fault.

    Returns
    -------
    FaultSpec
        The fault, with the kind's defaults filled in.

    Raises
    ------
    FaultError
        One line naming the problem and the valid kinds or keys.
    """
    head, colon, tail = text.strip().partition(":")
    kind, at, when = head.partition("@")
    kind = kind.strip()
    if kind not in PARAMS:
        what = f"unknown kind {kind!r}" if kind else "no kind"
        raise FaultError(f"fault {text!r}: {what} ({_kinds()}; syntax {_SYNTAX})")
    m = _WHEN.fullmatch(when.strip())
    if not at or m is None:
        raise FaultError(
            f"fault {text!r}: expected {kind}@AT_S[+DURATION_S] with AT_S >= 0 and "
            f"DURATION_S > 0 in seconds (syntax {_SYNTAX})"
        )
    duration = float(m.group(2)) if m.group(2) is not None else None
    side: str | None = None
    params: dict[str, float] = {}
    if colon:
        for item in tail.split(","):
            key, eq, value = (s.strip() for s in item.partition("="))
            if not eq or not key:
                raise FaultError(
                    f"fault {text!r}: expected key=value after ':', got {item.strip()!r} "
                    f"({_valid_keys(kind)})"
                )
            if key in params or (key == "side" and side is not None):
                raise FaultError(f"fault {text!r}: {key} given twice")
            if key == "side" and kind in SIDED_KINDS:
                side = value
                continue
            if key not in PARAMS[kind]:
                raise FaultError(f"fault {text!r}: unknown key {key!r} ({_valid_keys(kind)})")
            try:
                params[key] = float(value)
            except ValueError:
                raise FaultError(
                    f"fault {text!r}: {key}: expected {PARAMS[kind][key].describe()}, got {value!r}"
                ) from None
    try:
        return FaultSpec(kind, float(m.group(1)), duration, side, params)
    except FaultError as exc:
        raise FaultError(f"fault {text!r}: {str(exc).split(': ', 1)[1]}") from None


def _num(x: float) -> str:
    s = repr(float(x))
    return s[:-2] if s.endswith(".0") else s


def format_fault(spec: FaultSpec) -> str:
    """The command-line text of a fault (:func:`parse_fault` reads it back to an equal spec).

    Parameters
    ----------
    spec : FaultSpec
        The fault.

    Returns
    -------
    str
        ``KIND@AT_S[+DURATION_S][:side=SIDE,key=value,...]`` with every parameter.
    """
    text = f"{spec.kind}@{_num(spec.at_s)}"
    if spec.duration_s is not None:
        text += f"+{_num(spec.duration_s)}"
    items = ([f"side={spec.side}"] if spec.side is not None else []) + [
        f"{k}={_num(v)}" for k, v in spec.params.items()
    ]
    return text + (":" + ",".join(items) if items else "")


def schedule(faults: Sequence[FaultSpec]) -> list[dict[str, Any]]:
    """The faults as plain data, for a run's meta.json and metrics.json.

    Parameters
    ----------
    faults : sequence of FaultSpec
        The faults.

    Returns
    -------
    list of dict
        Per fault: ``fault`` (its text), ``kind``, ``at_s``, ``end_s`` (None: to the end)
        [s], ``side`` and ``params``.
    """
    out = []
    for f in faults:
        start, end = fault_window(f)
        out.append(
            {
                "fault": format_fault(f),
                "kind": f.kind,
                "at_s": start,
                "end_s": None if math.isinf(end) else end,
                "side": f.side,
                "params": dict(f.params),
            }
        )
    return out


def summary(entry: Mapping[str, Any]) -> str:
    """What one fault did, in words: an entry of :meth:`FaultInjector.record`.

    Parameters
    ----------
    entry : Mapping
        The entry.

    Returns
    -------
    str
        ``never acted``, or ``acted from T s`` and its count (``, 12 frames lost``).
    """
    first = entry["first_s"]
    if first is None:
        return "never acted"
    counts = "".join(
        f", {entry[key]} {key.replace('_', ' ')}" for key in COUNTS.values() if key in entry
    )
    return f"acted from {first:.3f} s{counts}"


# --------------------------------------------------------------------------- at run time


class _Active:
    """One fault at run time: its window, its random stream, what it did."""

    def __init__(self, spec: FaultSpec, rng: np.random.Generator) -> None:
        self.spec = spec
        self.start_s, self.end_s = fault_window(spec)
        self.rng = rng
        self.first_s: float | None = None  # the first instant it acted
        self.count = 0  # spikes, frames lost or corrupted, revolutions lost
        self.next_spike_s = math.inf
        if spec.kind == "imu_spike":
            self.next_spike_s = self.start_s + rng.exponential(1.0 / spec.params["rate_hz"])

    def active(self, t_s: float) -> bool:
        return self.start_s - TIME_EPS_S <= t_s < self.end_s - TIME_EPS_S

    def acted(self, t_s: float) -> None:
        if self.first_s is None:
            self.first_s = t_s


COUNTS = {
    "imu_spike": "spikes",
    "frame_loss": "frames_lost",
    "corrupt_bytes": "frames_corrupted",
    "lidar_dropout": "revolutions_lost",
}
"""The count each kind records of what it injected."""


def fault_streams(faults: Sequence[FaultSpec], seed: int) -> list[np.random.Generator]:
    """Each fault's random stream: keyed by the seed and the fault itself, not its position.

    Parameters
    ----------
    faults : sequence of FaultSpec
        The faults.
    seed : int
        The twin's seed (>= 0).

    Returns
    -------
    list of numpy.random.Generator
        One generator per fault, in order.
    """
    seen: dict[str, int] = {}
    out = []
    for f in faults:
        text = format_fault(f)
        n = seen.get(text, 0)
        seen[text] = n + 1
        out.append(np.random.default_rng([seed, FAULT_STREAM, zlib.crc32(text.encode()), n]))
    return out


class FaultInjector:
    """The twin's faults while it runs (see the module docstring for where each acts).

    Parameters
    ----------
    faults : sequence of FaultSpec
        The schedule.
    seed : int
        The twin's seed: each fault's stream derives from it (:func:`fault_streams`).

    Attributes
    ----------
    faults : tuple of FaultSpec
        The schedule.
    """

    def __init__(self, faults: Sequence[FaultSpec], seed: int) -> None:
        self.faults = tuple(faults)
        streams = fault_streams(self.faults, seed)
        self._all = [_Active(f, rng) for f, rng in zip(self.faults, streams, strict=True)]

        def of(*kinds: str) -> list[_Active]:
            return [a for a in self._all if a.spec.kind in kinds]

        self._gyro = of("imu_spike", "imu_bias_step")
        self._imu = of("imu_dead", "imu_stuck")
        self._encoders = of("encoder_dropout")
        self._slip = of("wheel_slip")
        self._link = of("frame_loss", "corrupt_bytes")
        self._lidar = of("lidar_noise", "lidar_dropout")
        self._lidar_line = of("lidar_garbage", "lidar_closed")
        self._last: SensorSample | None = None  # the previous reading, as the MCU read it
        self._stuck: SensorSample | None = None  # the registers a stuck IMU repeats
        self._held: list[int | None] = [None, None]  # a cut encoder's count, per wheel
        self._missed = [0, 0]  # counts a cut encoder lost, per wheel

    @property
    def lidar_line_faults(self) -> bool:
        """Whether any fault acts on the LiDAR's line (garbage, a closed port)."""
        return bool(self._lidar_line)

    @property
    def link(self) -> bool:
        """Whether any fault acts on the MCU's serial line."""
        return bool(self._link)

    # ------------------------------------------------------------------ IMU and encoders

    def gyro_z_offset_rad_s(self, t_s: float) -> float:
        """What the gyro's z rate gains in the reading at ``t_s``: bias steps in force and the
        spikes that fell since the previous reading. Call once per reading, in time order.

        Parameters
        ----------
        t_s : float
            The reading's instant [s].

        Returns
        -------
        float
            The offset [rad/s] (0.0 without such faults).
        """
        offset = 0.0
        for a in self._gyro:
            if a.spec.kind == "imu_bias_step":
                if a.active(t_s):
                    offset += a.spec.params["magnitude_rad_s"]
                    a.acted(t_s)
                continue
            if a.active(t_s):
                a.acted(t_s)
            magnitude, mean_gap_s = a.spec.params["magnitude_rad_s"], 1.0 / a.spec.params["rate_hz"]
            while a.next_spike_s <= t_s + TIME_EPS_S:
                sign = 1.0 if a.rng.random() < 0.5 else -1.0
                if a.next_spike_s < a.end_s - TIME_EPS_S:
                    offset += sign * magnitude
                    a.count += 1
                    a.next_spike_s += a.rng.exponential(mean_gap_s)
                else:
                    a.next_spike_s = math.inf
        return offset

    def sensors(self, t_s: float, sample: SensorSample) -> SensorSample:
        """The reading at ``t_s`` as the faulty sensors give it to the MCU.

        Parameters
        ----------
        t_s : float
            The reading's instant [s].
        sample : SensorSample
            What healthy sensors read (with :meth:`gyro_z_offset_rad_s` already in the gyro).

        Returns
        -------
        SensorSample
            ``imu_ok`` cleared while ``imu_dead`` acts; the registers of the last reading
            before onset while ``imu_stuck`` acts; a cut encoder's count held, and behind by
            what it missed after the cut ends.
        """
        last = self._last
        dead = stuck = False
        for a in self._imu:
            if a.active(t_s):
                a.acted(t_s)
                if a.spec.kind == "imu_dead":
                    dead = True
                else:
                    stuck = True
        out = sample
        if stuck:
            if self._stuck is None:
                self._stuck = last if last is not None else sample
            s = self._stuck
            out = SensorSample(out.enc_left, out.enc_right, out.imu_ok, s.accel, s.temp, s.gyro)
        else:
            self._stuck = None
        if dead:
            out = SensorSample(out.enc_left, out.enc_right, False, out.accel, out.temp, out.gyro)
        if self._encoders:
            counts = [out.enc_left, out.enc_right]
            cut = [False, False]
            for a in self._encoders:
                if a.active(t_s):
                    a.acted(t_s)
                    cut[SIDES.index(a.spec.side or "left")] = True
            for i in (0, 1):
                if cut[i]:
                    held = self._held[i]
                    if held is None:
                        before = (last.enc_left, last.enc_right)[i] if last else None
                        held = counts[i] - self._missed[i] if before is None else before
                        self._held[i] = held
                    self._missed[i] = counts[i] - held
                else:
                    self._held[i] = None
                counts[i] -= self._missed[i]
            out = SensorSample(counts[0], counts[1], out.imu_ok, out.accel, out.temp, out.gyro)
        self._last = out
        return out

    # ------------------------------------------------------------------ wheel slip

    def slip_boundaries_s(self) -> list[float]:
        """The instants a wheel-slip window opens or closes, ascending [s]."""
        edges = {t for a in self._slip for t in fault_window(a.spec) if math.isfinite(t)}
        return sorted(edges)

    def mu_scale(self, t_s: float) -> tuple[float, float] | None:
        """The factor on the floor's friction under each wheel at the physics step that starts
        at ``t_s`` (overlapping windows multiply), or None where no slip acts.

        Parameters
        ----------
        t_s : float
            The step's start [s].

        Returns
        -------
        tuple of float or None
            ``(left, right)`` factors [1].
        """
        scale = [1.0, 1.0]
        hit = False
        for a in self._slip:
            if a.active(t_s):
                a.acted(t_s)
                scale[SIDES.index(a.spec.side or "left")] *= a.spec.params["mu_scale"]
                hit = True
        return (scale[0], scale[1]) if hit else None

    # ------------------------------------------------------------------ the serial line

    def telemetry(self, t_s: float, frame: bytes) -> bytes | None:
        """A telemetry frame sent at ``t_s`` as it reaches the host's end of the line.

        Every link fault in its window draws for every frame (a loss, then a byte and a bit
        to flip), whatever the others do, so each fault's draws depend on its own window only.

        Parameters
        ----------
        t_s : float
            The frame's MCU time [s].
        frame : bytes
            The frame the MCU sent.

        Returns
        -------
        bytes or None
            None when the frame is lost; otherwise the frame, with one bit of one byte
            flipped when corrupted.
        """
        lost = False
        flips: list[tuple[int, int]] = []
        corrupters: list[_Active] = []
        for a in self._link:
            if not a.active(t_s):
                continue
            a.acted(t_s)
            p = a.spec.params["probability"]
            if a.spec.kind == "frame_loss":
                if a.rng.random() < p and not lost:
                    lost = True
                    a.count += 1
            else:
                hit = a.rng.random() < p
                index, bit = int(a.rng.integers(len(frame))), int(a.rng.integers(8))
                if hit:
                    flips.append((index, bit))
                    corrupters.append(a)
        if lost:
            return None  # a lost frame reaches nobody, corrupted or not
        for a in corrupters:
            a.count += 1
        if not flips:
            return frame
        out = bytearray(frame)
        for index, bit in flips:
            out[index] ^= 1 << bit
        return bytes(out)

    # ------------------------------------------------------------------ the LiDAR

    def scan(
        self,
        t_s: float,
        ranges: NDArray[np.float32],
        range_min_m: float,
        range_max_m: float,
    ) -> NDArray[np.float32] | None:
        """A scan taken at ``t_s`` as the faulty sensor delivers it.

        Parameters
        ----------
        t_s : float
            When the revolution ended [s].
        ranges : numpy.ndarray
            The healthy sensor's ranges [m] (``inf`` for no return).
        range_min_m, range_max_m : float
            The sensor's limits: a noisy reading outside them reads ``inf`` [m].

        Returns
        -------
        numpy.ndarray or None
            The ranges with each ``lidar_noise``'s N(0, sigma_m^2) added to every return
            (one draw per beam), or None when a ``lidar_dropout`` loses the revolution.
        """
        out = ranges
        lost = False
        for a in self._lidar:
            if not a.active(t_s):
                continue
            a.acted(t_s)
            if a.spec.kind == "lidar_noise":
                noise = a.rng.normal(0.0, a.spec.params["sigma_m"], len(ranges))
                noisy = out.astype(np.float64) + noise
                noisy[(noisy < range_min_m) | (noisy > range_max_m)] = np.inf
                out = noisy.astype(np.float32)
            elif a.rng.random() < a.spec.params["probability"]:
                if not lost:
                    a.count += 1
                lost = True
        return None if lost else out

    def lidar_line(self, t_s: float, revolution_bytes: int) -> tuple[bytes, bool]:
        """What the LiDAR's line carries at simulation time ``t_s`` besides its revolutions:
        (random bytes to put before the next revolution, whether the port is gone).

        Parameters
        ----------
        t_s : float
            Simulation time [s].
        revolution_bytes : int
            The size of one revolution on the line (``lidar_garbage``'s ratio is of it).
        """
        garbage = b""
        closed = False
        for a in self._lidar_line:
            if not a.active(t_s):
                continue
            a.acted(t_s)
            if a.spec.kind == "lidar_garbage":
                n = max(1, round(a.spec.params["ratio"] * revolution_bytes))
                garbage += a.rng.integers(0, 256, n, dtype=np.uint8).tobytes()
                a.count += 1
            else:
                closed = True
        return garbage, closed

    # ------------------------------------------------------------------ the record

    def record(self) -> list[dict[str, Any]]:
        """What was injected, for a run's metrics.json.

        Returns
        -------
        list of dict
            :func:`schedule`'s entries plus ``first_s``, the first instant the fault acted
            (a reading, a frame, a scan or a physics step; None: never, e.g. the run ended
            before its onset or the twin has no LiDAR) [s], and for spikes, lost and
            corrupted frames and lost revolutions their count (``spikes``, ``frames_lost``,
            ``frames_corrupted``, ``revolutions_lost``).
        """
        out = schedule(self.faults)
        for entry, a in zip(out, self._all, strict=True):
            entry["first_s"] = a.first_s
            if a.spec.kind in COUNTS:
                entry[COUNTS[a.spec.kind]] = a.count
        return out
