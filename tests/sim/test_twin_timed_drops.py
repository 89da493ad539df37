"""The twin with timed drops: the LiDAR sees a timed cylinder only while it stands, and a drop
waits until the robot has moved off the spot (needs sim/twin.py to pass the robot's position
to World.check_triggers and to read World.obstacles)."""

from __future__ import annotations

import numpy as np

from jackson.sim.config import Cylinder, Trigger, WorldSpec, load_robot
from jackson.sim.robot import WheelDrive
from jackson.sim.twin import Twin

ROOM = (  # 6 m x 4 m around the origin
    (-3.0, -2.0, 3.0, -2.0),
    (3.0, -2.0, 3.0, 2.0),
    (3.0, 2.0, -3.0, 2.0),
    (-3.0, 2.0, -3.0, -2.0),
)


def twin(trigger: Trigger) -> Twin:
    spec = WorldSpec("room", walls=ROOM, triggers=(trigger,))
    return Twin(spec, load_robot("jackson"), lidar=True, seed=1)


def nearest_m(tw: Twin) -> float:
    return float(np.nanmin(np.where(tw.scans[-1].ranges > 0, tw.scans[-1].ranges, np.nan)))


def test_the_lidar_sees_a_timed_cylinder_only_while_it_stands() -> None:
    tw = twin(Trigger(None, Cylinder(1.0, 0.0, 0.15), at_s=1.0, remove_at_s=2.0))
    tw.advance(0.9)
    assert nearest_m(tw) > 1.5  # the walls, 2 m and more away
    tw.advance(0.6)
    assert tw.world.inserted and nearest_m(tw) < 1.0  # the cylinder, 0.85 m ahead
    tw.advance(1.0)
    assert tw.world.removed and nearest_m(tw) > 1.5


def test_a_drop_waits_until_the_robot_has_moved_off_its_spot() -> None:
    tw = twin(Trigger(None, Cylinder(0.3, 0.0, 0.15), at_s=0.5))
    tw.advance(1.0)
    assert tw.world.inserted == []
    back = WheelDrive(-0.6, 1.0)
    tw.command(back, back)  # reverse west, away from the spot
    for _ in range(100):
        tw.advance(0.1)
        if tw.world.inserted:
            break
    t_s, _ = tw.world.inserted[0]
    truth = tw.truth()
    assert t_s > 1.0
    assert 0.3 - truth.x >= 0.15 + 0.19 + 0.1 - 0.01  # clear of the body and its margin
    assert tw.collisions == 0


def test_a_far_timed_drop_keeps_the_free_space_shortcut() -> None:
    """No per-step checks while the next timed event is far off: the model's free-space runs
    stay long (one check per scan or so, not one per physics step)."""
    tw = twin(Trigger(None, Cylinder(2.5, 1.5, 0.1), at_s=500.0))
    calls = 0
    check = tw.world.check_triggers

    def counting(*args: object, **kwargs: object) -> list[Cylinder]:
        nonlocal calls
        calls += 1
        return check(*args, **kwargs)  # type: ignore[arg-type]

    tw.world.check_triggers = counting  # type: ignore[method-assign]
    tw.advance(10.0)
    assert calls < 200  # 2000 steps
