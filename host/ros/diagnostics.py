"""The daemon's summary on /diagnostics: the values it gathers once a second
(:class:`DiagnosticValues`, :class:`NavigationValues`) and the statuses they make, one per
part (the link, each sensor, the EKF, the command watchdog, the clock, the navigation service),
in the style of diagnostic_updater."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

if TYPE_CHECKING:
    from jackson.host.ros.stamp_clock import StampClock
    from jackson.host.service.goals import GoalRecord

LEVEL_OK, LEVEL_WARN, LEVEL_ERROR = 0, 1, 2  # diagnostic_msgs/DiagnosticStatus levels
# a sensor's health state (docs/health.md) as a diagnostic level
HEALTH_LEVELS = {
    "ok": LEVEL_OK,
    "recovered": LEVEL_OK,
    "suspect": LEVEL_WARN,
    "excluded": LEVEL_ERROR,
}


@dataclass(frozen=True)
class DiagnosticValues:
    """One /diagnostics sample, on MCU time.

    Attributes
    ----------
    t_s : float
        MCU time [s].
    link_up : bool
        The serial link to the MCU is open and delivering frames.
    frames : int
        Telemetry frames processed.
    crc_errors : int
        Frames the host's decoder dropped for a bad CRC.
    imu_ok, imu_calibrated : bool
        The IMU_OK and IMU_CALIBRATED bits of the last telemetry frame.
    rejected : tuple of (str, int)
        Measurements the EKF's Mahalanobis gate rejected, per sensor.
    watchdog_expired : bool
        No external velocity command within the watchdog time (0.6 s).
    braked : bool
        The motors are braked.
    link : tuple of (str, object)
        The link's and motor path's counters (``LinkHealth`` of the daemon), as key/values.
    problems : tuple of str
        What the operator should look at (empty when all is well).
    sensors : tuple of (str, str)
        Each sensor's health state (docs/health.md), empty without the monitor.
    reasons : tuple of (str, str)
        Why each sensor is in its state ('' while it never left ``ok``).
    lidar : tuple of (str, object)
        The LiDAR's counters as the monitor keeps them (scans, unused, roughness, missing).
    navigation : NavigationValues or None
        The navigation service's state (None without the service).
    """

    t_s: float
    link_up: bool
    frames: int
    crc_errors: int
    imu_ok: bool
    imu_calibrated: bool
    rejected: tuple[tuple[str, int], ...] = field(default=())
    watchdog_expired: bool = True
    braked: bool = True
    link: tuple[tuple[str, object], ...] = field(default=())
    problems: tuple[str, ...] = field(default=())
    sensors: tuple[tuple[str, str], ...] = field(default=())
    reasons: tuple[tuple[str, str], ...] = field(default=())
    lidar: tuple[tuple[str, object], ...] = field(default=())
    navigation: NavigationValues | None = None


@dataclass(frozen=True)
class NavigationValues:
    """The navigation service's part of a /diagnostics sample.

    Attributes
    ----------
    state : str
        ``idle``, ``navigating`` or ``teleop``.
    unavailable : str or None
        Why goals are refused now, else None.
    goal : GoalRecord or None
        The active goal.
    last : GoalRecord or None
        The goal that ended last (its status and reason: the last result).
    counts : tuple of (str, int)
        Goals ended so far, per end (succeeded, aborted, canceled, rejected).
    eta_s : float
        Estimated time remaining of the active goal [s] (nan without one).
    """

    state: str
    unavailable: str | None = None
    goal: GoalRecord | None = None
    last: GoalRecord | None = None
    counts: tuple[tuple[str, int], ...] = field(default=())
    eta_s: float = math.nan


def navigation_status(n: NavigationValues) -> tuple[int, str, dict[str, object]]:
    """The ``jackson: navigation`` status: (level, message, key/values). An error while goals
    are refused (sensors or the LiDAR lost), a warning while the last goal's end was an abort
    and no goal is active, else OK."""
    kv: dict[str, object] = {"state": n.state}
    level = LEVEL_OK
    if n.unavailable is not None:
        level, text = LEVEL_ERROR, f"goals refused: {n.unavailable}"
    elif n.goal is not None:
        g = n.goal
        text = f"navigating to goal {g.goal_id} ({g.pose.x:.2f}, {g.pose.y:.2f}) from {g.source}"
    elif n.state == "teleop":
        text = "teleop: velocity commands drive the robot"
    else:
        text = "idle, braked"
    if n.goal is not None:
        g = n.goal
        kv.update(
            goal_id=g.goal_id,
            goal=f"{g.pose.x:.3f}, {g.pose.y:.3f}, {g.pose.yaw:.3f}",
            goal_source=g.source,
            navigation_time_s=f"{g.navigation_time_s:.1f}",
            distance_remaining_m=f"{g.distance_remaining_m:.2f}",
            eta_s=f"{n.eta_s:.1f}",
            recoveries=g.recoveries,
        )
    if n.last is not None:
        last = n.last
        text += f"; last goal {last.goal_id} {last.status.value}: {last.reason}"
        if n.goal is None and last.status.value == "aborted":
            level = max(level, LEVEL_WARN)
        kv.update(
            last_goal_id=last.goal_id,
            last_status=last.status.value,
            last_reason=last.reason,
        )
    kv.update({f"goals_{end}": count for end, count in n.counts})
    return level, text, kv


class StatusOf(Protocol):
    """Makes one diagnostic_msgs/DiagnosticStatus (the builder's ``status``)."""

    def __call__(self, name: str, level: int, message: str, **kv: object) -> Any:
        """The status ``name`` at ``level`` saying ``message``, with key/values ``kv``."""
        ...


def diagnostic_statuses(v: DiagnosticValues, status: StatusOf, clock: StampClock) -> list[Any]:
    """The statuses of /diagnostics: the serial link, one per sensor (the IMU, the encoders, the
    LiDAR: their flags and the health monitor's states), the EKF, the command watchdog, the
    clock (robot time, with ``clock``) and the navigation service."""
    health, reasons = dict(v.sensors), dict(v.reasons)

    def judged(sensor: str) -> tuple[int, str]:
        """The monitor's level of a sensor and what to say of it ('' while it is ok)."""
        state = health.get(sensor)
        if state is None or state == "ok":
            return LEVEL_OK, ""
        why = reasons.get(sensor, "")
        return HEALTH_LEVELS.get(state, LEVEL_WARN), f"{state}: {why}" if why else state

    if not v.link_up:
        link_level, link_text = LEVEL_ERROR, "down"
    elif v.problems:
        link_level, link_text = LEVEL_WARN, "up; " + "; ".join(v.problems)
    else:
        link_level, link_text = LEVEL_OK, "up"
    level, text = judged("link")
    link_level, link_text = max(link_level, level), link_text + (f"; {text}" if text else "")
    imu_level = LEVEL_ERROR if not v.imu_ok else (LEVEL_OK if v.imu_calibrated else LEVEL_WARN)
    imu_text = "ok" if v.imu_ok else "no data"
    if v.imu_ok and not v.imu_calibrated:
        imu_text = "not calibrated"
    level, text = judged("imu")
    imu_level, imu_text = max(imu_level, level), imu_text + (f"; {text}" if text else "")
    monitor = {"health": health["link"]} if "link" in health else {}
    rejected = sum(n for _, n in v.rejected)
    statuses = [
        status(
            "jackson: link",
            link_level,
            link_text,
            frames=v.frames,
            crc_errors=v.crc_errors,
            **{k: x for k, x in v.link if k != "crc_errors"},
            **monitor,
        ),
        status(
            "jackson: imu",
            imu_level,
            imu_text,
            imu_ok=v.imu_ok,
            imu_calibrated=v.imu_calibrated,
            **({"health": health["imu"]} if "imu" in health else {}),
        ),
    ]
    if "encoder_left" in health:  # the monitor runs
        sides = [(side, *judged(f"encoder_{side}")) for side in ("left", "right")]
        said = [f"{side} {text}" for side, _, text in sides if text]
        statuses.append(
            status(
                "jackson: encoders",
                max(level for _, level, _ in sides),
                "; ".join(said) if said else "ok",
                left=health["encoder_left"],
                right=health["encoder_right"],
            )
        )
    if "lidar" in health:
        level, text = judged("lidar")
        counts = dict(v.lidar)
        if not text:
            scans = counts.get("scans", 0)
            text = f"ok, {scans} scans" if scans else "no scans (no LiDAR read)"
        statuses.append(status("jackson: lidar", level, text, health=health["lidar"], **counts))
    statuses += [
        status(
            "jackson: ekf",
            LEVEL_OK if rejected == 0 else LEVEL_WARN,
            f"{rejected} rejected measurements",
            **{f"rejected_{name}": n for name, n in v.rejected},
        ),
        status(
            "jackson: command watchdog",
            LEVEL_OK,
            "expired: braked" if v.watchdog_expired else "commanded",
            expired=v.watchdog_expired,
            braked=v.braked,
        ),
    ]
    if not clock.sim_time and clock.offset_s is not None and clock.jitter_s:
        jitter = np.asarray(clock.jitter_s) * 1e3
        p50, p99 = (float(x) for x in np.percentile(jitter, [50, 99]))
        statuses.append(
            status(
                "jackson: clock",
                LEVEL_OK,
                f"MCU time + {clock.offset_s:.6f} s; receive jitter p50 {p50:.2f} ms, "
                f"p99 {p99:.2f} ms",
                offset_s=f"{clock.offset_s:.6f}",
                jitter_p50_ms=f"{p50:.3f}",
                jitter_p99_ms=f"{p99:.3f}",
                jitter_max_ms=f"{float(jitter.max()):.3f}",
            )
        )
    if v.navigation is not None:
        level, text, kv = navigation_status(v.navigation)
        statuses.append(status("jackson: navigation", level, text, **kv))
    return statuses
