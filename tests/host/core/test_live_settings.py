"""Live settings go through the core's front door: requested from any thread, taken at the next
telemetry frame, handed to every stage that holds a copy (the limiter, the watchdog, DWB and the
recoveries of a navigator), logged before that frame and replayed at it."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.actuation.output import NullOutput
from jackson.host.config import DEFAULT_CONFIG, HostConfig, load_config
from jackson.host.control.navigate import NavigateConfig, NavigateMission
from jackson.host.control.navigator import Navigator, NavigatorConfig
from jackson.host.core import HostCore, RunFolderListener
from jackson.host.core.settings import LiveSettings, SettingsInbox
from jackson.host.nav.dwb.core.kinematics import Kinematics
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D
from jackson.host.recording import KIND_RX, KIND_SETTINGS, RecordingError, RunRecorder, read_log
from jackson.host.recording.snapshot import SNAPSHOT_NAME, encode_snapshot, write_snapshot
from jackson.host.replay import replay
from jackson.host.ros.live_parameters import ParameterError, changed_settings
from jackson.host.ros.settings import RosSettings
from jackson.host.service.navigation import NavigationService
from jackson.host.service.settings import ServiceSettings
from jackson.protocol import (
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    Frame,
    FrameDecoder,
    Info,
    Message,
    Telemetry,
    TelemetryFlags,
    encode_frame,
)

SLOW = LimiterConfig(max_v_m_s=0.1, max_w_rad_s=1.0, max_accel_m_s2=0.25)


def frame(msg: Message, seq: int) -> Frame:
    (f,) = FrameDecoder().feed(encode_frame(msg, seq))
    return f


INFO = Info(
    protocol_version=PROTOCOL_VERSION,
    schema_hash=SCHEMA_HASH,
    telemetry_rate_hz=20,
    failsafe_ms=600,
    imu_rotation=(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
    accel_scale=1.0,
    boot_id=7,
)


def telemetry(k: int) -> Frame:
    counts = 3 * max(0, k - 40)
    return frame(
        Telemetry(
            t_us=50_000 * (k + 1),
            enc_left=counts,
            enc_right=counts,
            flags=TelemetryFlags.IMU_OK,
            accel=(0, 0, 16384),
            gyro=(0, 0, 5 if k % 3 else -5),
        ),
        (k + 1) % 256,
    )


def room(side_m: float = 6.0, res: float = 0.05) -> OccupancyGrid:
    n = round(side_m / res)
    data = np.zeros((n, n), np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyGrid(data, res, 0.0, 0.0)


def navigation(cfg: HostConfig) -> NavigateMission:
    config = NavigateConfig(start=Pose2D(1.0, 1.0, 0.0), goals=(), seed=3)
    return NavigateMission(config, cfg.navigation_limits(), room())


# ---------------------------------------------------------------------- the value


def test_live_settings_round_trip_through_the_log_exactly() -> None:
    s = LiveSettings(
        dataclasses.replace(SLOW, max_alpha_rad_s2=math.inf, max_decel_m_s2=0.1 + 0.2), 0.65
    )
    assert LiveSettings.decode(s.encode()) == s
    assert LiveSettings.of(HostConfig()) == LiveSettings(LimiterConfig(), 0.6)


@pytest.mark.parametrize("timeout_s", [0.0, 0.04, 10.5, math.nan, "1"])
def test_a_command_timeout_outside_its_range_is_refused(timeout_s: object) -> None:
    with pytest.raises(ValueError, match=r"cmd_vel_timeout_s must be within 0.05-10 s"):
        LiveSettings(LimiterConfig(), timeout_s)  # type: ignore[arg-type]


def test_settings_logged_under_the_former_name_watchdog_s_still_decode() -> None:
    old = LiveSettings.decode(b'{"limits":{"max_v_m_s":0.2},"watchdog_s":0.7}')
    assert old == LiveSettings(LimiterConfig(max_v_m_s=0.2), 0.7)
    assert b'"cmd_vel_timeout_s":0.7' in old.encode()


def test_damaged_settings_in_a_log_are_named() -> None:
    with pytest.raises(ValueError, match="not live settings"):
        LiveSettings.decode(b'{"limits":{"max_v_m_s":-1},"watchdog_s":0.6}')


# ---------------------------------------------------------------------- the frame boundary


def test_a_live_limit_change_reaches_the_limiter_and_dwb_at_the_next_frame() -> None:
    cfg = load_config(DEFAULT_CONFIG)
    mission = navigation(cfg)
    core = HostCore(cfg, NullOutput(), lambda m: None, mission=mission)
    nav = mission.navigator
    core.on_frame(frame(INFO, 0))
    core.on_frame(telemetry(0))
    wanted = LiveSettings(SLOW, 0.9)
    core.request_settings(wanted)
    # requested: what the next change starts from, but nothing is applied between frames
    assert core.settings == wanted
    assert core.limiter.config == cfg.limits and core.watchdog.timeout_s == cfg.cmd_vel_timeout_s
    assert nav.limits == cfg.navigation_limits()
    assert nav.dwb.kinematics == Kinematics.of(nav.limits)
    core.on_frame(telemetry(1))
    assert core.limiter.config == SLOW and core.watchdog.timeout_s == 0.9
    assert nav.limits == SLOW  # DWB's window and the recoveries' speeds
    assert nav.dwb.kinematics == Kinematics.of(SLOW)
    assert nav.dwb.window(0.0, 0.0)[1] <= SLOW.max_v_m_s
    assert core.live.take() is None  # taken once


def test_a_navigator_spins_and_backs_up_within_the_limits_set_last() -> None:
    nav = Navigator(NavigatorConfig(), room(), LimiterConfig())
    nav.set_limits(LimiterConfig(max_v_m_s=0.03, max_w_rad_s=0.4))
    pose = Pose2D(3.0, 3.0, 0.0)
    speeds = []
    for _ in range(4):  # clear_costmaps, spin, wait, backup
        assert nav.behaviours.begin(0.0, pose)
        speeds.append(nav.behaviours.tick(0.05, pose, nav.limits))
        nav.behaviours.current = None
    assert speeds == [None, (0.0, 0.4), (0.0, 0.0), (-0.03, 0.0)]


def test_the_navigation_top_speed_of_the_configuration_still_caps_a_live_limit() -> None:
    cfg = dataclasses.replace(load_config(DEFAULT_CONFIG), navigation_max_v_m_s=0.2)
    mission = navigation(cfg)
    core = HostCore(cfg, NullOutput(), lambda m: None, mission=mission)
    faster = dataclasses.replace(cfg.limits, max_v_m_s=0.28, max_w_rad_s=1.5)
    core.request_settings(LiveSettings(faster, cfg.cmd_vel_timeout_s))
    core.on_frame(telemetry(0))
    assert core.limiter.config == faster
    assert mission.navigator.dwb.kinematics == Kinematics.of(
        dataclasses.replace(faster, max_v_m_s=0.2)
    )


def test_the_service_takes_a_live_limit_change_to_its_navigator() -> None:
    cfg = load_config(DEFAULT_CONFIG)
    config = NavigateConfig(start=Pose2D(1.0, 1.0, 0.0), goals=(), seed=3)
    svc = NavigationService(config, cfg.navigation_limits(), room(), ServiceSettings())
    core = HostCore(cfg, NullOutput(), lambda m: None, mission=svc)
    core.request_settings(LiveSettings(SLOW, cfg.cmd_vel_timeout_s))
    core.on_frame(telemetry(0))
    assert svc.nav.navigator.dwb.kinematics == Kinematics.of(SLOW)


def test_the_newest_request_before_a_frame_wins_and_the_others_are_not_logged(
    tmp_path: Path,
) -> None:
    rec = RunRecorder(tmp_path / "run", {"mission": None})
    core = HostCore(load_config(DEFAULT_CONFIG), NullOutput(), lambda m: None, recorder=rec)
    core.request_settings(LiveSettings(SLOW, 1.0))
    core.request_settings(LiveSettings(SLOW, 2.0))
    core.on_frame(telemetry(0))
    rec.close()
    kinds = [(r.kind, r.payload) for r in read_log(tmp_path / "run")]
    settings = [LiveSettings.decode(p) for k, p in kinds if k == KIND_SETTINGS]
    assert settings == [LiveSettings(SLOW, 2.0)]
    assert [k for k, _ in kinds].index(KIND_SETTINGS) < [k for k, _ in kinds].index(KIND_RX)


def test_a_run_with_a_live_change_replays_bit_for_bit(tmp_path: Path) -> None:
    """A velocity command at 0.25 m/s, then the limit lowered to 0.1 m/s mid-run: the log
    holds the change before the frame that applied it, and the replay applies it there."""
    rec = RunRecorder(tmp_path / "run", {"mission": None})
    core = HostCore(load_config(DEFAULT_CONFIG), NullOutput(), lambda m: None, recorder=rec)
    core.on_frame(frame(INFO, 0))
    for k in range(120):
        if k % 5 == 0 and k >= 50:
            core.submit_velocity(0.25, 0.0)
        if k == 80:
            core.request_settings(LiveSettings(SLOW, 0.6))
        core.on_frame(telemetry(k))
    rec.close()
    commands = (tmp_path / "run" / "commands.csv").read_text().splitlines()[1:]
    v = [float(row.split(",")[1]) for row in commands]
    assert max(v[60:80]) > 0.2 and max(v[90:]) == pytest.approx(0.1)
    result = replay(tmp_path / "run", tmp_path / "out")
    assert result.complete and result.differ == []


def test_a_change_not_yet_taken_at_a_split_is_logged_in_the_next_folder(tmp_path: Path) -> None:
    """A snapshot leaves out the settings requested and not yet taken (as commands and
    requests): the next frame takes them into the next folder, whose replay starts from the
    snapshot and must give the same rows."""
    cfg = load_config(DEFAULT_CONFIG)
    config = NavigateConfig(start=Pose2D(1.0, 1.0, 0.0), goals=(), seed=3)
    svc = NavigationService(config, cfg.navigation_limits(), room(), ServiceSettings())
    first = RunRecorder(tmp_path / "run", {"mission": "service"})
    core = HostCore(cfg, NullOutput(), lambda m: None, mission=svc, recorder=first)
    core.on_frame(frame(INFO, 0))
    for k in range(60):
        if k == 30:
            svc.submit_goal(Pose2D(4.0, 2.0))
        core.on_frame(telemetry(k))
    core.request_settings(LiveSettings(SLOW, 0.6))
    pickled = core.snapshot()
    copy = HostCore.restore(pickled, NullOutput(), lambda m: None)
    assert copy.live.take() is None and core.settings.limits == SLOW
    second = RunRecorder(tmp_path / "run-002", {"mission": "service", "snapshot": SNAPSHOT_NAME})
    write_snapshot(second.folder / SNAPSHOT_NAME, encode_snapshot(pickled, {"frames": 60}))
    (listener,) = (x for x in core.listeners if isinstance(x, RunFolderListener))
    listener.recorder = second
    first.close()
    for k in range(60, 140):
        core.on_frame(telemetry(k))
    second.close()
    assert svc.nav.navigator.dwb.kinematics == Kinematics.of(SLOW)
    assert [r for r in read_log(second.folder) if r.kind == KIND_SETTINGS]
    result = replay(second.folder, tmp_path / "out")
    assert result.complete and result.differ == []


def test_a_damaged_settings_record_stops_the_replay_with_one_line(tmp_path: Path) -> None:
    rec = RunRecorder(tmp_path / "run", {"mission": None})
    rec.settings(0, b"[")
    rec.close()
    with pytest.raises(RecordingError, match="record 0: not live settings") as err:
        replay(tmp_path / "run", tmp_path / "out")
    assert "\n" not in str(err.value)


def test_an_inbox_pickles_without_what_was_not_taken() -> None:
    import pickle

    inbox = SettingsInbox(HostConfig())
    inbox.request(LiveSettings(SLOW, 0.6))
    copy = pickle.loads(pickle.dumps(inbox))
    assert copy.take() is None and inbox.take() == LiveSettings(SLOW, 0.6)


# ---------------------------------------------------------------------- ROS parameters


FIXED = RosSettings.__dataclass_fields__


def test_parameter_changes_become_one_new_value_or_none() -> None:
    current = LiveSettings(LimiterConfig(), 0.6)
    changes = [("limits.max_v_m_s", 0.2), ("cmd_vel_timeout_s", 1), ("limits.max_w_rad_s", 1.0)]
    new = changed_settings(current, changes, FIXED)
    assert new == LiveSettings(LimiterConfig(max_v_m_s=0.2, max_w_rad_s=1.0), 1.0)
    assert isinstance(new.cmd_vel_timeout_s, float)
    assert changed_settings(current, [("use_sim_time", True)], FIXED) is current
    assert changed_settings(current, [("cmd_vel_timeout_s", 0.6)], FIXED) is current


@pytest.mark.parametrize(
    ("name", "value", "says"),
    [
        ("limits.max_accel_m_s2", -1.0, "limits.max_accel_m_s2: LimiterConfig.max_accel_m_s2"),
        ("cmd_vel_timeout_s", 20.0, "cmd_vel_timeout_s must be within 0.05-10 s, got 20.0"),
        ("base_frame", "base", "base_frame is read when the node starts: restart the daemon"),
    ],
)
def test_a_refused_parameter_names_why(name: str, value: object, says: str) -> None:
    current = LiveSettings(LimiterConfig(), 0.6)
    with pytest.raises(ParameterError, match=says):
        changed_settings(current, [("limits.max_v_m_s", 0.2), (name, value)], FIXED)
