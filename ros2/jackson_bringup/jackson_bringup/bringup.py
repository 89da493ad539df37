"""What ``bringup.launch.py`` starts, worked out as plain data.

The launch file is a thin shell over this module: it reads its arguments, hands them to
:func:`parse_options`, and turns what the functions below return into launch actions. Nothing
here imports ROS, so the choices (which processes, with which command lines and parameters)
are tested without a ROS installation.

Who owns what on the ROS graph:

- the host daemon (``jackson daemon --ros``): /wheel/odom, /imu/data, /odometry/filtered,
  /joint_states, /diagnostics, odom -> base_footprint on /tf and the static mounts on
  /tf_static, all stamped with the MCU's clock; it drives from /cmd_vel;
- robot_state_publisher: the URDF on /robot_description, the wheel links from /joint_states;
- the clock: with ``twin:=true`` the twin's /clock (MCU time, which the daemon then stamps
  with); on the robot the system clock, onto which the daemon maps its stamps, or with
  ``use_sim_time:=true`` the MCU time of each /joint_states that ``mcu_clock`` republishes;
- /scan: sllidar_ros2 (``lidar:=sllidar``) or the daemon (``lidar:=host``, the twin's default);
- map -> odom: slam_toolbox (``slam:=true``) or AMCL (``map:=FILE``);
- /cmd_vel: Nav2 (``nav:=true``), or the user's teleop.
"""

from __future__ import annotations

import copy
import math
import shlex
import shutil
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

BASE_FOOTPRINT = "base_footprint"
BASE_LINK = "base_link"
IMU_LINK = "imu_link"
LASER = "laser"
SLLIDAR_FRAME = "laser_sllidar"  # sllidar_ros2's: laser turned by pi (it reports pi - heading)
LEFT_WHEEL_JOINT = "left_wheel_joint"
RIGHT_WHEEL_JOINT = "right_wheel_joint"

A1_BAUDRATE = 115200  # [baud] the RPLIDAR A1M8's serial rate
LIDAR_CHOICES = ("auto", "sllidar", "host", "none")
TWIN_READY = "waiting for HELLO"  # jackson sim prints this once its ports exist


class BringupError(ValueError):
    """A launch argument, or a combination of them, that cannot work; one line for the user."""


@dataclass(frozen=True)
class Argument:
    """A launch argument: its name, default value and description."""

    name: str
    default: str
    description: str


ARGUMENTS = (
    Argument("twin", "false", "true: start the digital twin (jackson sim --ros --realtime) "
             "and run the daemon against it"),
    Argument("world", "maze", "the twin's world: a name in sim/worlds or a world YAML"),
    Argument("jackson", "jackson", "the jackson command, e.g. ~/jackson/.venv/bin/jackson"),
    Argument("config", "", "host YAML for jackson daemon --config (default: the daemon's)"),
    Argument("port", "", "the MCU's serial port (default: serial.port of the config)"),
    Argument("i2c", "", "the PCA9685's I2C bus (default: pca9685.bus of the config)"),
    Argument("lidar", "auto", "who reads the RPLIDAR: sllidar (sllidar_ros2), host (the "
             "daemon), none; auto: sllidar on the robot, host with twin:=true (the daemon "
             "reads the twin's emulated RPLIDAR)"),
    Argument("lidar_port", "/dev/jackson-lidar", "the RPLIDAR's serial port"),
    Argument("slam", "false", "true: map with slam_toolbox (config/slam_toolbox.yaml)"),
    Argument("map", "", "a map_server YAML: localise on it with Nav2's map_server and AMCL"),
    Argument("nav", "false", "true: Nav2's navigation servers (config/nav2.yaml); needs "
             "slam:=true or map:=FILE"),
    Argument("initial_pose", "", "X,Y,YAW [m, m, rad]: AMCL's initial pose on the map "
             "(else give it in RViz with 2D Pose Estimate)"),
    Argument("use_sim_time", "auto", "run the nodes on /clock, the MCU's time; auto: with "
             "twin:=true (the twin's /clock), else on the system clock, onto which the daemon "
             "maps its stamps; true on the robot: mcu_clock republishes the daemon's MCU time"),
    Argument("rviz", "false", "true: start RViz with Nav2's default view"),
    Argument("daemon_args", "", "more arguments for jackson daemon, e.g. '--no-record'"),
    Argument("twin_args", "", "more arguments for jackson sim, e.g. '--seed 3'"),
)  # fmt: skip


@dataclass(frozen=True)
class Pose2D:
    """A planar pose [m, m, rad]."""

    x_m: float
    y_m: float
    yaw_rad: float


@dataclass(frozen=True)
class Options:
    """The launch arguments, checked and typed (see :data:`ARGUMENTS`).

    Attributes
    ----------
    lidar : str
        ``sllidar``, ``host`` or ``none``; ``auto`` is resolved (``host`` with the twin: the
        daemon reads its emulated RPLIDAR and publishes /scan, as on the robot).
    twin_lidar : bool
        With ``twin:=true``: whether the twin simulates its LiDAR.
    use_sim_time : bool
        The nodes (and the daemon's stamps) on /clock; ``auto`` is resolved (true with the
        twin).
    """

    twin: bool = False
    world: str = "maze"
    jackson: str = "jackson"
    config: str = ""
    port: str = ""
    i2c: str = ""
    lidar: str = "sllidar"
    twin_lidar: bool = True
    lidar_port: str = "/dev/jackson-lidar"
    slam: bool = False
    map: str = ""
    nav: bool = False
    initial_pose: Pose2D | None = None
    use_sim_time: bool = False
    rviz: bool = False
    daemon_args: tuple[str, ...] = ()
    twin_args: tuple[str, ...] = ()

    @property
    def clock(self) -> str | None:
        """Who publishes /clock: ``twin``, ``mcu`` (the mcu_clock node) or None."""
        if not self.use_sim_time:
            return None
        return "twin" if self.twin else "mcu"

    @property
    def localisation(self) -> str | None:
        """Who publishes map -> odom: ``slam_toolbox``, ``amcl`` or None."""
        if self.slam:
            return "slam_toolbox"
        return "amcl" if self.map else None


def parse_bool(name: str, text: str) -> bool:
    """A launch argument's ``true``/``false`` (also 1/0, yes/no, any case).

    Raises
    ------
    BringupError
        For anything else.
    """
    value = text.strip().lower()
    if value in ("true", "1", "yes"):
        return True
    if value in ("false", "0", "no"):
        return False
    raise BringupError(f"{name}:={text!r}: give true or false")


def parse_pose(name: str, text: str) -> Pose2D | None:
    """``X,Y[,YAW]`` [m, m, rad] as a pose; None for an empty string.

    Raises
    ------
    BringupError
        When the text is not two or three finite numbers.
    """
    if not text.strip():
        return None
    parts = text.replace(" ", "").split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise BringupError(f"{name}:={text!r}: give X,Y or X,Y,YAW in metres and radians")
    return Pose2D(values[0], values[1], values[2] if len(values) == 3 else 0.0)


def parse_options(
    values: Mapping[str, str],
    which: Callable[[str], str | None] = shutil.which,
) -> Options:
    """Check the launch arguments together and type them.

    Parameters
    ----------
    values : mapping of str to str
        Argument name to its value as given (missing ones take their default).
    which : callable
        Finds a command on PATH (:func:`shutil.which`; tests pass their own).

    Returns
    -------
    Options
        The arguments, with ``lidar:=auto`` resolved.

    Raises
    ------
    BringupError
        An unknown argument value, a missing file or command, or arguments that contradict
        each other (both a map and SLAM, Nav2 with neither, the twin with a robot's port).
    """
    args = {a.name: a.default for a in ARGUMENTS}
    args.update(values)
    twin = parse_bool("twin", args["twin"])
    lidar = args["lidar"].strip()
    if lidar not in LIDAR_CHOICES:
        raise BringupError(f"lidar:={lidar!r}: give one of {', '.join(LIDAR_CHOICES)}")
    twin_lidar = True
    if twin:
        if lidar == "sllidar":
            raise BringupError(
                "lidar:=sllidar with twin:=true: the daemon reads the twin's emulated RPLIDAR "
                "(lidar:=auto or host) or the twin has no LiDAR (lidar:=none)"
            )
        for name in ("port", "i2c"):
            if args[name].strip():
                raise BringupError(f"{name}:= is the robot's; twin:=true connects to the twin")
        twin_lidar = lidar != "none"
        lidar = "host" if twin_lidar else "none"
    elif lidar == "auto":
        lidar = "sllidar"
    slam = parse_bool("slam", args["slam"])
    nav = parse_bool("nav", args["nav"])
    map_yaml = args["map"].strip()
    if slam and map_yaml:
        raise BringupError(
            "slam:=true makes a map and map:= localises on one: give one of them, not both"
        )
    if map_yaml and not Path(map_yaml).expanduser().is_file():
        raise BringupError(f"map:={map_yaml}: no such file (a map_server YAML)")
    if nav and not (slam or map_yaml):
        raise BringupError("nav:=true needs a map frame: map:=FILE.yaml (AMCL) or slam:=true")
    sim_time = args["use_sim_time"].strip().lower()
    use_sim_time = twin if sim_time == "auto" else parse_bool("use_sim_time", sim_time)
    if twin and not use_sim_time:
        raise BringupError(
            "use_sim_time:=false: the twin's /ground_truth/odom and the daemon's stamps are on "
            "the twin's /clock, so the nodes must run on it (use_sim_time:=auto or true)"
        )
    initial_pose = parse_pose("initial_pose", args["initial_pose"])
    if initial_pose is not None and not map_yaml:
        raise BringupError("initial_pose:= is AMCL's: it needs map:=FILE.yaml")
    config = args["config"].strip()
    if config and not Path(config).expanduser().is_file():
        raise BringupError(f"config:={config}: no such file (a host YAML)")
    jackson = args["jackson"].strip()
    if which(str(Path(jackson).expanduser())) is None:
        raise BringupError(
            f"jackson:={jackson}: no such command; give the path of the virtual "
            "environment's jackson, e.g. jackson:=$HOME/jackson/.venv/bin/jackson"
        )
    try:
        daemon_args = tuple(shlex.split(args["daemon_args"]))
        twin_args = tuple(shlex.split(args["twin_args"]))
    except ValueError as exc:
        raise BringupError(f"daemon_args / twin_args: {exc}") from exc
    return Options(
        twin=twin,
        world=args["world"].strip(),
        jackson=str(Path(jackson).expanduser()) if "/" in jackson else jackson,
        config=str(Path(config).expanduser()) if config else "",
        port=args["port"].strip(),
        i2c=args["i2c"].strip(),
        lidar=lidar,
        twin_lidar=twin_lidar,
        lidar_port=args["lidar_port"].strip(),
        slam=slam,
        map=str(Path(map_yaml).expanduser().resolve()) if map_yaml else "",
        nav=nav,
        initial_pose=initial_pose,
        use_sim_time=use_sim_time,
        rviz=parse_bool("rviz", args["rviz"]),
        daemon_args=daemon_args,
        twin_args=twin_args,
    )


# ---------------------------------------------------------------------------------- the URDF


Vector3 = tuple[float, float, float]


@dataclass(frozen=True)
class Mounts:
    """The fixed offsets the daemon publishes on /tf_static, x, y, z [m] of each child frame."""

    base_link_m: Vector3
    imu_m: Vector3
    laser_m: Vector3


def _vector(text: str | None, what: str) -> Vector3:
    parts = (text or "0 0 0").split()
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3:
        raise BringupError(f"URDF: {what} must be three numbers, got {text!r}")
    return values[0], values[1], values[2]


def fixed_joint_origin(robot: ET.Element, parent: str, child: str) -> Vector3:
    """The translation of the fixed joint ``parent -> child`` of a URDF.

    Raises
    ------
    BringupError
        When there is no such fixed joint, or it has a rotation (the daemon publishes the
        mounts as translations only).
    """
    for joint in robot.iter("joint"):
        p, c = joint.find("parent"), joint.find("child")
        if p is None or c is None or p.get("link") != parent or c.get("link") != child:
            continue
        if joint.get("type") != "fixed":
            raise BringupError(f"URDF: the joint {parent} -> {child} must be fixed")
        origin = joint.find("origin")
        xyz = _vector(origin.get("xyz") if origin is not None else None, f"{child}'s xyz")
        rpy = _vector(origin.get("rpy") if origin is not None else None, f"{child}'s rpy")
        if any(abs(a) > 1e-12 for a in rpy):
            raise BringupError(
                f"URDF: {parent} -> {child} is rotated (rpy {rpy}); the daemon publishes it "
                "without rotation, so both would disagree on /tf_static"
            )
        return xyz
    raise BringupError(f"URDF: no fixed joint {parent} -> {child}")


def mounts_from_urdf(urdf_xml: str) -> Mounts:
    """The daemon's three mounting offsets, read from the robot description.

    Parameters
    ----------
    urdf_xml : str
        The URDF's text.

    Returns
    -------
    Mounts
        base_footprint -> base_link, base_link -> imu_link and base_link -> laser.

    Raises
    ------
    BringupError
        When the XML does not parse or a joint is missing or rotated.
    """
    try:
        robot = ET.fromstring(urdf_xml)
    except ET.ParseError as exc:
        raise BringupError(f"URDF: {exc}") from exc
    return Mounts(
        base_link_m=fixed_joint_origin(robot, BASE_FOOTPRINT, BASE_LINK),
        imu_m=fixed_joint_origin(robot, BASE_LINK, IMU_LINK),
        laser_m=fixed_joint_origin(robot, BASE_LINK, LASER),
    )


# ---------------------------------------------------------------------------------- processes


@dataclass(frozen=True)
class TwinPorts:
    """Where the twin puts its MCU serial port, its I2C socket and its RPLIDAR's port."""

    serial: Path
    i2c: Path
    lidar: Path

    @classmethod
    def in_folder(cls, folder: Path) -> TwinPorts:
        """The twin's serial link, I2C socket and LiDAR link inside ``folder``."""
        return cls(serial=folder / "mcu", i2c=folder / "i2c.sock", lidar=folder / "lidar")


def twin_command(opts: Options, ports: TwinPorts) -> list[str]:
    """``jackson sim``: the twin in real time (Nav2 and RViz run on the wall clock's pace),
    publishing /clock, /ground_truth/odom and /twin/scan; its RPLIDAR's port at
    ``ports.lidar`` for the daemon."""
    cmd = [opts.jackson, "sim", "--ros", "--realtime", "--world", opts.world]
    cmd += ["--link", str(ports.serial), "--i2c", str(ports.i2c)]
    if opts.twin_lidar:
        cmd += ["--lidar-link", str(ports.lidar)]
    else:
        cmd.append("--no-lidar")
    return cmd + list(opts.twin_args)


def _ros_list(v: Vector3) -> str:
    return "[" + ", ".join(repr(float(c)) for c in v) + "]"


def daemon_command(opts: Options, mounts: Mounts, ports: TwinPorts | None = None) -> list[str]:
    """``jackson daemon --ros``, its mounting offsets those of the URDF, stamping with MCU
    time itself when the nodes run on /clock (``use_sim_time``), else with MCU time mapped onto
    the system clock.

    Parameters
    ----------
    opts : Options
        The launch arguments.
    mounts : Mounts
        From :func:`mounts_from_urdf`: the daemon's offsets (its bag's /tf_static) are the
        URDF's; live, robot_state_publisher alone publishes them.
    ports : TwinPorts, optional
        The twin's ports (``twin:=true``); else the robot's from ``port:=``/``i2c:=`` or the
        host configuration.

    Returns
    -------
    list of str
        The command line.
    """
    cmd = [opts.jackson, "daemon"]
    if opts.config:
        cmd += ["--config", opts.config]
    if ports is not None:
        cmd += ["--port", str(ports.serial), "--i2c", f"unix:{ports.i2c}"]
    else:
        cmd += ["--port", opts.port] if opts.port else []
        cmd += ["--i2c", opts.i2c] if opts.i2c else []
    if opts.lidar == "host":
        cmd += ["--lidar", str(ports.lidar) if ports is not None else opts.lidar_port]
    cmd += list(opts.daemon_args)
    cmd += ["--ros", "--ros-args"]
    if opts.use_sim_time:  # stamp with MCU time itself, the clock of /clock
        cmd += ["-p", "use_sim_time:=true"]
    for name, value in (
        ("base_link_offset_m", mounts.base_link_m),
        ("imu_offset_m", mounts.imu_m),
        ("laser_offset_m", mounts.laser_m),
    ):
        cmd += ["-p", f"{name}:={_ros_list(value)}"]
    # robot_state_publisher turns /joint_states into the wheels' transforms and publishes the
    # URDF's fixed joints on /tf_static: one publisher per transform
    cmd += ["-p", "publish_wheel_tf:=false", "-p", "publish_static_tf:=false"]
    return cmd


def sllidar_parameters(opts: Options) -> dict[str, Any]:
    """sllidar_ros2's parameters for the A1M8 on ``lidar_port``, in its own frame
    (:data:`SLLIDAR_FRAME`, a child of ``laser`` in the URDF)."""
    return {
        "channel_type": "serial",
        "serial_port": opts.lidar_port,
        "serial_baudrate": A1_BAUDRATE,
        "frame_id": SLLIDAR_FRAME,
        "inverted": False,
        "angle_compensate": True,
        "use_sim_time": opts.use_sim_time,
    }


def nav2_parameters(params: Mapping[str, Any], initial_pose: Pose2D | None) -> dict[str, Any]:
    """Nav2's parameter file with AMCL's initial pose set (a copy; ``params`` is unchanged).

    Parameters
    ----------
    params : mapping
        The parameter file as loaded YAML (``config/nav2.yaml``).
    initial_pose : Pose2D or None
        AMCL's ``initial_pose`` on the map; None leaves the file as it is (the pose then
        comes from RViz's 2D Pose Estimate).

    Returns
    -------
    dict
        The parameters to write to a file for Nav2's launch files.
    """
    out = copy.deepcopy(dict(params))
    if initial_pose is not None:
        amcl = out.setdefault("amcl", {}).setdefault("ros__parameters", {})
        amcl["set_initial_pose"] = True
        amcl["initial_pose"] = {
            "x": initial_pose.x_m,
            "y": initial_pose.y_m,
            "z": 0.0,
            "yaw": initial_pose.yaw_rad,
        }
    return out


def twin_ready(text: str) -> bool:
    """Whether a chunk of ``jackson sim``'s output says its ports are open."""
    return TWIN_READY in text
