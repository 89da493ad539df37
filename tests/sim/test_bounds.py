"""Robot and world files are held to physical bounds (jackson.sim.bounds): a value no robot of
this class can have is refused with one line naming the file, the field and the range, before
any physics runs; the shipped files are all inside; a cylinder dropped onto the robot is
refused when it would land."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from jackson.main import main
from jackson.sim import bounds
from jackson.sim.config import (
    ROBOTS_DIR,
    WORLDS_DIR,
    ConfigError,
    Cylinder,
    Trigger,
    WorldSpec,
    load_robot,
    load_world,
)
from jackson.sim.world import World

ROOM = "walls:\n  - [-3, -3, 3, -3]\n  - [3, -3, 3, 3]\n  - [3, 3, -3, 3]\n  - [-3, 3, -3, -3]\n"


def test_the_shipped_robots_and_worlds_are_inside_the_bounds() -> None:
    for path in sorted(ROBOTS_DIR.glob("*.yaml")):
        load_robot(path)
    for path in sorted(WORLDS_DIR.glob("*.yaml")):
        load_world(path)


@pytest.mark.parametrize(
    ("text", "field", "interval"),
    [
        ("mass_kg: 1.0e+30\n", "mass_kg", "[0.1, 100]"),
        ("mass_kg: 0.001\n", "mass_kg", "[0.1, 100]"),
        ("inertia_kg_m2: 1.0e+9\n", "inertia_kg_m2", "[1e-05, 50]"),
        ("wheel_radius_m: 0.001\n", "wheel_radius_m", "[0.005, 0.5]"),
        ("wheel_radius_m: {left: 0.033, right: 3}\n", "wheel_radius_m.right", "[0.005, 0.5]"),
        ("wheel_separation_m: 0.001\n", "wheel_separation_m", "[0.02, 2]"),
        ("ticks_per_rev: 0.5\n", "ticks_per_rev", "[1, 1e+06]"),
        ("envelope_x_m: [-100, 0.1]\n", "envelope_x_m", "[-2, 2]"),
        ("motor:\n  no_load_rpm: 1.0e+9\n", "motor.no_load_rpm", "[1, 20000]"),
        ("motor:\n  battery_v: 1000\n", "motor.battery_v", "[0.5, 60]"),
        ("motor:\n  stall_torque_nm: 1.0e+6\n", "motor.stall_torque_nm", "[0.0001, 100]"),
        ("motor:\n  time_constant_s: 100\n", "motor.time_constant_s", "[0, 1]"),
        ("motor:\n  wheel_inertia_kg_m2: 1000\n", "motor.wheel_inertia_kg_m2", "[1e-08, 1]"),
        ("imu:\n  gravity_scale: 100\n", "imu.gravity_scale", "[0.5, 2]"),
        ("imu:\n  gyro_bias_rad_s: [0, 0, 50]\n", "imu.gyro_bias_rad_s", "[-1, 1]"),
        ("lidar:\n  mount_x_m: 1000\n", "lidar.mount_x_m", "[-1, 1]"),
    ],
)
def test_a_robot_outside_the_physical_bounds_is_one_line(
    tmp_path: Path, text: str, field: str, interval: str
) -> None:
    path = tmp_path / "r.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_robot(path)
    line = str(info.value)
    assert line.startswith(f"robot r.yaml: {field}: expected "), line
    assert interval in line and "\n" not in line


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("floor: {mu_static: 50, mu_dynamic: 0.7}\n", "floor.mu_static"),
        ("cylinders:\n  - {x: 1, y: 1, radius: 1.0e+6}\n", "cylinders[0].radius"),
        ("cylinders:\n  - {x: 1.0e+7, y: 1, radius: 0.1}\n", "cylinders[0].x"),
        ("walls:\n  - [0, 0, 1.0e+7, 0]\n", "walls[0]"),
        ("start_pose: [1.0e+7, 0, 0]\n", "start_pose"),
        ("goal: [0, 1.0e+7]\n", "goal"),
        (
            "triggers:\n  - when_moved_m: 0.5\n    add_cylinder: {x: 1, y: 0, radius: 1.0e+6}\n",
            "triggers[0].add_cylinder.radius",
        ),
        (
            "triggers:\n  - when_moved_m: 1.0e+9\n    add_cylinder: {x: 1, y: 0, radius: 0.2}\n",
            "triggers[0].when_moved_m",
        ),
        (
            "triggers:\n  - when_moved_m: 0.5\n    add_cylinder: {x: 0.2, y: 0, radius: 2}\n",
            "triggers[0].add_cylinder",
        ),
    ],
)
def test_a_world_outside_the_physical_bounds_is_one_line(
    tmp_path: Path, text: str, field: str
) -> None:
    path = tmp_path / "w.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_world(path)
    line = str(info.value)
    assert line.startswith(f"world w.yaml: {field}: "), line
    assert "\n" not in line


def test_a_cylinder_dropped_onto_the_robot_is_refused_when_it_lands() -> None:
    drop = Trigger(0.5, Cylinder(1.0, 0.0, 0.3))
    world = World(WorldSpec("w", walls=((-3.0, -3.0, 3.0, -3.0),), triggers=(drop,)))
    with pytest.raises(ConfigError, match=r"^world w: triggers\[0\]\.add_cylinder: .* drops onto"):
        world.check_triggers(0.5, 2.0, robot_xy=(0.9, 0.0), robot_radius_m=0.14)


def test_a_cylinder_dropped_beside_the_robot_lands() -> None:
    drop = Trigger(0.5, Cylinder(1.0, 0.0, 0.3))
    world = World(WorldSpec("w", triggers=(drop,)))
    assert world.check_triggers(0.5, 2.0, robot_xy=(0.5, 0.0), robot_radius_m=0.14) == [
        drop.cylinder
    ]
    assert math.isclose(world.circles[0][2], 0.3)


@pytest.mark.parametrize("command", [["sim", "--duration", "0.1"], ["run", "square"]])
def test_jackson_refuses_a_robot_of_1e30_kg(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: list[str]
) -> None:
    path = tmp_path / "heavy.yaml"
    text = (ROBOTS_DIR / "jackson_physical.yaml").read_text()
    path.write_text(text.replace("mass_kg: 2.0", "mass_kg: 1.0e+30", 1))
    out = ["--out", str(tmp_path / "run")] if command[0] == "run" else []
    rc = main([*command, "--robot", str(path), *out])
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert rc == 2
    assert lines == [
        f"jackson {command[0]}: robot heavy.yaml: mass_kg: expected a number in "
        f"[{bounds.ROBOT['mass_kg'][0]:g}, {bounds.ROBOT['mass_kg'][1]:g}], got 1e+30"
    ]


def test_a_robot_whose_physics_diverges_is_one_line_naming_it() -> None:
    """Each value inside its bounds, together too stiff for the 200 Hz step: the pose turns
    to nan, and the twin says so instead of driving on."""
    from jackson.sim.config import MotorSpec, RobotSpec, Sides
    from jackson.sim.robot import WheelDrive
    from jackson.sim.twin import Twin

    motor = MotorSpec(
        battery_v=13.6,
        nominal_v=17.2,
        no_load_rpm=20000.0,
        stall_torque_nm=100.0,
        time_constant_s=1.0,
        wheel_inertia_kg_m2=1e-8,
    )
    robot = RobotSpec(
        "stiff",
        mass_kg=0.1,
        inertia_kg_m2=1e-5,
        wheel_radius_m=Sides(0.005, 0.005),
        wheel_separation_m=0.224,
        motor=motor,
    )
    twin = Twin(load_world("open_floor"), robot, lidar=False, seed=52)
    twin.command(WheelDrive(1.0, 1.0), WheelDrive(-0.5, 1.0))
    with pytest.raises(ConfigError, match=r"^robot stiff: the physics diverged by "):
        for _ in range(10):
            twin.advance(0.5)
