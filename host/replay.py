"""``jackson replay``: a run folder fed back through a fresh :class:`HostCore`, offline.

The log's received frames and velocity commands go through the host in their recorded order
and the outputs (odometry, EKF, commands) are compared with the run's own files. A run that was
closed cleanly (its log ends with the end record) must be reproduced bit for bit. A run cut by
a kill or a power loss is compared on what both hold: every complete row the run kept must be
reproduced; the replay says how far the log went (frames, MCU time) and how many rows each file
kept. A log whose last bytes cannot be a record cut short (a record of an unknown kind, or one
whose length runs past a log that goes on to its end record: a flipped bit) is damaged, and
the one line says which record and at which byte.

A run folder that began at a split of a long-running daemon's recording (docs/recording.md)
starts from the core's snapshot it holds (``core.snapshot``, named by ``meta.json``'s
``snapshot``) instead of a fresh core: the state the live core had between the two frames.

A run the daemon ended on a lockstep stall (the twin stopped sending, :mod:`jackson.host.
transport`) has its end record, but did not end: its log holds the daemon's link record
``lockstep stalled: ...``, and the replay counts it as cut, with that line as the reason
(:attr:`ReplayResult.cut_reason`).
"""

from __future__ import annotations

import json
import struct
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from jackson.host.daemon_link import HOST_STALL_RECORD, host_stall_s
from jackson.host.recording import (
    KIND_CMD,
    KIND_END,
    KIND_LIDAR,
    KIND_LINK,
    KIND_REQUEST,
    KIND_RX,
    KIND_SETTINGS,
    KINDS,
    MAGIC,
    RecordingError,
    RunRecorder,
    read_log,
    unpack_command,
)
from jackson.protocol import Frame
from jackson.protocol.rplidar import DataType

if TYPE_CHECKING:  # the missions load when a run is replayed, not for jackson --help
    from jackson.host.actuation.limiter import LimiterConfig
    from jackson.host.control import Mission
    from jackson.host.control.navigate import NavigateConfig
    from jackson.host.core.settings import LiveSettings
    from jackson.host.nav.amcl import AmclConfig
    from jackson.host.nav.grid import OccupancyGrid
    from jackson.host.service.navigation import NavigationService, Request

COMPARED = ("odometry.csv", "ekf.csv", "commands.csv", "health.csv")
STALL_RECORD = "lockstep stalled: "  # the daemon's link record when a stall ended the run
NO_END_RECORD = "no end record: killed or power lost"
_RECORD = struct.Struct("<BQH")  # a log record's header: kind, host time [ns], payload length


@dataclass(frozen=True)
class HostStall:
    """The daemon's own stall, as its link record tells it (:func:`host_stall_s`) [s]."""

    stalled_s: float


@dataclass
class ReplayResult:
    frames: int = 0  # telemetry frames replayed
    commands: int = 0  # velocity commands replayed
    t0_s: float | None = None  # MCU time of the first and last telemetry frame
    t1_s: float | None = None
    complete: bool = False  # the run was closed cleanly: an end record and no stall
    rows: dict[str, tuple[int, int]] = field(default_factory=dict)  # file: (run, replay)
    differ: list[str] = field(default_factory=list)
    cut_reason: str | None = None  # why the run is cut (None when closed cleanly)
    snapshot: dict[str, object] | None = None  # the snapshot's header, when it started from one

    def how(self) -> str:
        """How the run ended, for the user: ``closed cleanly`` or ``cut (REASON)``."""
        return "closed cleanly" if self.cut_reason is None else f"cut ({self.cut_reason})"

    def span(self) -> str:
        if self.t0_s is None or self.t1_s is None:
            return "no telemetry"
        return f"MCU time {self.t0_s:.3f}-{self.t1_s:.3f} s"


def _lidar_answer_type(meta: dict[str, object], run: Path) -> int:
    """The answer type the run's LiDAR bytes are in: ``meta.json``'s ``lidar.answer_type``
    (0x81, standard nodes, in a run folder from before the daemon recorded it)."""
    from jackson.host.lidar.rplidar import DECODED_ANSWER_TYPES

    lidar = meta.get("lidar")
    if lidar is None:
        return int(DataType.MEASUREMENT)
    answer_type = lidar.get("answer_type") if isinstance(lidar, dict) else None
    if not isinstance(answer_type, int) or answer_type not in DECODED_ANSWER_TYPES:
        raise RecordingError(
            f"{run / 'meta.json'}: lidar.answer_type {answer_type!r} is not a scan answer type "
            "the host decodes (0x81, 0x82, 0x84, 0x85)"
        )
    return answer_type


def _meta(run: Path) -> tuple[dict[str, object], str | None]:
    from jackson.host.control import MISSIONS

    if not run.is_dir():
        what = "does not exist" if not run.exists() else "is a file"
        raise RecordingError(f"{run}: {what}; give a run folder written by jackson daemon")
    path = run / "meta.json"
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else "not valid JSON"
        raise RecordingError(f"{path}: {why}; not a run folder written by jackson daemon") from exc
    if not isinstance(meta, dict):
        raise RecordingError(f"{path}: expected a JSON object, got {type(meta).__name__}")
    mission = meta.get("mission")
    if mission is not None and mission not in MISSIONS and mission not in ("navigate", "service"):
        known = ", ".join(sorted(MISSIONS))
        raise RecordingError(f"{path}: mission {mission!r} is none of {known}")
    return meta, mission


def _checked_log(
    run: Path,
) -> tuple[
    list[tuple[int, Frame | tuple[float, float] | bytes | Request | LiveSettings | HostStall]],
    str | None,
]:
    """The log's records, each received frame decoded and each command unpacked, and why the
    run is cut (None: closed cleanly); or one line naming the first damaged record."""
    from jackson.host.core.settings import LiveSettings
    from jackson.protocol import ProtocolError, decode_message

    records: list[
        tuple[int, Frame | tuple[float, float] | bytes | Request | LiveSettings | HostStall]
    ] = []
    complete = False
    stalled: str | None = None
    consumed = len(MAGIC)  # bytes of the whole records read
    k = -1
    for k, r in enumerate(read_log(run)):
        consumed += _RECORD.size + len(r.payload)
        where = f"{run / 'log.jrec'}: record {k}"
        if r.kind not in KINDS:
            raise RecordingError(f"{where}: unknown kind {r.kind}; the log is damaged")
        if r.kind == KIND_RX:
            if len(r.payload) < 2:
                raise RecordingError(f"{where}: a received frame without TYPE and SEQ")
            frame = Frame(r.payload[0], r.payload[1], r.payload[2:])
            try:
                decode_message(frame)
            except (ProtocolError, KeyError, ValueError) as exc:
                raise RecordingError(
                    f"{where}: received frame of type {frame.type:#04x} does not decode ({exc})"
                ) from exc
            records.append((r.host_time_ns, frame))
        elif r.kind == KIND_CMD:
            if len(r.payload) != 16:
                raise RecordingError(
                    f"{where}: a velocity command of {len(r.payload)} bytes, expected 16"
                )
            records.append((r.host_time_ns, unpack_command(r.payload)))
        elif r.kind == KIND_LIDAR:
            records.append((r.host_time_ns, r.payload))
        elif r.kind == KIND_REQUEST:
            from jackson.host.service.navigation import Request

            try:
                records.append((r.host_time_ns, Request.decode(r.payload)))
            except ValueError as exc:
                raise RecordingError(f"{where}: {exc}") from exc
        elif r.kind == KIND_SETTINGS:
            try:
                records.append((r.host_time_ns, LiveSettings.decode(r.payload)))
            except ValueError as exc:
                raise RecordingError(f"{where}: {exc}") from exc
        elif r.kind == KIND_LINK and r.payload.startswith(STALL_RECORD.encode()):
            stalled = r.payload.decode("utf-8", "replace")
        elif r.kind == KIND_LINK and r.payload.startswith(HOST_STALL_RECORD.encode()):
            host_stall = host_stall_s(r.payload.decode("utf-8", "replace"))
            if host_stall is not None:  # the daemon's own stall, applied between the same frames
                records.append((r.host_time_ns, HostStall(host_stall)))
        elif r.kind == KIND_END:
            complete = True
    if not complete:
        _refuse_damaged_tail(run / "log.jrec", k + 1, consumed)
    return records, stalled if stalled is not None else (None if complete else NO_END_RECORD)


def _refuse_damaged_tail(path: Path, k: int, consumed: int) -> None:
    """Raise unless the bytes after the last whole record can be one record cut by a kill: a
    record of an unknown kind, or one whose length runs past a log that goes on to its end
    record, is damage (a flipped bit), not a cut."""
    data = path.read_bytes()
    tail = data[consumed:]
    if len(tail) < _RECORD.size:
        return  # a header cut short
    kind, _, n = _RECORD.unpack_from(tail)
    where = f"{path}: record {k} at byte {consumed}"
    if kind not in KINDS:
        raise RecordingError(f"{where}: unknown kind {kind}; the log is damaged")
    last_kind, _, last_n = _RECORD.unpack_from(data, len(data) - _RECORD.size)
    if len(tail) > _RECORD.size and last_kind == KIND_END and last_n == 0:
        raise RecordingError(
            f"{where}: its length ({n} bytes) runs past the end of the file, yet the log goes on "
            "to its end record; the log is damaged"
        )


def _rows(path: Path) -> list[str]:
    """The complete rows of a CSV file (a row cut by a kill has no newline and is dropped)."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise RecordingError(f"{path}: {why}") from exc
    lines = text.split("\n")
    return lines[:-1]  # the part after the last newline is empty or a cut row


def replay(run: Path, out: Path) -> ReplayResult:
    """Feed ``run`` through a fresh HostCore writing into ``out`` (a new or empty folder).

    Raises
    ------
    RecordingError
        The run folder is missing or damaged (one line naming the file).
    ConfigError
        Its config.yaml is not a valid host configuration.
    """
    from jackson.host.actuation.output import NullOutput
    from jackson.host.config import DEFAULT_CONFIG, load_config
    from jackson.host.control import make_mission
    from jackson.host.core import HostCore
    from jackson.host.core.settings import LiveSettings
    from jackson.host.recording.snapshot import load_error
    from jackson.host.service.navigation import NavigationService, Request
    from jackson.protocol import Telemetry

    meta, mission = _meta(run)
    cfg_path = run / "config.yaml"
    snapshot = _snapshot(run, meta)
    records, cut_reason = _checked_log(run)
    complete = cut_reason is None
    for name in COMPARED:
        if not (run / name).is_file():
            raise RecordingError(f"{run / name}: missing; the run folder is incomplete")
    result = ReplayResult(complete=complete, cut_reason=cut_reason)
    if snapshot is not None:  # the core as the daemon had it when this folder began
        path, result.snapshot, pickled = snapshot
        rec = RunRecorder(out, meta)
        try:
            core = HostCore.restore(pickled, NullOutput(), lambda m: None, rec)
        except Exception as exc:  # whatever a pickle of another version raises
            rec.close()
            raise load_error(path, result.snapshot, exc) from exc
        the_mission = core.mission
    else:
        cfg = load_config(cfg_path if cfg_path.exists() else DEFAULT_CONFIG)
        rec = RunRecorder(out, meta)
        the_mission = None
        if mission == "navigate":
            the_mission = _mission_from_meta(run, meta, cfg.navigation_limits())
        elif mission == "service":
            the_mission = _service_from_meta(run, meta, cfg.navigation_limits())
        elif mission:
            the_mission = make_mission(mission, cfg.square, cfg.figure8)
        core = HostCore(cfg, NullOutput(), lambda m: None, mission=the_mission, recorder=rec)
        core.lidar.expect(_lidar_answer_type(meta, run))
    for t_ns, item in records:
        if isinstance(item, bytes):
            core.on_lidar(item, t_ns)
        elif isinstance(item, Request):
            assert isinstance(the_mission, NavigationService)
            the_mission.put(item)
        elif isinstance(item, LiveSettings):
            core.request_settings(item)
        elif isinstance(item, HostStall):
            core.host_stalled(item.stalled_s)
        elif isinstance(item, Frame):
            core.on_frame(item, t_ns)
            if item.type == Telemetry.TYPE:
                t_s = Telemetry.unpack(item.payload).t_us / 1e6
                result.t0_s = t_s if result.t0_s is None else result.t0_s
                result.t1_s = t_s
                result.frames += 1
        else:
            v, w = item
            core.submit_velocity(v, w, t_ns)
            result.commands += 1
    rec.close()
    for name in COMPARED:
        kept, made = _rows(run / name), _rows(out / name)
        result.rows[name] = (max(len(kept) - 1, 0), max(len(made) - 1, 0))  # without the header
        same = kept == made if complete else made[: len(kept)] == kept
        if not same:
            result.differ.append(name)
    return result


def _snapshot(
    run: Path, meta: Mapping[str, object]
) -> tuple[Path, dict[str, object], bytes] | None:
    """The core's snapshot the run folder starts from (its path, header and pickle), or None
    for a folder that began with the daemon.

    Raises
    ------
    RecordingError
        ``meta.json`` names a snapshot that is missing or damaged.
    """
    from jackson.host.recording.snapshot import read_snapshot

    name = meta.get("snapshot")
    if name is None:
        return None
    if not isinstance(name, str) or "/" in name:
        raise RecordingError(f"{run / 'meta.json'}: snapshot {name!r} is not a file name")
    header, pickled = read_snapshot(run / name)
    return run / name, header, pickled


def _navigation_from_meta(
    run: Path, meta: Mapping[str, object]
) -> tuple[NavigateConfig, OccupancyGrid | None]:
    """The navigation settings and map a run folder recorded (``meta.json``'s ``navigate``).

    Raises
    ------
    RecordingError
        The ``navigate`` entry or the map is missing or damaged.
    """
    from jackson.host.control.navigate import NavigateConfig
    from jackson.host.control.navigator_config import NavigatorConfig
    from jackson.host.nav.grid import MapFileError, OccupancyGrid
    from jackson.host.nav.types import Pose2D

    where = run / "meta.json"
    nav = meta.get("navigate")
    if not isinstance(nav, Mapping):
        raise RecordingError(f"{where}: a navigation run without its navigate entry")
    try:
        config = NavigateConfig(
            start=Pose2D(*nav["start"]),
            goals=tuple(Pose2D(*g) for g in nav["goals"]),
            localisation=nav["localisation"],
            extent=tuple(nav["extent"]),
            lidar_mount=Pose2D(*nav["lidar_mount"]),
            deskew=bool(nav.get("deskew", False)),  # runs from before revolutions were deskewed
            amcl=_amcl_from_meta(nav.get("amcl")),
            # runs from before the planner took the mapper's map: never
            map_update_s=float(nav.get("map_update_s", 0.0)),
            seed=int(nav["seed"]),
            # runs from before the planner server took each plan on the tick that asked
            navigator=NavigatorConfig(plan_delay_ticks=int(nav.get("plan_delay_ticks", 0))),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise RecordingError(f"{where}: navigate: {exc}") from exc
    grid = None
    if nav.get("map"):
        try:
            grid = OccupancyGrid.load(run / str(nav["map"]))
        except MapFileError as exc:
            raise RecordingError(str(exc)) from exc
    return config, grid


def _amcl_from_meta(entry: object) -> AmclConfig:
    """The particle filter's parameters a run recorded; a run from before they were recorded
    ran with Nav2's translation noise (``alpha3``, ``alpha4`` 0.2) and the defaults else."""
    from jackson.host.nav.amcl import AmclConfig

    if entry is None:
        return AmclConfig(alpha3=0.2, alpha4=0.2)
    if not isinstance(entry, Mapping):
        raise TypeError(f"amcl: expected a mapping, got {entry!r}")
    return AmclConfig(**{str(k): v for k, v in entry.items()})


def _mission_from_meta(run: Path, meta: Mapping[str, object], limits: LimiterConfig) -> Mission:
    """The mission a navigation run folder was driven by (its ``meta.json`` and map).

    Raises
    ------
    RecordingError
        The ``navigate`` entry or the map is missing or damaged.
    """
    from jackson.host.control.navigate import NavigateMission

    config, grid = _navigation_from_meta(run, meta)
    return NavigateMission(config, limits, grid)


def _service_from_meta(
    run: Path, meta: Mapping[str, object], limits: LimiterConfig
) -> NavigationService:
    """The navigation service a run folder was recorded by (``navigate`` and ``service``).

    Raises
    ------
    RecordingError
        An entry or the map is missing or damaged.
    """
    from jackson.host.service.navigation import NavigationService
    from jackson.host.service.settings import ServiceSettings

    config, grid = _navigation_from_meta(run, meta)
    where = run / "meta.json"
    if grid is None:
        raise RecordingError(f"{where}: a service run without its map")
    entry = meta.get("service")
    if not isinstance(entry, Mapping):
        raise RecordingError(f"{where}: a service run without its service entry")
    try:
        settings = ServiceSettings(
            goal_timeout_s=float(entry["goal_timeout_s"]),
            lost_std_m=float(entry["lost_std_m"]),
            lost_confirm_s=float(entry["lost_confirm_s"]),
            history=int(entry["history"]),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise RecordingError(f"{where}: service: {exc}") from exc
    return NavigationService(config, limits, grid, settings)
