"""The ROS 2 package ros2/jackson_bringup: its manifest, URDF, launch file and parameter files
agree with the host daemon, the host configuration and the paper.

Without a ROS installation (``launch``, ``robot_state_publisher``, Nav2 are not on PyPI) the
URDF is checked with ``xml.etree`` (and ``urdf_parser_py`` where it is installed), the launch
file by its structure and by :mod:`jackson_bringup.bringup`, the pure module it delegates to;
where ``launch`` and ``launch_ros`` import, ``generate_launch_description()`` runs too. The
command lines the launch file starts are parsed by the real ``jackson`` argument parser, and
``mcu_clock`` runs under rclpy where rclpy imports (the ``ros`` extra on x86_64).
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import math
import platform
import sys
import time
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from jackson.host.config import DEFAULT_CONFIG, load_config
from jackson.host.control.navigator import NavigatorConfig
from jackson.host.nav.amcl import AmclConfig
from jackson.host.nav.astar import AStarConfig
from jackson.host.nav.costmap import ENVELOPE_X_M, ENVELOPE_Y_M, CostmapConfig
from jackson.host.nav.dwb import CRITICS, DwbConfig
from jackson.host.nav.slam.mapper import MappingConfig
from jackson.host.ros.names import FRAMES, TOPICS
from jackson.main import build_parser

from .conftest import private_ros_env

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "ros2" / "jackson_bringup"
URDF = PKG / "urdf" / "jackson.urdf"
LAUNCH = PKG / "launch" / "bringup.launch.py"
NAV2 = PKG / "config" / "nav2.yaml"
SLAM = PKG / "config" / "slam_toolbox.yaml"
DOCS = ROOT / "docs" / "ros2.md"


def _package() -> None:
    """Import jackson_bringup from its source folder (not the folder itself on sys.path, where
    its launch/ would pass for ROS's ``launch``)."""
    if "jackson_bringup" in sys.modules:
        return
    folder = PKG / "jackson_bringup"
    spec = importlib.util.spec_from_file_location(
        "jackson_bringup", folder / "__init__.py", submodule_search_locations=[str(folder)]
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["jackson_bringup"] = module
    spec.loader.exec_module(module)


_package()
bringup: Any = importlib.import_module("jackson_bringup.bringup")
mcu_clock: Any = importlib.import_module("jackson_bringup.mcu_clock")

CFG = load_config(DEFAULT_CONFIG)
R_M = CFG.robot.wheel_radius_left_m  # 0.033
B_M = CFG.robot.wheel_separation_m  # 0.198
PAPER_ROBOT_RADIUS_M = 0.16
PAPER_INFLATION_RADIUS_M = 0.25
PAPER_COST_SCALING = 10.0
PAPER_MIN_ANGULAR_RAD_S = 0.30
PAPER_XY_GOAL_TOLERANCE_M = 0.25
PAPER_LIDAR_CAP_M = 8.0
PAPER_SLAM_TF_PERIOD_S = 0.1  # map -> odom at 10 Hz (Sec. 2.3.2)


def _bridge_defaults() -> Any:
    """The daemon's ROS parameters with the host configuration's values."""
    try:
        from jackson.host.ros.messages import RosSettings

        return RosSettings.for_config(CFG)
    except ImportError:  # an older layout: the parameters beside the node
        from jackson.host.ros.bridge import BridgeParameters

        return BridgeParameters(base_link_offset_m=(0.0, 0.0, R_M))


def _floats(text: str | None) -> tuple[float, ...]:
    return tuple(float(v) for v in (text or "0 0 0").split())


def _robot() -> ET.Element:
    return ET.parse(URDF).getroot()


def _joints() -> dict[str, ET.Element]:
    return {j.get("name", ""): j for j in _robot().iter("joint")}


def _origin(joint: ET.Element) -> tuple[tuple[float, ...], tuple[float, ...]]:
    o = joint.find("origin")
    return _floats(o.get("xyz") if o is not None else None), _floats(
        o.get("rpy") if o is not None else None
    )


def _link_geometry(name: str, tag: str) -> ET.Element:
    link = next(link for link in _robot().iter("link") if link.get("name") == name)
    geometry = link.find("collision/geometry")
    assert geometry is not None, f"{name} has no collision geometry"
    shape = geometry.find(tag)
    assert shape is not None, f"{name}'s collision is not a {tag}"
    return shape


def _nav2() -> dict[str, Any]:
    out: dict[str, Any] = yaml.safe_load(NAV2.read_text(encoding="utf-8"))
    return out


def _params(node: str) -> dict[str, Any]:
    p = _nav2()[node]
    p = p.get(node, p)  # the costmaps nest their node name
    out: dict[str, Any] = p["ros__parameters"]
    return out


def _options(**values: str) -> Any:
    return bringup.parse_options(values, which=lambda cmd: "/usr/bin/" + cmd)


# ---------------------------------------------------------------------------------- package.xml


def _manifest() -> ET.Element:
    return ET.parse(PKG / "package.xml").getroot()


def _exec_depends() -> set[str]:
    return {e.text or "" for e in _manifest().iter("exec_depend")}


def test_package_xml_is_format_3_with_the_required_fields() -> None:
    root = _manifest()
    assert root.tag == "package" and root.get("format") == "3"
    assert root.findtext("name") == "jackson_bringup"
    assert (root.findtext("version") or "").count(".") == 2
    assert (root.findtext("description") or "").strip()
    maintainer = root.find("maintainer")
    assert maintainer is not None and "@" in maintainer.get("email", "")
    assert root.findtext("license") == "MIT"
    assert root.findtext("export/build_type") == "ament_python"
    assert {
        "robot_state_publisher",
        "slam_toolbox",
        "nav2_bringup",
        "sllidar_ros2",
        "rclpy",
        "launch",
        "launch_ros",
    } <= _exec_depends()


def test_setup_installs_the_package_files_and_mcu_clock() -> None:
    assert (PKG / "resource" / "jackson_bringup").is_file()
    setup_py = (PKG / "setup.py").read_text(encoding="utf-8")
    for pattern in ('"launch/*.launch.py"', '"urdf/*.urdf"', '"config/*.yaml"', "package.xml"):
        assert pattern in setup_py
    assert "mcu_clock = {PACKAGE}.mcu_clock:main" in setup_py
    assert 'PACKAGE = "jackson_bringup"' in setup_py
    assert "script_dir=$base/lib/jackson_bringup" in (PKG / "setup.cfg").read_text()


def test_the_ros_package_is_no_part_of_the_jackson_distribution() -> None:
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert "jackson_bringup" not in pyproject and '"ros2' not in pyproject


# ---------------------------------------------------------------------------------- the URDF


def test_urdf_is_one_tree_rooted_at_base_footprint() -> None:
    robot = _robot()
    assert robot.tag == "robot"
    links = [link.get("name") for link in robot.iter("link")]
    assert len(links) == len(set(links))
    parent_of: dict[str, str] = {}
    for joint in robot.iter("joint"):
        parent = joint.find("parent")
        child = joint.find("child")
        assert parent is not None and child is not None
        p, c = parent.get("link"), child.get("link")
        assert p in links and c in links, f"joint {joint.get('name')}: {p} -> {c}"
        assert c not in parent_of, f"{c} has two parents"
        parent_of[str(c)] = str(p)
    roots = [link for link in links if link not in parent_of]
    assert roots == [FRAMES.base_footprint]
    for link in links:  # every link reaches the root: no cycle
        seen = set()
        while link in parent_of:
            assert link not in seen
            seen.add(link)
            link = parent_of[str(link)]
        assert link == FRAMES.base_footprint
    for frame in (FRAMES.base_link, FRAMES.imu_link, FRAMES.laser):
        assert frame in links
    assert {"left_wheel_link", "right_wheel_link", "caster_link"} <= set(links)


def test_urdf_mounts_equal_the_daemons() -> None:
    joints = {
        (j.find("parent").get("link"), j.find("child").get("link")): j  # type: ignore[union-attr]
        for j in _robot().iter("joint")
    }
    defaults = _bridge_defaults()
    for parent, child, expected in (
        (FRAMES.base_footprint, FRAMES.base_link, defaults.base_link_offset_m),
        (FRAMES.base_link, FRAMES.imu_link, defaults.imu_offset_m),
        (FRAMES.base_link, FRAMES.laser, defaults.laser_offset_m),
    ):
        joint = joints[(parent, child)]
        assert joint.get("type") == "fixed"
        xyz, rpy = _origin(joint)
        assert xyz == pytest.approx(expected, abs=1e-12), f"{parent} -> {child}"
        assert rpy == (0.0, 0.0, 0.0)
    assert defaults.base_link_offset_m == pytest.approx((0.0, 0.0, R_M))
    mounts = bringup.mounts_from_urdf(URDF.read_text(encoding="utf-8"))
    assert mounts.base_link_m == pytest.approx((0.0, 0.0, R_M))
    assert mounts.imu_m == pytest.approx(defaults.imu_offset_m)
    assert mounts.laser_m == pytest.approx(defaults.laser_offset_m)


@pytest.mark.parametrize(
    ("name", "side"), [(FRAMES.left_wheel_joint, 1.0), (FRAMES.right_wheel_joint, -1.0)]
)
def test_wheel_joints_are_continuous_at_half_the_track(name: str, side: float) -> None:
    joint = _joints()[name]
    assert joint.get("type") == "continuous"
    assert joint.find("parent").get("link") == FRAMES.base_link  # type: ignore[union-attr]
    child = joint.find("child").get("link")  # type: ignore[union-attr]
    assert child == name.replace("_joint", "_link")
    xyz, rpy = _origin(joint)
    assert xyz == pytest.approx((0.0, side * B_M / 2.0, 0.0))  # on the axle, base_link's height
    assert rpy == (0.0, 0.0, 0.0)
    assert _floats(joint.find("axis").get("xyz")) == (0.0, 1.0, 0.0)  # type: ignore[union-attr]
    wheel = _link_geometry(str(child), "cylinder")
    assert float(wheel.get("radius", "nan")) == pytest.approx(R_M)


def test_chassis_is_the_papers_envelope_and_the_caster_touches_the_floor() -> None:
    box = _link_geometry(FRAMES.base_link, "box")
    sx, sy, _ = _floats(box.get("size"))
    assert sx == pytest.approx(ENVELOPE_X_M[1] - ENVELOPE_X_M[0])
    assert sy == pytest.approx(ENVELOPE_Y_M[1] - ENVELOPE_Y_M[0])
    link = next(lk for lk in _robot().iter("link") if lk.get("name") == FRAMES.base_link)
    cx, cy, _ = _floats(link.find("collision/origin").get("xyz"))  # type: ignore[union-attr]
    assert cx == pytest.approx(sum(ENVELOPE_X_M) / 2.0)
    assert cy == pytest.approx(sum(ENVELOPE_Y_M) / 2.0)
    caster_xyz, _ = _origin(_joints()["caster_joint"])
    ball = _link_geometry("caster_link", "sphere")
    assert R_M + caster_xyz[2] - float(ball.get("radius", "nan")) == pytest.approx(0.0, abs=1e-12)
    assert caster_xyz[0] < 0.0  # at the back


def test_sllidar_frame_is_laser_turned_by_pi() -> None:
    joint = _joints()["laser_sllidar_joint"]
    assert joint.find("parent").get("link") == FRAMES.laser  # type: ignore[union-attr]
    assert joint.find("child").get("link") == bringup.SLLIDAR_FRAME  # type: ignore[union-attr]
    xyz, rpy = _origin(joint)
    assert xyz == (0.0, 0.0, 0.0) and rpy == pytest.approx((0.0, 0.0, math.pi))


def test_urdf_parses_with_urdf_parser_py() -> None:
    from urdf_parser_py import urdf

    robot = urdf.URDF.from_xml_string(URDF.read_bytes())
    assert robot.get_root() == FRAMES.base_footprint
    assert {FRAMES.left_wheel_joint, FRAMES.right_wheel_joint} <= set(robot.joint_map)


def test_urdf_has_what_a_physics_simulator_needs() -> None:
    """Gazebo (sdformat's URDF import) drops a link without an inertial and with it its
    geometry: every link that has geometry has collision geometry and a physical inertia
    (mass > 0, a positive-definite tensor whose principal moments satisfy the triangle
    inequality); the root has none (KDL warns of a root inertia); the masses add up to the
    twin's 2.0 kg and the chassis turns like it about z (0.021 kg m^2)."""
    from urdf_parser_py import urdf

    robot = urdf.URDF.from_xml_string(URDF.read_bytes())
    assert robot.link_map[robot.get_root()].inertial is None
    total = 0.0
    for link in robot.links:
        if link.visual is None:
            continue
        assert link.collision is not None, link.name
        inertial = link.inertial
        assert inertial is not None and inertial.mass > 0.0, link.name
        i = inertial.inertia
        tensor = np.array(
            [[i.ixx, i.ixy, i.ixz], [i.ixy, i.iyy, i.iyz], [i.ixz, i.iyz, i.izz]], np.float64
        )
        moments = np.linalg.eigvalsh(tensor)
        assert moments.min() > 0.0, link.name
        assert moments.max() <= moments.sum() - moments.max() + 1e-12, link.name
        total += inertial.mass
    assert total == pytest.approx(2.0)
    chassis = robot.link_map[FRAMES.base_link].inertial.inertia
    assert chassis.izz == pytest.approx(0.021, rel=0.05)


def test_mounts_refuse_a_rotated_or_missing_joint() -> None:
    text = URDF.read_text(encoding="utf-8")
    rotated = text.replace(
        '<child link="laser"/>\n    <origin xyz="0 0 0" rpy="0 0 0"/>',
        '<child link="laser"/>\n    <origin xyz="0 0 0" rpy="0 0 3.14159"/>',
    )
    assert rotated != text
    with pytest.raises(bringup.BringupError, match="rotated"):
        bringup.mounts_from_urdf(rotated)
    with pytest.raises(bringup.BringupError, match="no fixed joint base_link -> imu_link"):
        bringup.mounts_from_urdf(text.replace('<child link="imu_link"/>', '<child link="x"/>'))
    with pytest.raises(bringup.BringupError, match="URDF"):
        bringup.mounts_from_urdf("<robot>")


# ---------------------------------------------------------------------------------- the launch


def _launch_calls() -> Iterator[tuple[str, dict[str, Any], list[Any]]]:
    """(callee, constant keyword arguments, constant positional arguments) of every call."""
    tree = ast.parse(LAUNCH.read_text(encoding="utf-8"), str(LAUNCH))
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            kwargs = {
                k.arg: k.value.value
                for k in node.keywords
                if k.arg and isinstance(k.value, ast.Constant)
            }
            args = [a.value for a in node.args if isinstance(a, ast.Constant)]
            yield node.func.id, kwargs, args


def test_launch_file_defines_its_description_from_the_arguments() -> None:
    tree = ast.parse(LAUNCH.read_text(encoding="utf-8"), str(LAUNCH))
    functions = {f.name for f in tree.body if isinstance(f, ast.FunctionDef)}
    assert {"generate_launch_description", "launch_setup"} <= functions
    calls = list(_launch_calls())
    assert any(name == "OpaqueFunction" for name, _, _ in calls)
    assert any(name == "DeclareLaunchArgument" for name, _, _ in calls)
    names = [a.name for a in bringup.ARGUMENTS]
    assert len(names) == len(set(names))
    assert {"twin", "use_sim_time", "lidar", "slam", "map", "nav", "rviz"} <= set(names)


def test_every_ros_package_the_launch_starts_is_a_dependency() -> None:
    calls = list(_launch_calls())
    nodes = {(kw["package"], kw["executable"]) for name, kw, _ in calls if name == "Node"}
    assert nodes == {
        ("robot_state_publisher", "robot_state_publisher"),
        ("jackson_bringup", "mcu_clock"),
        ("sllidar_ros2", "sllidar_node"),
        ("rviz2", "rviz2"),
    }
    shared = {args[0] for name, _, args in calls if name == "share" and args}
    assert shared == {
        "robot_state_publisher",
        "jackson_bringup",
        "sllidar_ros2",
        "slam_toolbox",
        "nav2_bringup",
        "rviz2",
    }
    assert (shared - {"jackson_bringup"}) <= _exec_depends()
    text = LAUNCH.read_text(encoding="utf-8")
    for included in ("online_async_launch.py", "localization_launch.py", "navigation_launch.py"):
        assert f'"{included}"' in text


def test_generate_launch_description_declares_every_argument() -> None:
    pytest.importorskip("launch")
    pytest.importorskip("launch_ros")
    spec = importlib.util.spec_from_file_location("jackson_bringup_launch", LAUNCH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    declared = [a.name for a in description.get_launch_arguments()]
    assert declared == [a.name for a in bringup.ARGUMENTS]


# ---------------------------------------------------------------------------------- what it starts


def test_robot_defaults_drive_the_daemon_with_sllidar_on_the_system_clock() -> None:
    opts = _options()
    assert (opts.twin, opts.lidar, opts.use_sim_time, opts.clock) == (False, "sllidar", False, None)
    mounts = bringup.mounts_from_urdf(URDF.read_text(encoding="utf-8"))
    cmd = bringup.daemon_command(opts, mounts)
    assert cmd[:2] == ["jackson", "daemon"]
    assert "use_sim_time:=true" not in cmd
    args = build_parser().parse_args(cmd[1:])
    assert args.ros and args.lidar is None and args.port is None
    assert args.ros_args == [
        "-p",
        "base_link_offset_m:=[0.0, 0.0, 0.033]",
        "-p",
        "imu_offset_m:=[0.0, 0.0, 0.0]",
        "-p",
        "laser_offset_m:=[0.0, 0.0, 0.0]",
        "-p",
        "publish_wheel_tf:=false",  # robot_state_publisher's
        "-p",
        "publish_static_tf:=false",  # robot_state_publisher's: one publisher per transform
    ]
    params = bringup.sllidar_parameters(opts)
    assert params["frame_id"] == bringup.SLLIDAR_FRAME
    assert params["serial_port"] == "/dev/jackson-lidar"
    assert params["serial_baudrate"] == 115200 and params["use_sim_time"] is False


def test_host_lidar_port_and_extra_daemon_arguments_reach_jackson_daemon(tmp_path: Path) -> None:
    config = tmp_path / "robot.yaml"
    config.write_text("robot: {}\n")
    opts = _options(
        lidar="host",
        lidar_port="/dev/ttyUSB3",
        port="/dev/ttyACM1",
        i2c="/dev/i2c-1",
        config=str(config),
        daemon_args="--no-record --max-seconds 60",
        use_sim_time="true",
    )
    assert opts.clock == "mcu"
    cmd = bringup.daemon_command(opts, bringup.Mounts((0, 0, 0.033), (0.01, 0, 0.05), (0, 0, 0)))
    args = build_parser().parse_args(cmd[1:])
    assert (args.lidar, args.port, args.i2c, args.config) == (
        "/dev/ttyUSB3",
        "/dev/ttyACM1",
        "/dev/i2c-1",
        config,
    )
    assert args.no_record and args.max_seconds == 60.0 and args.ros
    assert args.ros_args[:2] == ["-p", "use_sim_time:=true"]
    assert "imu_offset_m:=[0.01, 0.0, 0.05]" in args.ros_args


def test_twin_runs_on_its_clock_and_the_daemon_on_its_ports(tmp_path: Path) -> None:
    opts = _options(twin="true", world="square_room", twin_args="--seed 3")
    assert (opts.lidar, opts.twin_lidar, opts.use_sim_time, opts.clock) == (
        "host",  # the daemon reads the twin's emulated RPLIDAR, as on the robot
        True,
        True,
        "twin",
    )
    ports = bringup.TwinPorts.in_folder(tmp_path)
    twin = bringup.twin_command(opts, ports)
    targs = build_parser().parse_args(twin[1:])
    assert targs.ros and targs.realtime and not targs.no_lidar and targs.seed == 3
    assert (targs.world, targs.link, targs.i2c) == ("square_room", str(ports.serial), ports.i2c)
    mounts = bringup.mounts_from_urdf(URDF.read_text(encoding="utf-8"))
    dargs = build_parser().parse_args(bringup.daemon_command(opts, mounts, ports)[1:])
    assert (dargs.port, dargs.i2c) == (str(ports.serial), f"unix:{ports.i2c}")
    assert targs.lidar_link == str(ports.lidar) and dargs.lidar == str(ports.lidar)
    assert dargs.ros_args[:2] == ["-p", "use_sim_time:=true"]  # stamps = the twin's /clock
    no_lidar = _options(twin="true", lidar="none")
    assert "--no-lidar" in bringup.twin_command(no_lidar, ports)
    assert bringup.twin_ready("twin: world maze, robot jackson, real time; waiting for HELLO\n")
    assert not bringup.twin_ready("serial: /dev/pts/3\n")


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"lidar": "rplidar"}, "lidar:='rplidar': give one of auto, sllidar, host, none"),
        ({"twin": "true", "lidar": "sllidar"}, "the daemon reads the twin's emulated RPLIDAR"),
        ({"twin": "true", "port": "/dev/ttyACM0"}, "port:= is the robot's"),
        ({"twin": "true", "use_sim_time": "false"}, "must run on it"),
        ({"slam": "yes", "map": "maze.yaml"}, "not both"),
        ({"nav": "true"}, "nav:=true needs a map frame"),
        ({"map": "/nonexistent/maze.yaml"}, "no such file"),
        ({"slam": "true", "initial_pose": "0,0,0"}, "initial_pose:= is AMCL's"),
        ({"initial_pose": "1,two"}, "X,Y or X,Y,YAW"),
        ({"rviz": "maybe"}, "rviz:='maybe': give true or false"),
        ({"config": "/nonexistent/jackson.yaml"}, "config:=/nonexistent/jackson.yaml: no such"),
        ({"daemon_args": "--run-dir 'unclosed"}, "daemon_args / twin_args"),
    ],
)
def test_arguments_that_cannot_work_are_one_line_errors(
    values: dict[str, str], message: str
) -> None:
    with pytest.raises(bringup.BringupError) as info:
        _options(**values)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_a_missing_jackson_command_is_named() -> None:
    with pytest.raises(bringup.BringupError, match="jackson:=jackson: no such command"):
        bringup.parse_options({}, which=lambda cmd: None)


def test_map_and_initial_pose_reach_amcl(tmp_path: Path) -> None:
    map_yaml = tmp_path / "maze.yaml"
    map_yaml.write_text("image: maze.pgm\n")
    opts = _options(map=str(map_yaml), nav="true", initial_pose="-0.6909,-0.0364,0")
    assert opts.localisation == "amcl" and opts.map == str(map_yaml.resolve())
    base = _nav2()
    params = bringup.nav2_parameters(base, opts.initial_pose)
    amcl = params["amcl"]["ros__parameters"]
    assert amcl["set_initial_pose"] is True
    assert amcl["initial_pose"] == {"x": -0.6909, "y": -0.0364, "z": 0.0, "yaw": 0.0}
    assert base["amcl"]["ros__parameters"]["set_initial_pose"] is False  # a copy
    assert bringup.nav2_parameters(base, None) == base
    assert _options(slam="true", nav="true").localisation == "slam_toolbox"


# ---------------------------------------------------------------------------------- parameters


def test_nav2_frames_and_topics_are_the_bridges() -> None:
    amcl = _params("amcl")
    assert (amcl["global_frame_id"], amcl["odom_frame_id"], amcl["base_frame_id"]) == (
        "map",
        FRAMES.odom,
        FRAMES.base_footprint,
    )
    assert _params("bt_navigator")["odom_topic"] == TOPICS.filtered
    assert _params("velocity_smoother")["odom_topic"] == TOPICS.filtered
    assert _params("local_costmap")["global_frame"] == FRAMES.odom
    assert _params("global_costmap")["global_frame"] == "map"
    for node in ("bt_navigator", "local_costmap", "global_costmap", "behavior_server"):
        assert _params(node)["robot_base_frame"] == FRAMES.base_footprint
    cm = _params("collision_monitor")
    assert (cm["base_frame_id"], cm["odom_frame_id"]) == (FRAMES.base_footprint, FRAMES.odom)
    assert cm["cmd_vel_out_topic"] == "cmd_vel"
    for costmap in ("local_costmap", "global_costmap"):
        assert _params(costmap)["obstacle_layer"]["scan"]["topic"] == "/scan"


def test_nav2_costmaps_are_the_papers() -> None:
    host = CostmapConfig()
    assert host.robot_radius_m == PAPER_ROBOT_RADIUS_M
    assert host.inflation_radius_m == PAPER_INFLATION_RADIUS_M
    assert host.cost_scaling_factor == PAPER_COST_SCALING
    nav = NavigatorConfig()
    for name in ("local_costmap", "global_costmap"):
        p = _params(name)
        assert p["robot_radius"] == PAPER_ROBOT_RADIUS_M
        assert p["resolution"] == nav.local_resolution_m == 0.05
        inflation = p["inflation_layer"]
        assert inflation["inflation_radius"] == PAPER_INFLATION_RADIUS_M
        assert inflation["cost_scaling_factor"] == PAPER_COST_SCALING
        scan = p["obstacle_layer"]["scan"]
        assert scan["obstacle_max_range"] == host.obstacle_max_range_m
        assert scan["raytrace_max_range"] == host.raytrace_max_range_m
    local = _params("local_costmap")
    assert local["width"] == local["height"] == nav.local_size_m and local["rolling_window"]
    assert _params("global_costmap")["track_unknown_space"] is nav.global_track_unknown_space


def test_dwb_speeds_accelerations_and_critics_are_the_daemons() -> None:
    limits, dwb = CFG.limits, DwbConfig()
    p = _params("controller_server")
    f = p["FollowPath"]
    assert f["plugin"] == "dwb_core::DWBLocalPlanner"
    assert p["controller_frequency"] == dwb.controller_frequency_hz
    assert f["max_vel_x"] == f["max_speed_xy"] == limits.max_v_m_s
    assert f["max_vel_theta"] == limits.max_w_rad_s
    assert f["min_vel_x"] == dwb.min_vel_x_m_s
    assert f["min_speed_theta"] == dwb.min_speed_theta_rad_s == PAPER_MIN_ANGULAR_RAD_S
    assert f["acc_lim_x"] == limits.max_accel_m_s2
    assert f["decel_lim_x"] == -limits.max_decel_m_s2
    assert f["acc_lim_theta"] == limits.max_alpha_rad_s2
    assert f["decel_lim_theta"] == -limits.max_alpha_decel_rad_s2
    assert f["max_vel_y"] == f["acc_lim_y"] == 0.0
    assert (f["vx_samples"], f["vtheta_samples"]) == (dwb.vx_samples, dwb.vtheta_samples)
    assert f["sim_time"] == dwb.sim_time_s
    assert f["linear_granularity"] == dwb.linear_granularity_m
    assert f["angular_granularity"] == dwb.angular_granularity_rad
    nav = NavigatorConfig()
    assert dwb.xy_goal_tolerance_m == PAPER_XY_GOAL_TOLERANCE_M == nav.xy_goal_tolerance_m
    # the navigator hands DWB its goal window: the tolerance less the margin it aims inside
    assert f["xy_goal_tolerance"] == pytest.approx(nav.xy_goal_tolerance_m - nav.goal_margin_m)
    assert f["trans_stopped_velocity"] == dwb.trans_stopped_velocity_m_s
    assert f["prune_distance"] == dwb.prune_distance_m
    assert f["forward_prune_distance"] == dwb.forward_prune_distance_m
    assert f["short_circuit_trajectory_evaluation"] == dwb.short_circuit_trajectory_evaluation
    assert tuple(f["critics"]) == CRITICS
    assert f["RotateToGoal.scale"] == dwb.rotate_to_goal_scale
    assert f["RotateToGoal.slowing_factor"] == dwb.rotate_to_goal_slowing_factor
    assert f["Oscillation.scale"] == dwb.oscillation_scale
    assert f["Oscillation.oscillation_reset_dist"] == dwb.oscillation_reset_dist_m
    assert f["Oscillation.oscillation_reset_angle"] == dwb.oscillation_reset_angle_rad
    assert f["Oscillation.x_only_threshold"] == dwb.oscillation_x_only_threshold_m_s
    assert f["BaseObstacle.scale"] == dwb.base_obstacle_scale
    assert f["GoalAlign.scale"] == dwb.goal_align_scale
    assert f["GoalAlign.forward_point_distance"] == dwb.goal_align_forward_point_distance_m
    assert f["PathAlign.scale"] == dwb.path_align_scale
    assert f["PathAlign.forward_point_distance"] == dwb.path_align_forward_point_distance_m
    assert f["PathDist.scale"] == dwb.path_dist_scale
    assert f["GoalDist.scale"] == dwb.goal_dist_scale
    vs = _params("velocity_smoother")
    assert vs["max_velocity"] == [limits.max_v_m_s, 0.0, limits.max_w_rad_s]
    assert vs["min_velocity"] == [-limits.max_v_m_s, 0.0, -limits.max_w_rad_s]
    assert vs["max_accel"] == [limits.max_accel_m_s2, 0.0, limits.max_alpha_rad_s2]
    assert vs["max_decel"] == [-limits.max_decel_m_s2, 0.0, -limits.max_alpha_decel_rad_s2]


def test_checkers_planner_and_recoveries_are_the_navigators() -> None:
    nav, p = NavigatorConfig(), _params("controller_server")
    assert p["failure_tolerance"] == nav.controller_failure_tolerance_s
    progress = p["progress_checker"]
    assert progress["required_movement_radius"] == nav.progress_radius_m
    assert progress["movement_time_allowance"] == nav.progress_time_s
    goal = p["general_goal_checker"]
    assert nav.xy_goal_tolerance_m == PAPER_XY_GOAL_TOLERANCE_M
    assert goal["xy_goal_tolerance"] == pytest.approx(nav.xy_goal_tolerance_m - nav.goal_margin_m)
    assert nav.yaw_goal_tolerance_rad is None and goal["yaw_goal_tolerance"] > math.pi
    grid = _params("planner_server")["GridBased"]
    assert grid["use_astar"] is True and grid["tolerance"] == AStarConfig().goal_tolerance_m
    behaviours = _params("behavior_server")
    assert behaviours["min_rotational_vel"] == nav.spin_min_rad_s == PAPER_MIN_ANGULAR_RAD_S
    assert behaviours["max_rotational_vel"] == nav.spin_max_rad_s
    assert behaviours["rotational_acc_lim"] == CFG.limits.max_alpha_rad_s2
    assert behaviours["simulate_ahead_time"] == nav.simulate_ahead_time_s
    assert _params("docking_server")["dock_plugins"]  # Jazzy's docking server needs one


def test_amcl_is_the_hosts_particle_filter() -> None:
    host, amcl = AmclConfig(), _params("amcl")
    for name in (
        "min_particles",
        "max_particles",
        "alpha1",
        "alpha2",
        "alpha3",
        "alpha4",
        "z_hit",
        "z_rand",
        "sigma_hit",
        "laser_likelihood_max_dist",
        "max_beams",
        "laser_min_range",
        "laser_max_range",
        "update_min_d",
        "update_min_a",
        "resample_interval",
        "pf_err",
        "pf_z",
        "recovery_alpha_slow",
        "recovery_alpha_fast",
    ):
        assert amcl[name] == getattr(host, name), name
    assert amcl["laser_max_range"] == PAPER_LIDAR_CAP_M
    assert amcl["laser_model_type"] == "likelihood_field"
    assert amcl["robot_model_type"] == "nav2_amcl::DifferentialMotionModel"


def test_slam_toolbox_maps_as_the_paper_and_the_hosts_mapper() -> None:
    doc = yaml.safe_load(SLAM.read_text(encoding="utf-8"))
    p = doc["slam_toolbox"]["ros__parameters"]
    mapper = MappingConfig()
    assert (p["map_frame"], p["odom_frame"], p["base_frame"]) == (
        "map",
        FRAMES.odom,
        FRAMES.base_footprint,
    )
    assert p["scan_topic"] == "/scan" and p["mode"] == "mapping"
    assert p["resolution"] == mapper.resolution_m
    assert p["minimum_travel_distance"] == mapper.min_travel_m
    assert p["minimum_travel_heading"] == mapper.min_heading_rad
    assert p["max_laser_range"] == PAPER_LIDAR_CAP_M
    assert p["transform_publish_period"] == PAPER_SLAM_TF_PERIOD_S


# ---------------------------------------------------------------------------------- mcu_clock


def test_mcu_clock_advances_drops_repeats_and_follows_a_restart() -> None:
    s = 1_000_000_000
    assert mcu_clock.next_clock_ns(None, 5 * s, s) == 5 * s
    assert mcu_clock.next_clock_ns(5 * s, 5 * s + 50_000_000, s) == 5 * s + 50_000_000
    assert mcu_clock.next_clock_ns(5 * s, 5 * s, s) is None  # repeated
    assert mcu_clock.next_clock_ns(5 * s, 4 * s + 950_000_000, s) is None  # reordered
    assert mcu_clock.next_clock_ns(5 * s, 1 * s, s) == 1 * s  # a new MCU clock


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """A private ROS domain on the loopback interface (as tests/ros/test_bridge.py)."""
    private_ros_env(monkeypatch, tmp_path, 1, 100)


@pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")
@pytest.mark.usefixtures("ros_domain")
def test_mcu_clock_publishes_joint_state_stamps_on_clock() -> None:
    """The node under rclpy: /joint_states in (reliable, as the daemon publishes them), /clock
    out (best effort, as rclpy's time source subscribes), repeats dropped."""
    if platform.machine() != "x86_64":
        pytest.importorskip("rclpy")
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    context = Context()
    rclpy.init(context=context)
    try:
        clock_node = Node("mcu_clock", context=context)
        clock = mcu_clock.McuClock(clock_node)
        peer = Node("peer", context=context)
        received: list[int] = []  # [ns]
        peer.create_subscription(
            Clock,
            "/clock",
            lambda m: received.append(m.clock.sec * 1_000_000_000 + m.clock.nanosec),
            QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT),
        )
        pub = peer.create_publisher(JointState, TOPICS.joint_states, 10)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(clock_node)
        executor.add_node(peer)

        def send(t_ns: int) -> None:
            msg = JointState()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_ns, 1_000_000_000)
            msg.name = [FRAMES.left_wheel_joint, FRAMES.right_wheel_joint]
            msg.position = [0.0, 0.0]
            pub.publish(msg)

        def wait_for(t_ns: int, timeout_s: float = 20.0) -> None:
            deadline = time.monotonic() + timeout_s
            while time.monotonic() < deadline and t_ns not in received:
                executor.spin_once(timeout_sec=0.05)
            assert t_ns in received, (t_ns, received)

        frame_ns = 50_000_000  # one telemetry frame
        t = 10_000_000_000
        deadline = time.monotonic() + 20.0
        while not received and time.monotonic() < deadline:  # until discovery completes
            t += frame_ns
            send(t)
            executor.spin_once(timeout_sec=0.05)
        wait_for(t)
        send(t)  # a repeat
        send(t - frame_ns)  # reordered
        send(t + frame_ns)
        wait_for(t + frame_ns)
        send(2_000_000_000)  # the daemon started again
        wait_for(2_000_000_000)
        assert received[received.index(t) :] == [t, t + frame_ns, 2_000_000_000]
        assert clock.last_ns == 2_000_000_000 and clock.published == len(received)
        executor.shutdown()
    finally:
        context.try_shutdown()


# ---------------------------------------------------------------------------------- docs


def test_docs_walk_through_every_launch_argument() -> None:
    text = DOCS.read_text(encoding="utf-8")
    section = text[text.index("## A system ROS 2: jackson_bringup") :]
    for argument in bringup.ARGUMENTS:
        assert f"`{argument.name}`" in section, argument.name
    for command in ("colcon build", "ros2 launch jackson_bringup", "rviz", "navigate_to_pose"):
        assert command in section
