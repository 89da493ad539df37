"""What a running daemon reports of itself: ``jackson status``'s answer (read from another
thread, from snapshots) and the run folder's health.json (the link, the sensors, what the
operator was told, CPU, frame latency, commands)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from jackson.host.commands import CommandCounters
    from jackson.host.core import HostCore
    from jackson.host.cpu import CpuMeter
    from jackson.host.daemon_latency import LatencyMeter
    from jackson.host.daemon_link import LinkHealth
    from jackson.host.service.navigation import NavigationService


def sensor_states(core: HostCore) -> dict[str, str]:
    """Each sensor's health state now (empty with the monitor off)."""
    hm = core.health
    return {name: state.value for name, state in hm.sensors.items()} if hm is not None else {}


def status_doc(
    core: HostCore,
    service: NavigationService | None,
    link: LinkHealth,
    cpu: CpuMeter,
    disk: dict[str, Any],
    latency: LatencyMeter | None = None,
) -> dict[str, Any]:
    """What ``jackson status`` shows: the service's state, goal, pose with covariance,
    sensor health, link problems, CPU, the frame latency and the recording folder's disk use
    (``disk``)."""
    out: dict[str, Any] = {"t_s": core.t_s, "frames": core.frames}
    if service is not None:
        st = service.status
        out.update(
            state=st.state.value,
            unavailable=st.unavailable,
            pose={
                "x": st.pose.x,
                "y": st.pose.y,
                "yaw": st.pose.yaw,
                "covariance": list(st.covariance),
            },
            goal=None if st.goal is None else st.goal.as_dict(),
            eta_s=None if math.isnan(st.eta_s) else st.eta_s,
            goals=dict(service.book.counts),
            last_goal=(lambda h: h[-1].as_dict() if h else None)(service.book.history()),
        )
    out["sensors"] = sensor_states(core)
    out["problems"] = link.problems()
    out["cpu"] = {
        "share_of_core": cpu.share_of_core,
        "robot_s": cpu.robot_s,
        "frame_p99_ms": cpu.percentile_us(0.99) / 1e3,
    }
    if latency is not None:
        out["latency_ms"] = {
            "median": latency.percentile_us(0.5) / 1e3,
            "p99": latency.percentile_us(0.99) / 1e3,
            "max": latency.max_us / 1e3,
        }
    out["disk"] = disk
    return out


def sensor_health(core: HostCore) -> dict[str, Any]:
    """The health monitor's verdict for health.json: states now and every transition."""
    hm = core.health
    if hm is None:
        return {"monitor": "off"}
    return {
        "states": {name: state.value for name, state in hm.sensors.items()},
        "transitions": [
            {
                "t_s": tr.t_s,
                "sensor": tr.sensor,
                "from": tr.old.value,
                "to": tr.new.value,
                "reason": tr.reason,
            }
            for tr in hm.transitions
        ],
        "counts": dict(hm.counts),
        "lidar": {
            **hm.lidar_counts,
            "roughness_m": hm.lidar_roughness_m,
            "missing_fraction": hm.lidar_missing,
        },
        "wheel_yaw_scale": hm.model.scale,
        "wheel_yaw_per_m": hm.model.per_metre,
    }


def health_doc(
    core: HostCore,
    link: LinkHealth,
    events: Iterable[str],
    cpu: CpuMeter,
    commands: CommandCounters,
    period_s: float,
    latency: LatencyMeter | None = None,
) -> dict[str, Any]:
    """health.json of the run folder being written: the link, the sensors, what the
    operator was told (``events``), CPU and the frame latency per telemetry period
    (``period_s``), commands."""
    doc: dict[str, Any] = {
        "link": dataclasses.asdict(link),
        "problems": link.problems(),
        "abort_reason": core.abort_reason,
        "sensors": sensor_health(core),
        "events": list(events),
        "cpu": cpu.report(period_s),
        "commands": {
            "acked": commands.acked,
            "nacked": commands.nacked,
            "retried": commands.retried,
            "errors": commands.errors,
        },
    }
    if latency is not None:
        doc["latency"] = latency.report(period_s)
    from jackson.host.ros.output import navigation_of

    nav = navigation_of(core.mission)
    if nav is not None:  # where its global plans were searched (the planner server)
        doc["planner"] = nav.navigator.planning.planner.report()
    return doc
