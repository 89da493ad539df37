"""The host's runtime configuration: YAML in, validated frozen dataclasses out.

This is what the robot *believes* (the paper's "physical runtime" column of Table 3 and the EKF
settings of Table 2): wheel radii, separation and encoder resolution per side, covariances,
limits, deadbands, the PCA9685 wiring, the MCU's settings. The twin's truth lives in its own
robot files and is never read here. ``host/config/jackson.yaml`` is the paper's robot and the
default; every field is optional and defaults to that file's value, unknown fields are refused.

Every problem is reported as one :class:`ConfigError` line naming the file and the field, e.g.
``config jackson.yaml: deadband.left.forward: expected a number in [0, 0.9), got 1.2``.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, is_dataclass, replace
from pathlib import Path
from typing import Any, TypeVar

from jackson.common.fields import ConfigError as ConfigError  # re-exported
from jackson.common.fields import Fields, read_yaml, show
from jackson.host.actuation.deadband import DeadbandConfig
from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.actuation.settings import ACTUATORS as ACTUATORS  # re-exported
from jackson.host.actuation.settings import DEFAULT_CONFIG as DEFAULT_CONFIG
from jackson.host.actuation.settings import LEFT_CHANNELS as LEFT_CHANNELS
from jackson.host.actuation.settings import PWM_FREQUENCY_RANGE_HZ as PWM_FREQUENCY_RANGE_HZ
from jackson.host.actuation.settings import RIGHT_CHANNELS as RIGHT_CHANNELS
from jackson.host.actuation.settings import Actuator as Actuator
from jackson.host.actuation.settings import Pca9685Settings as Pca9685Settings
from jackson.host.actuation.settings import parse_actuator, parse_pca9685
from jackson.host.actuation.watchdog import COMMAND_TIMEOUT_S
from jackson.host.actuation.wheel_pi import WheelPiConfig
from jackson.host.control.figure8 import FigureEightConfig
from jackson.host.control.square import SquareConfig
from jackson.host.estimation.ekf import EkfConfig, ProcessNoise
from jackson.host.estimation.odometry import OdometryCovariance, RobotGeometry
from jackson.host.health.config import POLICIES, HealthConfig
from jackson.host.service.settings import LiveViewSettings, ServiceSettings
from jackson.protocol.messages import (
    ACCEL_SCALE_RANGE,
    FAILSAFE_MS_DEFAULT,
    FAILSAFE_MS_RANGE,
    GYRO_BIAS_RAD_S_RANGE,
    TELEMETRY_RATE_HZ_DEFAULT,
    TELEMETRY_RATE_HZ_RANGE,
)

MAX_DEADBAND_DUTY = 0.9  # a breakaway duty at or above this leaves no range to control
MAX_GAIN = 2.0  # a deadband gain trim above this hides a miswired or stalled motor
MAX_TELEMETRY_RATE_HZ = TELEMETRY_RATE_HZ_RANGE[1]  # SET_RATE limit (protocol/schema.yaml)
# the host's /cmd_vel watchdog: the paper's command timeout, within the firmware's failsafe range
CMD_VEL_TIMEOUT_S_DEFAULT = COMMAND_TIMEOUT_S
CMD_VEL_TIMEOUT_RANGE_S = (FAILSAFE_MS_RANGE[0] / 1000.0, FAILSAFE_MS_RANGE[1] / 1000.0)
WATCHDOG_RANGE_S = CMD_VEL_TIMEOUT_RANGE_S  # its former name
ROTATION_TOLERANCE = 1e-3  # the firmware's test for a proper rotation
MAX_GYRO_BIAS_RAD_S = GYRO_BIAS_RAD_S_RANGE[1]  # the firmware refuses a bias of this or more

_Numbers = TypeVar("_Numbers", LimiterConfig, SquareConfig, FigureEightConfig)

Rotation = tuple[float, float, float, float, float, float, float, float, float]  # row-major 3x3
IDENTITY: Rotation = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


# ------------------------------------------------------------------------- the configuration


@dataclass(frozen=True)
class ImuCalibration:
    """Sent with SET_IMU_CALIBRATION: omega = R omega_s - gyro_bias, a = accel_scale R a_s."""

    rotation: Rotation = IDENTITY  # sensor to base frame, row-major
    gyro_bias_rad_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_scale: float = 1.0


@dataclass(frozen=True)
class ImuSettings:
    """The MCU's SET_CONFIG fields and the optional on-board IMU calibration."""

    accel_fs: int = 0  # 0-3: +-2, 4, 8, 16 g
    gyro_fs: int = 0  # 0-3: +-250, 500, 1000, 2000 deg/s
    direction_flags: int = 0  # bit 0 inverts the left encoder, bit 1 the right
    calibration: ImuCalibration | None = None


@dataclass(frozen=True)
class SerialSettings:
    """The link to the MCU."""

    port: str = "/dev/jackson-mcu"
    baudrate: int = 921600
    telemetry_rate_hz: int = TELEMETRY_RATE_HZ_DEFAULT  # the device's own (protocol/schema.yaml)


BAG_TOPIC_KEYS = (
    "wheel_odom", "imu", "filtered", "joint_states", "diagnostics", "tf", "tf_static", "scan",
    "map", "plan", "local_plan", "cmd_vel", "goal_pose", "initialpose", "telemetry",
)  # fmt: skip
"""The topic keys ``recording.bag_topic_hz`` may name: those of
:data:`jackson.host.ros.settings.TOPIC_TYPES` (the ROS package imports the config, so the
config keeps its own list; a test keeps the two the same)."""
BAG_TOPIC_HZ: dict[str, float] = {"local_plan": 5.0}
"""``recording.bag_topic_hz`` by default: /local_plan (the chosen roll-out, a visualisation,
about 16 Hz as the local planner publishes it) at 5 Hz in the bag."""


@dataclass(frozen=True)
class HostConfig:
    """Everything the daemon believes about its robot."""

    robot: RobotGeometry = field(default_factory=RobotGeometry)
    odometry: OdometryCovariance = field(default_factory=OdometryCovariance)
    ekf: EkfConfig = field(default_factory=EkfConfig)
    limits: LimiterConfig = field(default_factory=LimiterConfig)
    # the local planner's top speed (Nav2 DWB's max_vel_x) [m/s]; None: limits.max_v_m_s
    navigation_max_v_m_s: float | None = None
    square: SquareConfig = field(default_factory=SquareConfig)  # Stage 1's waypoint controller
    figure8: FigureEightConfig = field(default_factory=FigureEightConfig)  # Stage 2's profile
    deadband: DeadbandConfig = field(default_factory=DeadbandConfig)
    wheel_pi: WheelPiConfig = field(default_factory=WheelPiConfig)
    health: HealthConfig = field(default_factory=HealthConfig)
    actuator: Actuator = "pca9685"
    pca9685: Pca9685Settings = field(default_factory=Pca9685Settings)
    imu: ImuSettings = field(default_factory=ImuSettings)
    serial: SerialSettings = field(default_factory=SerialSettings)
    # [s] external velocity commands older than this brake the motors (the host's watchdog)
    cmd_vel_timeout_s: float = CMD_VEL_TIMEOUT_S_DEFAULT
    # [ms] the MCU brakes (and drops the interlock line) when HEARTBEATs stop this long
    failsafe_ms: int = FAILSAFE_MS_DEFAULT
    recording_folder: Path = Path("runs")
    bag_max_mb: float = 1024.0  # a run's bag goes on in its next file beyond this (0: never)
    bag_compression: str = "zstd"  # the bag's MCAP chunk compression: zstd, lz4 or none
    # at most this many messages per second of MCU time of each topic key in the bag (the live
    # node publishes every one): Nav2 visualisation topics thinned, every other topic whole
    bag_topic_hz: Mapping[str, float] = field(default_factory=lambda: dict(BAG_TOPIC_HZ))
    recording_split: str = "goal"  # a service's run folders: one per goal, per split_s, or none
    recording_split_s: float = 3600.0  # [s] of MCU time per run folder (split: duration)
    recording_budget_mb: float = 4000.0  # beyond it the oldest run folders go (0: never)
    service: ServiceSettings = field(default_factory=ServiceSettings)

    def navigation_limits(self) -> LimiterConfig:
        """The bounds the local planner samples within: ``limits`` with the navigation's top
        speed (``navigation.max_vel_x_m_s``) when one is set below ``limits.max_v_m_s``."""
        v = self.navigation_max_v_m_s
        if v is None or v >= self.limits.max_v_m_s:
            return self.limits
        return replace(self.limits, max_v_m_s=v)


BAG_COMPRESSIONS = ("zstd", "lz4", "none")

RECORDING_SPLITS = ("goal", "duration", "none")
"""``recording.bag_compression``: the MCAP chunk compressions a run's bag may use."""

DEFAULTS = HostConfig()
"""Every field's default: the parser reads them from here, never from a second literal."""


# ------------------------------------------------------------------------- validation


def load_config(path: str | Path = DEFAULT_CONFIG) -> HostConfig:
    """Read and validate a host configuration file.

    Parameters
    ----------
    path : str or Path
        A YAML file in the layout of ``host/config/jackson.yaml``.

    Returns
    -------
    HostConfig
        The validated configuration.

    Raises
    ------
    ConfigError
        One line naming the file and the field at fault.
    """
    where, data = read_yaml(Path(path), "config")
    return parse_config(data, where)


def parse_config(data: Mapping[Any, Any], where: str = "config") -> HostConfig:
    """Validate an already parsed mapping (the layout of the YAML file).

    Raises
    ------
    ConfigError
        One line ``<where>: <dotted field>: <problem>``.
    """
    top = Fields(where, data)
    cfg = HostConfig(
        robot=_robot(top.section("robot")),
        odometry=_odometry(top.section("odometry")),
        ekf=_ekf(top.section("ekf")),
        limits=_limits(top.section("limits")),
        navigation_max_v_m_s=_navigation(top.section("navigation")),
        square=_square(top.section("square")),
        figure8=_positive(top.section("figure8"), FigureEightConfig()),
        deadband=_deadband(top.section("deadband")),
        wheel_pi=_wheel_pi(top.section("wheel_pi")),
        health=_health(top.section("health")),
        actuator=parse_actuator(top),
        pca9685=parse_pca9685(top.section("pca9685")),
        imu=_imu(top.section("imu")),
        serial=_serial(top.section("serial")),
        cmd_vel_timeout_s=_cmd_vel_timeout(top),
        failsafe_ms=top.integer("failsafe_ms", DEFAULTS.failsafe_ms, *FAILSAFE_MS_RANGE),
        **_recording(top.section("recording")),
        service=_service(top.section("service")),
    )
    top.finish()
    return cfg


def _cmd_vel_timeout(top: Fields) -> float:
    """``cmd_vel_timeout_s``, or its deprecated name ``watchdog_s`` with a one-line warning (it
    once set the MCU's failsafe too; that is ``failsafe_ms`` now)."""
    if not top.has("watchdog_s"):
        return top.number("cmd_vel_timeout_s", DEFAULTS.cmd_vel_timeout_s, *CMD_VEL_TIMEOUT_RANGE_S)
    if top.has("cmd_vel_timeout_s"):
        raise top.fail("watchdog_s", "deprecated name of cmd_vel_timeout_s, also set: remove it")
    print(
        f"{top.where}: watchdog_s is deprecated: read as cmd_vel_timeout_s; the MCU's failsafe "
        "is failsafe_ms",
        file=sys.stderr,
    )
    return top.number("watchdog_s", DEFAULTS.cmd_vel_timeout_s, *CMD_VEL_TIMEOUT_RANGE_S)


def _robot(s: Fields) -> RobotGeometry:
    d = RobotGeometry()
    r_left, r_right = s.sides("wheel_radius_m", d.wheel_radius_left_m, 0.0, 1.0, lo_open=True)
    tpr_left, tpr_right = s.sides("ticks_per_rev", d.ticks_per_rev_left, 0.0, lo_open=True)
    out = RobotGeometry(
        wheel_radius_left_m=r_left,
        wheel_radius_right_m=r_right,
        wheel_separation_m=s.number(
            "wheel_separation_m", d.wheel_separation_m, 0.0, 5.0, lo_open=True
        ),
        ticks_per_rev_left=tpr_left,
        ticks_per_rev_right=tpr_right,
    )
    s.finish()
    return out


def _odometry(s: Fields) -> OdometryCovariance:
    d = OdometryCovariance()
    twist = s.section("twist_covariance")
    pose = s.section("pose_covariance")
    out = OdometryCovariance(
        twist_vx=twist.number("vx", d.twist_vx, 0.0),
        twist_vy=twist.number("vy", d.twist_vy, 0.0),
        twist_wz=twist.number("wz", d.twist_wz, 0.0),
        pose_xy=pose.number("xy", d.pose_xy, 0.0),
        pose_yaw=pose.number("yaw", d.pose_yaw, 0.0),
    )
    twist.finish()
    pose.finish()
    s.finish()
    return out


def _ekf(s: Fields) -> EkfConfig:
    d = EkfConfig()
    q = s.section("process_noise")
    qd = ProcessNoise()
    noise = ProcessNoise(**{f.name: q.number(f.name, getattr(qd, f.name), 0.0) for f in fields(qd)})
    q.finish()
    gate = s.section("mahalanobis_threshold")
    wheel = gate.optional_number("wheel", 0.0, lo_open=True)
    imu = gate.optional_number("imu", 0.0, lo_open=True)
    gate.finish()
    out = EkfConfig(
        frequency_hz=s.number("frequency_hz", d.frequency_hz, 0.0, lo_open=True),
        sensor_timeout_s=s.number("sensor_timeout_s", d.sensor_timeout_s, 0.0, lo_open=True),
        process_noise=noise,
        initial_covariance=s.number("initial_covariance", d.initial_covariance, 0.0, lo_open=True),
        r_vx=s.number("r_vx", d.r_vx, 0.0, lo_open=True),
        r_vy=s.number("r_vy", d.r_vy, 0.0, lo_open=True),
        r_wz=s.number("r_wz", d.r_wz, 0.0, lo_open=True),
        mahalanobis_wheel=wheel,
        mahalanobis_imu=imu,
        gyro_bias_window_s=s.number("gyro_bias_window_s", d.gyro_bias_window_s, 0.0),
    )
    s.finish()
    return out


def _limits(s: Fields) -> LimiterConfig:
    return _positive(s, LimiterConfig())


MAX_SPEED_M_S = 10.0  # [m/s] beyond any robot this stack drives (1000: a slip of units)
MAX_TURN_RATE_RAD_S = 100.0  # [rad/s] wheels 0.2 m apart, each at MAX_SPEED_M_S


def _within_reach(s: Fields, key: str, value: float) -> None:
    """Refuse a speed (``*_m_s``) or turn rate (``*_rad_s``) no robot drives: the limiter would
    cap it without a word, and the mission would not be the one written."""
    hi = MAX_SPEED_M_S if key.endswith("_m_s") else MAX_TURN_RATE_RAD_S
    if key.endswith(("_m_s", "_rad_s")) and value > hi:
        raise s.fail(key, f"expected a number in (0, {hi:g}], got {value:g}")


def _navigation(s: Fields) -> float | None:
    out = s.optional_number("max_vel_x_m_s", 0.0, lo_open=True)
    if out is not None:
        _within_reach(s, "max_vel_x_m_s", out)
    s.finish()
    return out


def _positive(s: Fields, d: _Numbers) -> _Numbers:
    """A dataclass of numbers, each above 0 (speeds and turn rates within reach), defaulting to
    ``d``'s."""
    out = replace(
        d, **{f.name: s.number(f.name, getattr(d, f.name), 0.0, lo_open=True) for f in fields(d)}
    )
    for f in fields(d):
        _within_reach(s, f.name, getattr(out, f.name))
    s.finish()
    return out


def _square(s: Fields) -> SquareConfig:
    out = _positive(s, SquareConfig())
    if out.v_min_m_s > out.v_max_m_s:
        raise s.fail(
            "v_min_m_s", f"must not exceed v_max_m_s ({out.v_max_m_s:g}), got {out.v_min_m_s:g}"
        )
    if out.w_min_rad_s > out.w_max_rad_s:
        raise s.fail(
            "w_min_rad_s",
            f"must not exceed w_max_rad_s ({out.w_max_rad_s:g}), got {out.w_min_rad_s:g}",
        )
    return out


def _deadband(s: Fields) -> DeadbandConfig:
    d = DeadbandConfig()
    duty: dict[str, float] = {}
    for side in ("left", "right"):
        w = s.section(side)
        for direction in ("forward", "reverse"):
            name = f"{direction}_{side}"
            duty[name] = w.number(direction, getattr(d, name), 0.0, MAX_DEADBAND_DUTY, hi_open=True)
        w.finish()
    gain = s.section("gain")
    gain_left, gain_reverse_left = _gain(gain, "left", d.gain_left)
    gain_right, gain_reverse_right = _gain(gain, "right", d.gain_right)
    gain.finish()
    max_wheel = s.number("max_wheel_rad_s", d.max_wheel_rad_s, 0.0, lo_open=True)
    zero = s.number("zero_threshold_rad_s", d.zero_threshold_rad_s, 0.0, max_wheel, hi_open=True)
    s.finish()
    return DeadbandConfig(
        **duty,
        max_wheel_rad_s=max_wheel,
        zero_threshold_rad_s=zero,
        gain_left=gain_left,
        gain_right=gain_right,
        gain_reverse_left=gain_reverse_left,
        gain_reverse_right=gain_reverse_right,
    )


def _gain(s: Fields, side: str, default: float) -> tuple[float, float | None]:
    """``side: 0.95`` (both directions) or ``side: {forward: 0.95, reverse: 0.97}``; the
    (forward, reverse) gains, reverse None when it follows forward."""
    if not isinstance(s.data.get(side), Mapping):
        return s.number(side, default, 0.0, MAX_GAIN, lo_open=True), None
    w = s.section(side)
    forward = w.number("forward", default, 0.0, MAX_GAIN, lo_open=True)
    reverse = (
        w.number("reverse", forward, 0.0, MAX_GAIN, lo_open=True) if w.has("reverse") else None
    )
    w.finish()
    return forward, reverse


def _wheel_pi(s: Fields) -> WheelPiConfig:
    d = WheelPiConfig()
    out = WheelPiConfig(
        enabled=s.boolean("enabled", d.enabled),
        external=s.boolean("external", d.external),
        kp=s.number("kp", d.kp, 0.0),
        ki=s.number("ki", d.ki, 0.0),
        integral_limit=s.number("integral_limit", d.integral_limit, 0.0, 1.0),
        output_limit=s.number("output_limit", d.output_limit, 0.0, 1.0, lo_open=True),
    )
    s.finish()
    return out


def _health(s: Fields) -> HealthConfig:
    d = HealthConfig()
    values: dict[str, Any] = {}
    for f in fields(HealthConfig):
        default = getattr(d, f.name)
        if isinstance(default, bool):
            values[f.name] = s.boolean(f.name, default)
        elif isinstance(default, int):
            values[f.name] = s.integer(f.name, default, 1, 1000)
        elif isinstance(default, str):
            v = s.text(f.name, default)
            if v not in POLICIES:
                raise s.fail(f.name, f"expected one of {', '.join(POLICIES)}, got {show(v)}")
            values[f.name] = v
        else:
            values[f.name] = s.number(f.name, default, 0.0)
    s.finish()
    try:
        return HealthConfig(**values)
    except ValueError as exc:  # "HealthConfig.<field> must be ..."
        key, _, problem = str(exc).removeprefix("HealthConfig.").partition(" ")
        raise s.fail(key, problem) from None


def _imu(s: Fields) -> ImuSettings:
    d = ImuSettings()
    calibration = None
    if s.data.get("calibration") is not None:
        calibration = _imu_calibration(s.section("calibration"))
    else:
        s.used.add("calibration")
    out = ImuSettings(
        accel_fs=s.integer("accel_fs", d.accel_fs, 0, 3),
        gyro_fs=s.integer("gyro_fs", d.gyro_fs, 0, 3),
        direction_flags=s.integer("direction_flags", d.direction_flags, 0, 3),
        calibration=calibration,
    )
    s.finish()
    return out


def _imu_calibration(s: Fields) -> ImuCalibration:
    """The firmware's own acceptance test, so a bad calibration fails here, not as a NACK."""
    for key in ("rotation", "gyro_bias_rad_s", "accel_scale"):
        if not s.has(key):
            raise s.fail(
                key, "missing (a calibration needs rotation, gyro_bias_rad_s and accel_scale)"
            )
    d = ImuCalibration()
    r = s.vector("rotation", d.rotation, 9)
    worst = max(
        abs(sum(r[3 * i + k] * r[3 * j + k] for k in range(3)) - (1.0 if i == j else 0.0))
        for i in range(3)
        for j in range(3)
    )
    det = (
        r[0] * (r[4] * r[8] - r[5] * r[7])
        - r[1] * (r[3] * r[8] - r[5] * r[6])
        + r[2] * (r[3] * r[7] - r[4] * r[6])
    )
    if worst >= ROTATION_TOLERANCE or abs(det - 1.0) >= ROTATION_TOLERANCE:
        raise s.fail(
            "rotation",
            f"expected a rotation (orthonormal, determinant +1, within {ROTATION_TOLERANCE:g}) "
            f"as 9 numbers row by row, got {list(r)}",
        )
    bias = s.vector("gyro_bias_rad_s", d.gyro_bias_rad_s, 3)
    if max(abs(b) for b in bias) >= MAX_GYRO_BIAS_RAD_S:
        raise s.fail(
            "gyro_bias_rad_s",
            f"expected 3 numbers in rad/s, each smaller than {MAX_GYRO_BIAS_RAD_S:g} in "
            f"magnitude, got {list(bias)}",
        )
    out = ImuCalibration(
        rotation=(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]),
        gyro_bias_rad_s=(bias[0], bias[1], bias[2]),
        accel_scale=s.number("accel_scale", d.accel_scale, *ACCEL_SCALE_RANGE),
    )
    s.finish()
    return out


def _serial(s: Fields) -> SerialSettings:
    d = SerialSettings()
    out = SerialSettings(
        port=s.text("port", d.port),
        baudrate=s.integer("baudrate", d.baudrate, 1, 100_000_000),
        telemetry_rate_hz=s.integer(
            "telemetry_rate_hz", d.telemetry_rate_hz, 1, MAX_TELEMETRY_RATE_HZ
        ),
    )
    s.finish()
    return out


def _recording(s: Fields) -> dict[str, Any]:
    out = {
        "recording_folder": Path(s.text("folder", str(DEFAULTS.recording_folder))),
        "bag_max_mb": s.number("bag_max_mb", DEFAULTS.bag_max_mb, 0.0),
        "bag_compression": s.text("bag_compression", DEFAULTS.bag_compression),
    }
    out["bag_topic_hz"] = _bag_topic_hz(s)
    out["recording_split"] = s.text("split", DEFAULTS.recording_split)
    if out["recording_split"] not in RECORDING_SPLITS:
        raise s.fail(
            "split", f"{out['recording_split']!r} is not one of {', '.join(RECORDING_SPLITS)}"
        )
    out["recording_split_s"] = s.number("split_s", DEFAULTS.recording_split_s, 0.0, lo_open=True)
    out["recording_budget_mb"] = s.number("budget_mb", DEFAULTS.recording_budget_mb, 0.0)
    if out["bag_compression"] not in BAG_COMPRESSIONS:
        raise s.fail(
            "bag_compression",
            f"{out['bag_compression']!r} is not one of {', '.join(BAG_COMPRESSIONS)}",
        )
    s.finish()
    return out


def _bag_topic_hz(s: Fields) -> dict[str, float]:
    """``recording.bag_topic_hz``: topic key -> at most this many messages per second
    (absent: :data:`BAG_TOPIC_HZ`; ``{}`` or null: every message of every topic)."""
    if not s.has("bag_topic_hz"):
        s.used.add("bag_topic_hz")
        return dict(BAG_TOPIC_HZ)
    rates = s.section("bag_topic_hz")
    out = {}
    for key in list(rates.data):
        if key not in BAG_TOPIC_KEYS:
            raise rates.fail(str(key), f"not a topic key (one of {', '.join(BAG_TOPIC_KEYS)})")
        out[str(key)] = rates.number(str(key), 1.0, 0.0, lo_open=True)
    rates.finish()
    return out


def _service(s: Fields) -> ServiceSettings:
    d = ServiceSettings()
    map_file = s.optional_text("map")
    lv = s.section("live_view")
    dv = LiveViewSettings()
    live_view = LiveViewSettings(
        enabled=lv.boolean("enabled", dv.enabled),
        host=lv.text("host", dv.host),
        port=lv.integer("port", dv.port, 1, 65535),
    )
    lv.finish()
    out = ServiceSettings(
        lidar=s.optional_text("lidar"),
        lidar_mode=s.text("lidar_mode", d.lidar_mode),
        map=None if map_file is None else Path(map_file),
        start=tuple(s.vector("start", d.start, 3)),  # type: ignore[arg-type]
        socket=s.text("socket", d.socket),
        goal_timeout_s=s.number("goal_timeout_s", d.goal_timeout_s, 0.0, lo_open=True),
        lost_std_m=s.number("lost_std_m", d.lost_std_m, 0.0, lo_open=True),
        lost_confirm_s=s.number("lost_confirm_s", d.lost_confirm_s, 0.0),
        history=s.integer("history", d.history, 1, 100_000),
        live_view=live_view,
    )
    s.finish()
    return out


# ------------------------------------------------------------------------- output


def _per_side(left: float, right: float) -> float | dict[str, float]:
    return left if left == right else {"left": left, "right": right}


def _per_direction(forward: float, reverse: float | None) -> float | dict[str, float]:
    return forward if reverse is None else {"forward": forward, "reverse": reverse}


def dump_config(cfg: HostConfig) -> dict[str, Any]:
    """The configuration in the layout of the YAML file; ``parse_config`` reads it back equal."""
    sv = cfg.service
    robot, odo, ekf, db, pca, imu = (
        cfg.robot,
        cfg.odometry,
        cfg.ekf,
        cfg.deadband,
        cfg.pca9685,
        cfg.imu,
    )
    out: dict[str, Any] = {
        "robot": {
            "wheel_radius_m": _per_side(robot.wheel_radius_left_m, robot.wheel_radius_right_m),
            "wheel_separation_m": robot.wheel_separation_m,
            "ticks_per_rev": _per_side(robot.ticks_per_rev_left, robot.ticks_per_rev_right),
        },
        "odometry": {
            "twist_covariance": {"vx": odo.twist_vx, "vy": odo.twist_vy, "wz": odo.twist_wz},
            "pose_covariance": {"xy": odo.pose_xy, "yaw": odo.pose_yaw},
        },
        "ekf": {
            "frequency_hz": ekf.frequency_hz,
            "sensor_timeout_s": ekf.sensor_timeout_s,
            "process_noise": {
                f.name: getattr(ekf.process_noise, f.name) for f in fields(ProcessNoise)
            },
            "initial_covariance": ekf.initial_covariance,
            "r_vx": ekf.r_vx,
            "r_vy": ekf.r_vy,
            "r_wz": ekf.r_wz,
            "mahalanobis_threshold": {"wheel": ekf.mahalanobis_wheel, "imu": ekf.mahalanobis_imu},
            "gyro_bias_window_s": ekf.gyro_bias_window_s,
        },
        "limits": {f.name: getattr(cfg.limits, f.name) for f in fields(LimiterConfig)},
        "navigation": {"max_vel_x_m_s": cfg.navigation_max_v_m_s},
        "square": {f.name: getattr(cfg.square, f.name) for f in fields(SquareConfig)},
        "figure8": {f.name: getattr(cfg.figure8, f.name) for f in fields(FigureEightConfig)},
        "deadband": {
            "left": {"forward": db.forward_left, "reverse": db.reverse_left},
            "right": {"forward": db.forward_right, "reverse": db.reverse_right},
            "max_wheel_rad_s": db.max_wheel_rad_s,
            "zero_threshold_rad_s": db.zero_threshold_rad_s,
            "gain": {
                "left": _per_direction(db.gain_left, db.gain_reverse_left),
                "right": _per_direction(db.gain_right, db.gain_reverse_right),
            },
        },
        "wheel_pi": {f.name: getattr(cfg.wheel_pi, f.name) for f in fields(WheelPiConfig)},
        "health": {f.name: getattr(cfg.health, f.name) for f in fields(HealthConfig)},
        "actuator": cfg.actuator,
        "pca9685": {
            "bus": pca.bus,
            "address": pca.address,
            "frequency_hz": pca.frequency_hz,
            "channels": {
                side: {"pwm": b.pwm, "in1": b.in1, "in2": b.in2}
                for side, b in (("left", pca.left), ("right", pca.right))
            },
            "stby_channel": pca.stby_channel,
        },
        "imu": {
            "accel_fs": imu.accel_fs,
            "gyro_fs": imu.gyro_fs,
            "direction_flags": imu.direction_flags,
        },
        "serial": {f.name: getattr(cfg.serial, f.name) for f in fields(SerialSettings)},
        "cmd_vel_timeout_s": cfg.cmd_vel_timeout_s,
        "failsafe_ms": cfg.failsafe_ms,
        "recording": {
            "folder": str(cfg.recording_folder),
            "bag_max_mb": cfg.bag_max_mb,
            "bag_compression": cfg.bag_compression,
            "bag_topic_hz": dict(cfg.bag_topic_hz),
            "split": cfg.recording_split,
            "split_s": cfg.recording_split_s,
            "budget_mb": cfg.recording_budget_mb,
        },
        "service": {
            "lidar": sv.lidar,
            "lidar_mode": sv.lidar_mode,
            "map": None if sv.map is None else str(sv.map),
            "start": list(sv.start),
            "socket": sv.socket,
            "goal_timeout_s": sv.goal_timeout_s,
            "lost_std_m": sv.lost_std_m,
            "lost_confirm_s": sv.lost_confirm_s,
            "history": sv.history,
            "live_view": {
                "enabled": sv.live_view.enabled,
                "host": sv.live_view.host,
                "port": sv.live_view.port,
            },
        },
    }
    if imu.calibration is not None:
        out["imu"]["calibration"] = {
            "rotation": list(imu.calibration.rotation),
            "gyro_bias_rad_s": list(imu.calibration.gyro_bias_rad_s),
            "accel_scale": imu.calibration.accel_scale,
        }
    return out


def _format(value: Any) -> str:
    """A leaf value for :func:`config_diff`: 621.0 as 621, None as null, tuples as lists."""
    if value is None or isinstance(value, bool):
        return show(value)
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() and abs(value) < 1e15 else repr(value)
    if isinstance(value, (int, str, Path)):
        return str(value)
    if isinstance(value, tuple):
        return "[" + ", ".join(_format(v) for v in value) + "]"
    if is_dataclass(value):
        inner = ", ".join(f"{f.name}: {_format(getattr(value, f.name))}" for f in fields(value))
        return "{" + inner + "}"
    return repr(value)


def config_diff(old: HostConfig, new: HostConfig) -> list[str]:
    """What changed between two configurations, one line per field.

    Lines name the dataclass fields, e.g. ``robot.ticks_per_rev_left: 621 -> 617``; a
    sub-configuration that appears or disappears (``imu.calibration``) is one line.
    """
    lines: list[str] = []

    def walk(prefix: str, a: Any, b: Any) -> None:
        if is_dataclass(a) and not isinstance(a, type) and type(a) is type(b):
            for f in fields(a):
                walk(f"{prefix}{f.name}.", getattr(a, f.name), getattr(b, f.name))
        elif a != b:
            lines.append(f"{prefix[:-1]}: {_format(a)} -> {_format(b)}")

    walk("", old, new)
    return lines
