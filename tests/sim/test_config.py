"""Robot and world files: read with the same field reader as the host's config."""

from __future__ import annotations

from pathlib import Path

import pytest

from jackson.sim.config import ConfigError, Sides, load_robot, load_world


def robot_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "r.yaml"
    path.write_text(text)
    return path


def test_exponent_numbers_and_per_side_values(tmp_path: Path) -> None:
    spec = load_robot(
        robot_file(
            tmp_path,
            "name: r\nmotor:\n  wheel_inertia_kg_m2: 3e-4\n"
            "ticks_per_rev: {left: 617, right: 626}\nwheel_radius_m: 0.0331\n",
        )
    )
    assert spec.motor.wheel_inertia_kg_m2 == 3e-4
    assert spec.ticks_per_rev == Sides(617.0, 626.0)
    assert spec.wheel_radius_m == Sides(0.0331, 0.0331)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "motor:\n  stall_torque_nm: -1\n",
            r"robot r.yaml: motor.stall_torque_nm: expected a number in \[0.0001, 100\], got -1",
        ),
        (
            "wheel_separation_m: 0.2\nwheel_separation_m: 0.21\n",
            "robot r.yaml: line 2: .*duplicate field 'wheel_separation_m'",
        ),
        (
            "track_width_m: 0.2\n",
            "robot r.yaml: track_width_m: renamed wheel_separation_m",
        ),
        ("ticks_per_rev: {left: 617}\n", "robot r.yaml: ticks_per_rev.right: missing"),
        ("imu:\n  presnt: false\n", "robot r.yaml: imu.presnt: unknown field"),
        ("imu:\n  present: null\n", "robot r.yaml: imu.present: expected true or false, got null"),
        ("motor: 3\n", "robot r.yaml: motor: expected a mapping of fields, got 3"),
        ("- 1\n", "robot r.yaml: expected a mapping of fields at the top level"),
    ],
)
def test_a_bad_robot_file_gets_one_line(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=f"^{message}") as info:
        load_robot(robot_file(tmp_path, text))
    assert "\n" not in str(info.value)


def test_a_bad_world_file_gets_one_line(tmp_path: Path) -> None:
    path = tmp_path / "w.yaml"
    path.write_text("floor: {mu_static: 0.5, mu_dynamic: 0.6}\n")
    with pytest.raises(ConfigError, match=r"^world w\.yaml: floor\.mu_dynamic: must not exceed"):
        load_world(path)
    path.write_text("walls:\n  - [0, 0, 1]\n")
    with pytest.raises(
        ConfigError, match=r"^world w\.yaml: walls\[0\]: expected \[x1, y1, x2, y2\]"
    ):
        load_world(path)
