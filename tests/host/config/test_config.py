"""The host configuration: the shipped file, one-line errors, per-side values, diffs."""

from __future__ import annotations

import dataclasses
import importlib.resources
import math
from pathlib import Path
from typing import Any

import pytest
import yaml

from jackson.experiments.fidelity.mechanisms import BRINGUP_CONFIG
from jackson.host.actuation.tb6612 import BridgeChannels
from jackson.host.config import (
    DEFAULT_CONFIG,
    ConfigError,
    HostConfig,
    ImuCalibration,
    config_diff,
    dump_config,
    load_config,
    parse_config,
)
from jackson.host.estimation.ekf import PAPER_EKF
from jackson.protocol.messages import FAILSAFE_MS_DEFAULT

ROOT = Path(__file__).resolve().parents[3]


def shipped() -> dict[str, Any]:
    data = yaml.safe_load(DEFAULT_CONFIG.read_text(encoding="utf-8"))
    assert isinstance(data, dict)
    return data


def merge(base: dict[str, Any], change: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in change.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value)
        else:
            out[key] = value
    return out


def write(tmp_path: Path, data: Any, name: str = "jackson.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def load_with(tmp_path: Path, change: dict[str, Any]) -> HostConfig:
    """The shipped file with ``change`` merged in, loaded from tmp_path/jackson.yaml."""
    return load_config(write(tmp_path, merge(shipped(), change)))


def error_of(tmp_path: Path, change: dict[str, Any]) -> str:
    with pytest.raises(ConfigError) as info:
        load_with(tmp_path, change)
    message = str(info.value)
    assert "\n" not in message
    return message


# ------------------------------------------------------------------------- the shipped file


def test_shipped_file_carries_the_papers_runtime_values() -> None:
    cfg = load_config(DEFAULT_CONFIG)
    robot = cfg.robot
    assert (robot.wheel_radius_left_m, robot.wheel_radius_right_m) == (0.033, 0.033)
    assert robot.wheel_separation_m == 0.198
    assert (robot.ticks_per_rev_left, robot.ticks_per_rev_right) == (621, 621)
    assert robot.meters_per_tick_left == pytest.approx(2 * math.pi * 0.033 / 621)  # Eq. A18
    ekf = cfg.ekf
    assert (ekf.frequency_hz, ekf.sensor_timeout_s) == (30, 0.2)  # Table 2
    # Q and R: the consistent profile by default (docs/estimation.md), not Table 2's
    assert (ekf.r_vx, ekf.r_vy, ekf.r_wz) == (1e-4, 0.001, 4e-6)
    assert (ekf.mahalanobis_wheel, ekf.mahalanobis_imu) == (None, None)
    assert ekf.initial_covariance == 1e-9
    noise = ekf.process_noise
    assert (noise.x, noise.y, noise.yaw, noise.vx, noise.vyaw) == (0.0, 0.0, 2e-5, 2.5e-4, 2e-4)
    assert (cfg.odometry.twist_vx, cfg.odometry.twist_vy, cfg.odometry.twist_wz) == (
        0.01,
        0.001,
        0.02,
    )
    assert cfg.limits.max_v_m_s == 0.30
    assert cfg.deadband.forward_left == cfg.deadband.reverse_right == 0.10
    assert cfg.deadband.max_wheel_rad_s == 10.47
    assert not cfg.wheel_pi.enabled
    assert cfg.actuator == "pca9685"
    pca = cfg.pca9685
    assert (pca.bus, pca.address, pca.frequency_hz) == ("/dev/i2c-7", 0x40, 1000)
    assert pca.left == BridgeChannels(0, 1, 2)
    assert pca.right == BridgeChannels(5, 3, 4)
    assert pca.stby_channel is None
    assert (cfg.imu.accel_fs, cfg.imu.gyro_fs, cfg.imu.direction_flags) == (0, 0, 0)
    assert cfg.imu.calibration is None
    assert cfg.serial.port == "/dev/jackson-mcu"
    assert (cfg.serial.baudrate, cfg.serial.telemetry_rate_hz) == (921600, 20)
    assert cfg.cmd_vel_timeout_s == 0.6  # the paper's /cmd_vel watchdog
    assert cfg.failsafe_ms == 200  # the MCU's own, 4 heartbeat frames
    assert cfg.recording_folder == Path("runs")


def test_shipped_file_equals_the_defaults() -> None:
    assert load_config() == HostConfig()


def test_the_bringup_profile_carries_the_papers_ekf() -> None:
    """Table 2's Q and R, which the fidelity campaign compares with the paper's figures."""
    ekf = load_config(BRINGUP_CONFIG).ekf
    assert ekf == PAPER_EKF
    assert (ekf.r_vx, ekf.r_vy, ekf.r_wz) == (0.01, 0.001, 0.0004)  # Table 2
    noise = ekf.process_noise
    assert (noise.x, noise.y, noise.yaw, noise.vx, noise.vy, noise.vyaw, noise.ax) == (
        0.05, 0.05, 0.06, 0.025, 0.025, 0.02, 0.01,
    )  # fmt: skip
    assert (ekf.frequency_hz, ekf.sensor_timeout_s) == (30, 0.2)


def test_shipped_file_is_package_data() -> None:
    resource = importlib.resources.files("jackson.host") / "config" / "jackson.yaml"
    assert resource.is_file()
    assert DEFAULT_CONFIG == ROOT / "host" / "config" / "jackson.yaml"


def test_empty_sections_take_the_defaults(tmp_path: Path) -> None:
    assert load_config(write(tmp_path, {"robot": None, "ekf": {}})) == HostConfig()


# ------------------------------------------------------------------------- errors


def test_duty_out_of_range_names_file_and_field(tmp_path: Path) -> None:
    message = error_of(tmp_path, {"deadband": {"left": {"forward": 1.2}}})
    assert message == (
        "config jackson.yaml: deadband.left.forward: expected a number in [0, 0.9), got 1.2"
    )


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.yaml"
    with pytest.raises(ConfigError, match=r"^config file .*nowhere\.yaml: cannot read it \("):
        load_config(path)


def test_bad_yaml_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text("robot:\n  wheel_radius_m: 0.033\n  bad: [1, 2\n", encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert message.startswith("config broken.yaml: line ")
    assert "not valid YAML" in message
    assert "\n" not in message


def test_duplicate_key_is_bad_yaml(tmp_path: Path) -> None:
    path = tmp_path / "twice.yaml"
    path.write_text("failsafe_ms: 200\nfailsafe_ms: 300\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"^config twice.yaml: line 2: .*duplicate field"):
        load_config(path)


def test_top_level_must_be_a_mapping(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="expected a mapping of fields at the top level"):
        load_config(write(tmp_path, [1, 2]))


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        ({"robot": {"wheel_radus_m": 0.033}}, "robot.wheel_radus_m: unknown field"),
        ({"colour": "red"}, "colour: unknown field"),
        ({"deadband": {"left": {"forwards": 0.1}}}, "deadband.left.forwards: unknown field"),
        (
            {"robot": {"wheel_radius_m": -0.033}},
            "robot.wheel_radius_m: expected a number in (0, 1]",
        ),
        (
            {"robot": {"wheel_radius_m": {"left": 0.033, "right": 0}}},
            "robot.wheel_radius_m.right: expected a number in (0, 1], got 0",
        ),
        ({"robot": {"wheel_radius_m": {"left": 0.033}}}, "robot.wheel_radius_m.right: missing"),
        ({"robot": {"ticks_per_rev": 0}}, "robot.ticks_per_rev: expected a number > 0, got 0"),
        ({"robot": {"ticks_per_rev": "621"}}, "robot.ticks_per_rev: expected a number > 0"),
        ({"robot": {"wheel_separation_m": True}}, "got true"),
        ({"ekf": {"frequency_hz": 0}}, "ekf.frequency_hz: expected a number > 0, got 0"),
        ({"ekf": {"process_noise": {"yaw": -1}}}, "ekf.process_noise.yaw: expected a number >= 0"),
        (
            {"ekf": {"mahalanobis_threshold": {"imu": -3}}},
            "ekf.mahalanobis_threshold.imu: expected a number > 0 or null, got -3",
        ),
        ({"ekf": []}, "ekf: expected a mapping of fields, got []"),
        ({"limits": {"max_v_m_s": 0}}, "limits.max_v_m_s: expected a number > 0"),
        ({"deadband": {"right": {"reverse": -0.1}}}, "deadband.right.reverse: expected a number"),
        ({"deadband": {"gain": {"right": 0}}}, "deadband.gain.right: expected a number in (0, 2]"),
        (
            {"deadband": {"zero_threshold_rad_s": 11}},
            "deadband.zero_threshold_rad_s: expected a number in [0, 10.47), got 11",
        ),
        ({"wheel_pi": {"enabled": "yes"}}, "wheel_pi.enabled: expected true or false, got 'yes'"),
        (
            {"pca9685": {"channels": {"right": {"in1": 1}}}},
            "pca9685.channels.right.in1: channel 1 is already used by pca9685.channels.left.in1",
        ),
        (
            {"pca9685": {"stby_channel": 5}},
            "pca9685.stby_channel: channel 5 is already used by pca9685.channels.right.pwm",
        ),
        (
            {"pca9685": {"channels": {"left": {"pwm": 16}}}},
            "pca9685.channels.left.pwm: expected an integer in 0-15, got 16",
        ),
        (
            {"pca9685": {"address": 0x80}},
            "pca9685.address: expected an integer in 0x03-0x77, got 0x80",
        ),
        (
            {"pca9685": {"frequency_hz": 2000}},
            "pca9685.frequency_hz: expected a number in [24, 1526]",
        ),
        ({"pca9685": {"bus": "i2c1"}}, "pca9685.bus: expected /dev/i2c-N or unix:/path/to.sock"),
        ({"pca9685": {"bus": "unix:"}}, "pca9685.bus: expected /dev/i2c-N or unix:/path/to.sock"),
        ({"actuator": "arduino"}, "actuator: expected pca9685 or mcu, got 'arduino'"),
        ({"imu": {"gyro_fs": 4}}, "imu.gyro_fs: expected an integer in 0-3, got 4"),
        ({"imu": {"direction_flags": 4}}, "imu.direction_flags: expected an integer in 0-3"),
        (
            {"imu": {"calibration": {"rotation": [1, 0, 0, 0, 1, 0, 0, 0, 1]}}},
            "imu.calibration.gyro_bias_rad_s: missing",
        ),
        (
            {
                "imu": {
                    "calibration": {
                        "rotation": [1, 0, 0, 0, 1, 0, 0, 0, -1],
                        "gyro_bias_rad_s": [0, 0, 0],
                        "accel_scale": 1.0,
                    }
                }
            },
            "imu.calibration.rotation: expected a rotation (orthonormal, determinant +1",
        ),
        (
            {
                "imu": {
                    "calibration": {
                        "rotation": [1, 0, 0, 0, 1, 0, 0, 0],
                        "gyro_bias_rad_s": [0, 0, 0],
                        "accel_scale": 1.0,
                    }
                }
            },
            "imu.calibration.rotation: expected a list of 9 numbers",
        ),
        (
            {
                "imu": {
                    "calibration": {
                        "rotation": [1, 0, 0, 0, 1, 0, 0, 0, 1],
                        "gyro_bias_rad_s": [0, 0, 0.5],
                        "accel_scale": 1.0,
                    }
                }
            },
            "imu.calibration.gyro_bias_rad_s: expected 3 numbers in rad/s",
        ),
        ({"serial": {"port": ""}}, "serial.port: expected a non-empty text"),
        (
            {"serial": {"telemetry_rate_hz": 0}},
            "serial.telemetry_rate_hz: expected an integer in 1-500",
        ),
        ({"serial": {"baudrate": 9600.5}}, "serial.baudrate: expected an integer"),
        ({"cmd_vel_timeout_s": 0}, "cmd_vel_timeout_s: expected a number in [0.05, 10], got 0"),
        ({"failsafe_ms": 20}, "failsafe_ms: expected an integer in 50-10000, got 20"),
        ({"failsafe_ms": 0.2}, "failsafe_ms: expected an integer in 50-10000, got 0.2"),
        (
            {"watchdog_s": 0.5, "cmd_vel_timeout_s": 0.5},
            "watchdog_s: deprecated name of cmd_vel_timeout_s, also set: remove it",
        ),
        ({"recording": {"folder": 3}}, "recording.folder: expected a non-empty text, got 3"),
        (
            {"recording": {"bag_compression": "gzip"}},
            "recording.bag_compression: 'gzip' is not one of zstd, lz4, none",
        ),
        (
            {"recording": {"bag_topic_hz": {"local_plans": 5}}},
            "recording.bag_topic_hz.local_plans: not a topic key (one of wheel_odom, imu,",
        ),
        (
            {"recording": {"bag_topic_hz": {"scan": 0}}},
            "recording.bag_topic_hz.scan: expected a number > 0, got 0",
        ),
    ],
)
def test_each_bad_field_gives_one_line_naming_it(
    tmp_path: Path, change: dict[str, Any], expected: str
) -> None:
    message = error_of(tmp_path, change)
    assert message.startswith("config jackson.yaml: ")
    assert expected in message


# ------------------------------------------------------------------------- accepted values


def test_the_bag_thins_local_plan_by_default_and_a_config_may_keep_every_message(
    tmp_path: Path,
) -> None:
    assert load_config(DEFAULT_CONFIG).bag_topic_hz == {"local_plan": 5.0}
    assert load_with(tmp_path, {"recording": {"bag_topic_hz": None}}).bag_topic_hz == {}
    cfg = load_with(tmp_path, {"recording": {"bag_topic_hz": {"scan": 2, "local_plan": 1}}})
    assert cfg.bag_topic_hz == {"scan": 2.0, "local_plan": 1.0}


def test_the_bag_rates_name_every_topic_key_the_bag_has() -> None:
    from jackson.host.config import BAG_TOPIC_KEYS
    from jackson.host.ros.settings import TOPIC_TYPES

    assert BAG_TOPIC_KEYS == tuple(TOPIC_TYPES)


def test_per_side_values(tmp_path: Path) -> None:
    cfg = load_with(
        tmp_path,
        {
            "robot": {
                "wheel_radius_m": {"left": 0.0329, "right": 0.0331},
                "ticks_per_rev": {"left": 617, "right": 621},
            }
        },
    )
    assert (cfg.robot.wheel_radius_left_m, cfg.robot.wheel_radius_right_m) == (0.0329, 0.0331)
    assert (cfg.robot.ticks_per_rev_left, cfg.robot.ticks_per_rev_right) == (617.0, 621.0)
    assert cfg.robot.meters_per_tick_left == pytest.approx(2 * math.pi * 0.0329 / 617)
    assert cfg.robot.meters_per_tick_right == pytest.approx(2 * math.pi * 0.0331 / 621)


def test_one_number_applies_to_both_sides(tmp_path: Path) -> None:
    cfg = load_with(tmp_path, {"robot": {"ticks_per_rev": 652.5}})
    assert cfg.robot.ticks_per_rev_left == cfg.robot.ticks_per_rev_right == 652.5


def test_exponent_without_a_dot_is_a_number(tmp_path: Path) -> None:
    path = tmp_path / "jackson.yaml"
    path.write_text("ekf:\n  initial_covariance: 1e-9\n", encoding="utf-8")
    assert load_config(path).ekf.initial_covariance == 1e-9


def test_twin_bus_mcu_actuator_and_calibration(tmp_path: Path) -> None:
    calibration = {
        "rotation": [0, -1, 0, 1, 0, 0, 0, 0, 1],
        "gyro_bias_rad_s": [0.001, -0.002, 0.003],
        "accel_scale": 1.054,
    }
    cfg = load_with(
        tmp_path,
        {
            "actuator": "mcu",
            "pca9685": {"bus": "unix:/tmp/twin/i2c.sock", "stby_channel": 6},
            "imu": {"calibration": calibration},
            "ekf": {"mahalanobis_threshold": {"wheel": 9.21}},
        },
    )
    assert cfg.actuator == "mcu"
    assert cfg.pca9685.bus == "unix:/tmp/twin/i2c.sock"
    assert cfg.pca9685.stby_channel == 6
    assert cfg.imu.calibration == ImuCalibration(
        rotation=(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
        gyro_bias_rad_s=(0.001, -0.002, 0.003),
        accel_scale=1.054,
    )
    assert (cfg.ekf.mahalanobis_wheel, cfg.ekf.mahalanobis_imu) == (9.21, None)


def test_the_mcu_failsafe_and_the_command_watchdog_are_set_apart(tmp_path: Path) -> None:
    cfg = load_config(write(tmp_path, {"failsafe_ms": 300, "cmd_vel_timeout_s": 1.5}))
    assert (cfg.failsafe_ms, cfg.cmd_vel_timeout_s) == (300, 1.5)
    assert load_config(write(tmp_path, {"failsafe_ms": 300})).cmd_vel_timeout_s == 0.6
    assert load_config(write(tmp_path, {"cmd_vel_timeout_s": 1.5})).failsafe_ms == 200
    assert HostConfig().failsafe_ms == FAILSAFE_MS_DEFAULT  # the device's power-up value


def test_watchdog_s_is_read_as_the_command_timeout_with_one_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = load_config(write(tmp_path, {"watchdog_s": 0.8}))
    assert (cfg.cmd_vel_timeout_s, cfg.failsafe_ms) == (0.8, 200)  # the failsafe stays its own
    err = capsys.readouterr().err
    assert err == (
        "config jackson.yaml: watchdog_s is deprecated: read as cmd_vel_timeout_s; the MCU's "
        "failsafe is failsafe_ms\n"
    )


def test_configuration_is_frozen() -> None:
    cfg = HostConfig()
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.cmd_vel_timeout_s = 1.0  # type: ignore[misc]


# ------------------------------------------------------------------------- dump and diff


def changed_config() -> HostConfig:
    cfg = HostConfig()
    return dataclasses.replace(
        cfg,
        robot=dataclasses.replace(cfg.robot, ticks_per_rev_left=617.0, wheel_radius_right_m=0.0331),
        imu=dataclasses.replace(cfg.imu, calibration=ImuCalibration(accel_scale=1.054)),
        pca9685=dataclasses.replace(cfg.pca9685, left=BridgeChannels(8, 9, 10)),
    )


@pytest.mark.parametrize("cfg", [HostConfig(), changed_config()])
def test_dump_reads_back_equal(tmp_path: Path, cfg: HostConfig) -> None:
    assert parse_config(dump_config(cfg)) == cfg
    assert load_config(write(tmp_path, dump_config(cfg))) == cfg


def test_config_diff_names_each_changed_field() -> None:
    old = HostConfig()
    assert config_diff(old, old) == []
    new = dataclasses.replace(old, robot=dataclasses.replace(old.robot, ticks_per_rev_left=617.0))
    assert config_diff(old, new) == ["robot.ticks_per_rev_left: 621 -> 617"]
    lines = config_diff(old, changed_config())
    assert lines[:3] == [
        "robot.wheel_radius_right_m: 0.033 -> 0.0331",
        "robot.ticks_per_rev_left: 621 -> 617",
        "pca9685.left.pwm: 0 -> 8",
    ]
    assert lines[5].startswith("imu.calibration: null -> {rotation: [1, 0, 0, 0, 1, 0, 0, 0, 1], ")
    assert len(lines) == 6
    assert config_diff(old, dataclasses.replace(old, actuator="mcu")) == [
        "actuator: pca9685 -> mcu"
    ]


# ------------------------------------------------------------------------- navigation


def test_navigation_top_speed_caps_only_the_local_planner(tmp_path: Path) -> None:
    cfg = load_with(tmp_path, {"navigation": {"max_vel_x_m_s": 0.1}})
    assert cfg.navigation_max_v_m_s == 0.1
    assert cfg.limits.max_v_m_s == 0.30  # the limiter (and the square) keep theirs
    nav = cfg.navigation_limits()
    assert nav.max_v_m_s == 0.1
    assert dataclasses.replace(nav, max_v_m_s=0.30) == cfg.limits
    # unset, or above the limiter's: the limiter's
    assert HostConfig().navigation_limits() == HostConfig().limits
    fast = load_with(tmp_path, {"navigation": {"max_vel_x_m_s": 0.5}})
    assert fast.navigation_limits() == fast.limits
    assert parse_config(dump_config(cfg)) == cfg  # round trip
    assert error_of(tmp_path, {"navigation": {"max_vel_x_m_s": 0}}).endswith(
        "navigation.max_vel_x_m_s: expected a number > 0 or null, got 0"
    )


# ------------------------------------------------------------------------- missions


def test_mission_sections_reach_the_daemons_missions(tmp_path: Path) -> None:
    from jackson.host.control import FigureEight, SquareMission, make_mission

    cfg = load_with(
        tmp_path,
        {"square": {"heading_tolerance_rad": 0.02, "k_cross": 1.5}, "figure8": {"w_rad_s": 0.2}},
    )
    assert cfg.square.heading_tolerance_rad == 0.02
    assert cfg.square.k_cross == 1.5
    assert cfg.square.v_max_m_s == HostConfig().square.v_max_m_s  # the rest default
    assert parse_config(dump_config(cfg)) == cfg
    square = make_mission("square", cfg.square, cfg.figure8)
    assert isinstance(square, SquareMission) and square.cfg == cfg.square
    eight = make_mission("figure8", cfg.square, cfg.figure8)
    assert isinstance(eight, FigureEight) and eight.cfg.w_rad_s == 0.2


@pytest.mark.parametrize(
    ("data", "tail"),
    [
        ({"square": {"k_cross": 0}}, "square.k_cross: expected a number > 0, got 0"),
        ({"square": {"tolerance": 1}}, "square.tolerance: unknown field (check the spelling)"),
        (
            {"square": {"v_min_m_s": 0.2}},
            "square.v_min_m_s: must not exceed v_max_m_s (0.15), got 0.2",
        ),
        ({"figure8": {"v_m_s": -0.08}}, "figure8.v_m_s: expected a number > 0, got -0.08"),
    ],
)
def test_bad_mission_fields_name_the_field(tmp_path: Path, data: dict[str, Any], tail: str) -> None:
    assert error_of(tmp_path, data).endswith(tail)
