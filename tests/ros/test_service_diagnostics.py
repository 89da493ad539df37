"""/diagnostics as the builder makes them (no ROS needed): a status per sensor from the health
monitor, the serial link's, the navigation service's; and the navigation a mission's topics
show (:func:`navigation_of`)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.config import HostConfig
from jackson.host.control.navigate import NavigateConfig, NavigateMission
from jackson.host.nav.types import Pose2D
from jackson.host.ros.messages import (
    LEVEL_ERROR,
    LEVEL_OK,
    LEVEL_WARN,
    DiagnosticValues,
    MessageBuilder,
    NavigationValues,
    RosSettings,
    StampClock,
    navigation_of,
)
from jackson.host.service.goals import GoalRecord, GoalStatus
from jackson.host.service.navigation import NavigationService
from jackson.host.service.settings import ServiceSettings

from ..host.service.test_service import room

HEALTHY = (
    ("imu", "ok"),
    ("encoder_left", "ok"),
    ("encoder_right", "ok"),
    ("link", "ok"),
    ("lidar", "ok"),
)


def statuses(values: DiagnosticValues) -> dict[str, Any]:
    cfg = HostConfig()
    builder = MessageBuilder(RosSettings.for_config(cfg), cfg.odometry, StampClock(True))
    return {s.name: s for s in builder.diagnostics(values).status}


def sample(**changes: Any) -> DiagnosticValues:
    base = DiagnosticValues(
        t_s=12.0,
        link_up=True,
        frames=240,
        crc_errors=0,
        imu_ok=True,
        imu_calibrated=True,
        sensors=HEALTHY,
        reasons=tuple((name, "") for name, _ in HEALTHY),
        lidar=(("scans", 80), ("unused", 0)),
    )
    return replace(base, **changes)


def values(status: Any) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def test_each_sensor_has_a_status_with_the_monitors_state() -> None:
    got = statuses(sample())
    assert {"jackson: link", "jackson: imu", "jackson: encoders", "jackson: lidar"} <= set(got)
    assert "jackson: sensor health" not in got  # one status per sensor instead
    assert all(got[n].level == LEVEL_OK for n in ("jackson: imu", "jackson: encoders"))
    assert got["jackson: lidar"].message == "ok, 80 scans"
    assert values(got["jackson: encoders"]) == {"left": "ok", "right": "ok"}
    assert values(got["jackson: link"])["health"] == "ok"


def test_an_excluded_sensor_is_an_error_with_its_reason() -> None:
    sensors = dict(HEALTHY, encoder_left="excluded", lidar="suspect")
    reasons = {"encoder_left": "counts stopped while the gyro turned", "lidar": "rough ranges"}
    got = statuses(sample(sensors=tuple(sensors.items()), reasons=tuple(reasons.items())))
    enc = got["jackson: encoders"]
    assert enc.level == LEVEL_ERROR
    assert enc.message == "left excluded: counts stopped while the gyro turned"
    assert got["jackson: lidar"].level == LEVEL_WARN
    assert got["jackson: lidar"].message == "suspect: rough ranges"
    assert got["jackson: imu"].level == LEVEL_OK


def test_the_imu_status_is_the_worse_of_its_flags_and_its_health() -> None:
    sensors = dict(HEALTHY, imu="excluded")
    got = statuses(sample(imu_calibrated=False, sensors=tuple(sensors.items())))
    assert got["jackson: imu"].level == LEVEL_ERROR
    assert got["jackson: imu"].message.startswith("not calibrated; excluded")


def test_without_the_monitor_the_imu_and_link_come_from_the_frames_only() -> None:
    got = statuses(sample(sensors=(), reasons=(), lidar=()))
    assert "jackson: encoders" not in got and "jackson: lidar" not in got
    assert "health" not in values(got["jackson: imu"])
    assert got["jackson: link"].message == "up"


def test_the_link_status_names_the_link_problems() -> None:
    got = statuses(sample(problems=("3 CRC errors",), crc_errors=3))
    assert got["jackson: link"].level == LEVEL_WARN
    assert got["jackson: link"].message == "up; 3 CRC errors"
    assert statuses(sample(link_up=False))["jackson: link"].level == LEVEL_ERROR


def test_the_navigation_status_tells_state_goal_last_result_and_counts() -> None:
    active = GoalRecord(4, Pose2D(7.5, 5.0, 0.0), "navigate_to_pose", GoalStatus.ACTIVE)
    active = replace(active, t_start_s=10.0, t_end_s=12.0, distance_remaining_m=3.2)
    last = GoalRecord(3, Pose2D(1.0, 1.0), "goal_pose", GoalStatus.ABORTED, "timeout")
    counts = (("succeeded", 2), ("aborted", 1), ("canceled", 0), ("rejected", 1))
    nav = NavigationValues("navigating", None, active, last, counts, 9.5)
    status = statuses(sample(navigation=nav))["jackson: navigation"]
    kv = values(status)
    assert status.level == LEVEL_OK  # a goal is active: the abort is history
    assert status.message.startswith("navigating to goal 4 (7.50, 5.00) from navigate_to_pose")
    assert kv["goal_id"] == "4" and kv["distance_remaining_m"] == "3.20"
    assert (kv["last_status"], kv["last_reason"]) == ("aborted", "timeout")
    assert (kv["goals_succeeded"], kv["goals_rejected"]) == ("2", "1")
    idle = statuses(sample(navigation=replace(nav, state="idle", goal=None)))
    assert idle["jackson: navigation"].level == LEVEL_WARN
    refused = replace(nav, state="idle", goal=None, unavailable="LiDAR lost: port closed")
    got = statuses(sample(navigation=refused))["jackson: navigation"]
    assert got.level == LEVEL_ERROR and got.message.startswith("goals refused: LiDAR lost")


def test_the_topics_show_the_services_navigator_and_a_one_shot_missions_own() -> None:
    config = NavigateConfig(start=Pose2D(1.0, 1.0, 0.0), goals=())
    service = NavigationService(config, LimiterConfig(), room(), ServiceSettings())
    assert navigation_of(service) is service.nav
    one_shot = NavigateMission(
        replace(config, goals=(Pose2D(2.0, 1.0),)), LimiterConfig(), room(), keep_samples=False
    )
    assert navigation_of(one_shot) is one_shot
    assert navigation_of(None) is None
    assert math.isnan(NavigationValues("idle").eta_s)
