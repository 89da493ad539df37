"""Bring up the Jackson UGV on a system ROS 2, on the robot or against the digital twin.

    ros2 launch jackson_bringup bringup.launch.py jackson:=$HOME/jackson/.venv/bin/jackson
    ros2 launch jackson_bringup bringup.launch.py twin:=true slam:=true rviz:=true
    ros2 launch jackson_bringup bringup.launch.py map:=maze.yaml nav:=true rviz:=true

Starts the host daemon (``jackson daemon --ros``; with ``twin:=true`` first ``jackson sim --ros
--realtime`` and the daemon on its ports once they exist), robot_state_publisher with
urdf/jackson.urdf, and as asked sllidar_ros2, slam_toolbox (config/slam_toolbox.yaml), Nav2
(config/nav2.yaml), RViz and, for a robot run on its MCU's clock (``use_sim_time:=true``
without the twin), ``mcu_clock``.
``ros2 launch jackson_bringup bringup.launch.py --show-args`` lists the arguments; what they
start is worked out in :mod:`jackson_bringup.bringup`. The launch ends when the daemon (or the
twin) stops.
"""

from __future__ import annotations

import contextlib
import tempfile
from pathlib import Path
from typing import Any

import yaml
from jackson_bringup import bringup
from launch import LaunchContext, LaunchDescription
from launch.actions import (
    DeclareLaunchArgument,
    ExecuteProcess,
    IncludeLaunchDescription,
    OpaqueFunction,
    RegisterEventHandler,
    Shutdown,
)
from launch.event_handlers import OnProcessIO
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

SHARE = Path(__file__).resolve().parents[1]  # share/jackson_bringup (or the source folder)
URDF = SHARE / "urdf" / "jackson.urdf"
NAV2_PARAMS = SHARE / "config" / "nav2.yaml"
SLAM_PARAMS = SHARE / "config" / "slam_toolbox.yaml"
APT_HINT = "install it with: sudo apt install ros-$ROS_DISTRO-{}"


def generate_launch_description() -> LaunchDescription:
    """The arguments of :data:`jackson_bringup.bringup.ARGUMENTS`, then :func:`launch_setup`."""
    return LaunchDescription(
        [
            *(
                DeclareLaunchArgument(a.name, default_value=a.default, description=a.description)
                for a in bringup.ARGUMENTS
            ),
            OpaqueFunction(function=launch_setup),
        ]
    )


def share(package: str, why: str, hint: str | None = None) -> Path:
    """A ROS package's share folder; a one-line error naming what to install when it is not
    there."""
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    try:
        return Path(get_package_share_directory(package))
    except PackageNotFoundError:
        help_text = hint or APT_HINT.format(package.replace("_", "-"))
        raise bringup.BringupError(f"{why} needs the ROS package {package}; {help_text}") from None


def launch_setup(context: LaunchContext) -> list[Any]:
    """The actions for the arguments given (an argument error ends the launch in one line)."""
    values = {a.name: LaunchConfiguration(a.name).perform(context) for a in bringup.ARGUMENTS}
    opts = bringup.parse_options(values)
    urdf = URDF.read_text(encoding="utf-8")
    mounts = bringup.mounts_from_urdf(urdf)
    sim_time = {"use_sim_time": opts.use_sim_time}
    sim_time_arg = "true" if opts.use_sim_time else "false"
    actions: list[Any] = []

    if opts.twin:
        folder = Path(tempfile.mkdtemp(prefix="jackson-twin-"))
        ports = bringup.TwinPorts.in_folder(folder)
        twin = ExecuteProcess(
            cmd=bringup.twin_command(opts, ports),
            name="twin",
            output="screen",
            on_exit=[
                OpaqueFunction(function=lambda _: _remove_empty(folder)),
                Shutdown(reason="the twin stopped"),
            ],
        )
        daemon = _daemon(bringup.daemon_command(opts, mounts, ports))
        started: list[bool] = []

        def on_twin_stdout(event: Any) -> Any:
            if started or not bringup.twin_ready(event.text.decode(errors="replace")):
                return None
            started.append(True)
            return daemon

        actions += [
            RegisterEventHandler(OnProcessIO(target_action=twin, on_stdout=on_twin_stdout)),
            twin,
        ]
    else:
        actions.append(_daemon(bringup.daemon_command(opts, mounts)))

    share("robot_state_publisher", "the robot model")
    actions.append(
        Node(
            package="robot_state_publisher",
            executable="robot_state_publisher",
            output="screen",
            parameters=[{"robot_description": urdf, **sim_time}],
        )
    )
    if opts.clock == "mcu":
        share("jackson_bringup", "the MCU clock", "build this package with colcon")
        actions.append(Node(package="jackson_bringup", executable="mcu_clock", output="screen"))
    if opts.lidar == "sllidar":
        share(
            "sllidar_ros2",
            "lidar:=sllidar",
            "clone Slamtec's sllidar_ros2 into the workspace and build it, or give lidar:=host",
        )
        actions.append(
            Node(
                package="sllidar_ros2",
                executable="sllidar_node",
                name="sllidar_node",
                output="screen",
                parameters=[bringup.sllidar_parameters(opts)],
            )
        )
    if opts.slam:
        slam_launch = share("slam_toolbox", "slam:=true") / "launch" / "online_async_launch.py"
        actions.append(
            IncludeLaunchDescription(
                PythonLaunchDescriptionSource(str(slam_launch)),
                launch_arguments={
                    "slam_params_file": str(SLAM_PARAMS),
                    "use_sim_time": sim_time_arg,
                }.items(),
            )
        )
    if opts.map or opts.nav:
        nav2_launch = share("nav2_bringup", "Nav2 (map:= or nav:=true)") / "launch"
        params = str(NAV2_PARAMS)
        if opts.initial_pose is not None:
            loaded = yaml.safe_load(NAV2_PARAMS.read_text(encoding="utf-8"))
            with tempfile.NamedTemporaryFile(
                "w", prefix="jackson-nav2-", suffix=".yaml", delete=False, encoding="utf-8"
            ) as f:
                yaml.safe_dump(bringup.nav2_parameters(loaded, opts.initial_pose), f)
            params = f.name
        nav2_args = {"params_file": params, "use_sim_time": sim_time_arg, "autostart": "true"}
        if opts.map:
            actions.append(
                IncludeLaunchDescription(
                    PythonLaunchDescriptionSource(str(nav2_launch / "localization_launch.py")),
                    launch_arguments={**nav2_args, "map": opts.map}.items(),
                )
            )
        if opts.nav:
            actions.append(
                IncludeLaunchDescription(
                    PythonLaunchDescriptionSource(str(nav2_launch / "navigation_launch.py")),
                    launch_arguments=nav2_args.items(),
                )
            )
    if opts.rviz:
        share("rviz2", "rviz:=true")
        arguments: list[str] = []
        try:
            view = share("nav2_bringup", "RViz") / "rviz" / "nav2_default_view.rviz"
            arguments = ["-d", str(view)] if view.is_file() else []
        except bringup.BringupError:
            pass  # RViz without Nav2's view
        actions.append(
            Node(
                package="rviz2",
                executable="rviz2",
                output="screen",
                arguments=arguments,
                parameters=[sim_time],
            )
        )
    return actions


def _daemon(cmd: list[str]) -> ExecuteProcess:
    return ExecuteProcess(
        cmd=cmd, name="daemon", output="screen", on_exit=Shutdown(reason="the daemon stopped")
    )


def _remove_empty(folder: Path) -> None:
    with contextlib.suppress(OSError):
        folder.rmdir()  # the twin removes its link and socket when it stops
