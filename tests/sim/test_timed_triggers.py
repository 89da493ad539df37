"""Timed obstacles in world files: a cylinder that appears at an MCU time, waits while the robot
stands where it would land, and leaves again; and the world file's patrol section."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import pymunk
import pytest

from jackson.sim.config import (
    WORLDS_DIR,
    ConfigError,
    Cylinder,
    PatrolSpec,
    Trigger,
    WorldSpec,
    load_robot,
    load_world,
)
from jackson.sim.lidar import cast
from jackson.sim.twin import Twin
from jackson.sim.world import World

ROOM = (  # 6 m x 4 m around the origin
    (-3.0, -2.0, 3.0, -2.0),
    (3.0, -2.0, 3.0, 2.0),
    (3.0, 2.0, -3.0, 2.0),
    (-3.0, 2.0, -3.0, -2.0),
)
PERSON = Cylinder(1.0, 0.0, 0.15)
ROBOT_RADIUS_M = 0.19
FAR = (-2.0, 1.5)  # [m] a robot position well clear of PERSON


def room(*triggers: Trigger) -> WorldSpec:
    return WorldSpec("room", walls=ROOM, triggers=triggers)


def range_east(world: World) -> float:
    """What the LiDAR's ray caster reads from the origin straight east (x)."""
    return float(cast((0.0, 0.0), [0.0], world.obstacles, 12.0)[0])


def person_in_space(world: World) -> bool:
    """Whether pymunk holds a static shape at PERSON's centre (the robot would hit it)."""
    hits = world.space.point_query((PERSON.x, PERSON.y), 0.0, pymunk.ShapeFilter())
    return any(h.shape is not None and h.shape.body is world.space.static_body for h in hits)


def world_file(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "w.yaml"
    path.write_text("name: w\n" + body)
    return path


# ------------------------------------------------------------------------- world files


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            "triggers:\n  - {when_moved_m: 1, at_s: 2, add_cylinder: {x: 1, y: 0, radius: 0.1}}\n",
            r"triggers\[0\]\.at_s: give when_moved_m or at_s, not both",
        ),
        (
            "triggers:\n  - {add_cylinder: {x: 1, y: 0, radius: 0.1}}\n",
            r"triggers\[0\]\.when_moved_m: missing \(or at_s",
        ),
        ("triggers:\n  - {at_s: 2}\n", r"triggers\[0\]\.add_cylinder: missing"),
        (
            "triggers:\n  - {when_moved_m: 1, remove_at_s: 5, "
            "add_cylinder: {x: 1, y: 0, radius: 0.1}}\n",
            r"triggers\[0\]\.remove_at_s: only a timed drop \(at_s\) is removed",
        ),
        (
            "triggers:\n  - {at_s: 5, remove_at_s: 5, add_cylinder: {x: 1, y: 0, radius: 0.1}}\n",
            r"triggers\[0\]\.remove_at_s: expected a time after at_s \(5\), got 5",
        ),
        (
            "triggers:\n  - {at_s: -1, add_cylinder: {x: 1, y: 0, radius: 0.1}}\n",
            r"triggers\[0\]\.at_s: expected a number >= 0, got -1",
        ),
        (
            "triggers:\n  - {at_s: 1, remove_at_s: soon, "
            "add_cylinder: {x: 1, y: 0, radius: 0.1}}\n",
            r"triggers\[0\]\.remove_at_s: expected a number >= 0 or null, got 'soon'",
        ),
        (
            "triggers:\n  - {at_s: 1, remove_at: 3, add_cylinder: {x: 1, y: 0, radius: 0.1}}\n",
            r"triggers\[0\]\.remove_at: unknown field",
        ),
        ("triggers:\n  - 3\n", r"triggers\[0\]: expected \{when_moved_m or at_s"),
        (
            "patrol:\n  drop_spots: [[1, 2], [1, .inf]]\n",
            r"patrol\.drop_spots\[1\]: expected \[x, y\] in metres, got \[1, inf\]",
        ),
        (
            "patrol:\n  unreachable: [[1, 2, 3]]\n",
            r"patrol\.unreachable\[0\]: expected \[x, y\] in metres",
        ),
        ("patrol:\n  drop_spot: [[1, 2]]\n", r"patrol\.drop_spot: unknown field"),
        ("patrol: [1, 2]\n", r"patrol: expected a mapping of fields"),
    ],
)
def test_a_bad_trigger_or_patrol_gets_one_line_naming_the_field(
    tmp_path: Path, body: str, message: str
) -> None:
    with pytest.raises(ConfigError, match=rf"^world w\.yaml: {message}") as info:
        load_world(world_file(tmp_path, body))
    assert "\n" not in str(info.value)


def test_a_timed_trigger_and_the_patrol_section_load(tmp_path: Path) -> None:
    spec = load_world(
        world_file(
            tmp_path,
            "triggers:\n"
            "  - {at_s: 12.5, remove_at_s: 40, add_cylinder: {x: 1, y: 0, radius: 0.15}}\n"
            "  - {at_s: 3, add_cylinder: {x: 2, y: 0, radius: 0.1}}\n"
            "  - {when_moved_m: 0.5, add_cylinder: {x: 0, y: 1, radius: 0.1}}\n"
            "patrol:\n  drop_spots: [[1, 2], [3.5, -4]]\n  unreachable: [[9, 9]]\n",
        )
    )
    assert spec.triggers == (
        Trigger(None, Cylinder(1.0, 0.0, 0.15), at_s=12.5, remove_at_s=40.0),
        Trigger(None, Cylinder(2.0, 0.0, 0.1), at_s=3.0),
        Trigger(0.5, Cylinder(0.0, 1.0, 0.1)),
    )
    assert spec.patrol == PatrolSpec(((1.0, 2.0), (3.5, -4.0)), ((9.0, 9.0),))


def test_a_world_without_a_patrol_section_has_none() -> None:
    assert load_world("maze").patrol is None


@pytest.mark.parametrize("name", sorted(p.stem for p in WORLDS_DIR.glob("*.yaml")))
def test_every_bundled_world_still_loads(name: str) -> None:
    spec = load_world(name)
    World(spec)
    for t in spec.triggers:
        assert (t.when_moved_m is None) != (t.at_s is None)


def test_a_trigger_takes_exactly_one_of_distance_and_time() -> None:
    with pytest.raises(ValueError, match="exactly one"):
        Trigger(None, PERSON)
    with pytest.raises(ValueError, match="exactly one"):
        Trigger(1.0, PERSON, at_s=2.0)
    with pytest.raises(ValueError, match="remove_at_s must follow at_s"):
        Trigger(None, PERSON, at_s=2.0, remove_at_s=1.0)


# ------------------------------------------------------------------------- the world


def test_a_timed_drop_appears_at_its_time() -> None:
    world = World(room(Trigger(None, PERSON, at_s=5.0)))
    assert range_east(world) == pytest.approx(3.0)
    assert world.check_triggers(0.0, 4.995, FAR, ROBOT_RADIUS_M) == []
    assert range_east(world) == pytest.approx(3.0) and not person_in_space(world)
    assert world.check_triggers(0.0, 5.0, FAR, ROBOT_RADIUS_M) == [PERSON]
    assert world.inserted == [(5.0, PERSON)]
    assert range_east(world) == pytest.approx(0.85)  # the LiDAR sees it
    assert person_in_space(world)  # and the robot collides with it
    assert world.clearance(0.0, 0.0) == pytest.approx(0.85)
    assert not world.pending


def test_a_timed_drop_waits_while_the_robot_stands_where_it_would_land() -> None:
    world = World(room(Trigger(None, PERSON, at_s=5.0)))
    assert world.check_triggers(0.0, 5.0, (1.0, 0.0), ROBOT_RADIUS_M) == []
    # 0.43 m off: the body (0.19 m) and its 0.1 m margin still overlap the 0.15 m cylinder
    assert world.check_triggers(0.0, 6.0, (1.43, 0.0), ROBOT_RADIUS_M) == []
    assert range_east(world) == pytest.approx(3.0) and not person_in_space(world)
    assert world.pending and world.next_check_step(1200, 0.005) == 1201  # every step now
    assert world.check_triggers(0.0, 7.0, (1.45, 0.0), ROBOT_RADIUS_M) == [PERSON]
    assert world.inserted == [(7.0, PERSON)]
    assert range_east(world) == pytest.approx(0.85)


def test_a_timed_drop_is_removed_at_remove_at_s() -> None:
    world = World(room(Trigger(None, PERSON, at_s=5.0, remove_at_s=20.0)))
    world.check_triggers(0.0, 5.0, FAR, ROBOT_RADIUS_M)
    assert world.pending and world.next_check_step(1000, 0.005) == 4000  # 20 s at 200 Hz
    world.check_triggers(0.0, 19.99, FAR, ROBOT_RADIUS_M)
    assert range_east(world) == pytest.approx(0.85) and person_in_space(world)
    world.check_triggers(0.0, 20.0, FAR, ROBOT_RADIUS_M)
    assert world.removed == [(20.0, PERSON)]
    assert range_east(world) == pytest.approx(3.0)  # the ray caster no longer sees it
    assert not person_in_space(world)  # nor does pymunk
    assert world.circles == [] and world.clearance(0.0, 0.0) == pytest.approx(2.0)
    assert not world.pending and world.next_check_step(4000, 0.005) == sys.maxsize


def test_a_drop_still_waiting_at_its_removal_never_happens() -> None:
    trigger = Trigger(None, PERSON, at_s=5.0, remove_at_s=8.0)
    world = World(room(trigger))
    world.check_triggers(0.0, 5.0, (1.0, 0.0), ROBOT_RADIUS_M)
    world.check_triggers(0.0, 8.0, FAR, ROBOT_RADIUS_M)
    assert world.inserted == [] and world.cancelled == [trigger]
    assert range_east(world) == pytest.approx(3.0) and not world.pending


def test_static_cylinders_stay_when_a_timed_one_leaves() -> None:
    post = Cylinder(1.0, 0.0, 0.15)  # the same place as PERSON: only one of them leaves
    spec = dataclasses.replace(
        room(Trigger(None, PERSON, at_s=1.0, remove_at_s=2.0)), cylinders=(post,)
    )
    world = World(spec)
    world.check_triggers(0.0, 1.0, FAR, ROBOT_RADIUS_M)
    world.check_triggers(0.0, 2.0, FAR, ROBOT_RADIUS_M)
    assert world.circles == [(1.0, 0.0, 0.15)]
    assert range_east(world) == pytest.approx(0.85) and person_in_space(world)


def test_distance_triggers_fire_as_before() -> None:
    world = World(room(Trigger(0.5, PERSON)))
    assert world.next_check_step(10, 0.005) == 11
    assert world.check_triggers(0.49, 100.0) == []
    assert world.check_triggers(0.5, 100.0) == [PERSON]
    assert world.inserted == [(100.0, PERSON)]


# ------------------------------------------------------------------------- in the twin


def test_the_twin_drops_and_removes_on_mcu_time() -> None:
    spec = dataclasses.replace(
        room(Trigger(None, PERSON, at_s=1.0, remove_at_s=2.0)), start_pose=(-2.0, 0.0, 0.0)
    )
    tw = Twin(spec, load_robot("jackson"), lidar=False)
    tw.advance(0.995)
    assert tw.world.inserted == []
    tw.advance(0.5)
    assert tw.world.inserted == [(pytest.approx(1.0), PERSON)]
    tw.advance(1.0)
    assert tw.world.removed == [(pytest.approx(2.0), PERSON)]
    assert tw.world.circles == []
