"""Physical bounds of the twin's robot and world files.

A robot file describes a small differential-drive robot (the class of the paper's: 2 kg,
33 mm wheels, a 0.2 m track); a world file a floor a robot of that class drives on. Values far
outside what such a robot or floor can be make the physics meaningless or break it (a mass of
1e30 kg divides by zero in the traction model; a cylinder of 1e6 m radius leaves no floor), so
each number is checked against the closed range here, and a file outside it is refused with one
line naming the file, the field and the range (:func:`jackson.sim.config.load_robot`,
:func:`jackson.sim.config.load_world`, which use :func:`vector` and :func:`not_on_start` here).

The ranges are wide: from a toy robot to a service robot, two orders of magnitude either side
of the shipped values, so that no plausible robot is refused.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol

from jackson.common.fields import Fields, show

Range = tuple[float, float]

ROBOT: dict[str, Range] = {
    "mass_kg": (0.1, 100.0),
    "inertia_kg_m2": (1.0e-5, 50.0),  # about z: a 0.1 kg puck to a 100 kg, 1 m wide base
    "wheel_radius_m": (0.005, 0.5),
    "wheel_separation_m": (0.02, 2.0),
    "ticks_per_rev": (1.0, 1.0e6),
    "envelope_m": (-2.0, 2.0),  # each side of the collision envelope, from the axle centre
}
"""Top-level fields of a robot file."""

MOTOR: dict[str, Range] = {
    "battery_v": (0.5, 60.0),
    "nominal_v": (0.5, 60.0),
    "no_load_rpm": (1.0, 20_000.0),
    "stall_torque_nm": (1.0e-4, 100.0),  # at the wheel shaft
    "time_constant_s": (0.0, 1.0),
    "wheel_inertia_kg_m2": (1.0e-8, 1.0),
}
"""The ``motor:`` section."""

IMU: dict[str, Range] = {
    "gyro_noise_sigma_rad_s": (0.0, 1.0),
    "accel_noise_sigma_m_s2": (0.0, 10.0),
    "gravity_scale": (0.5, 2.0),
    "yaw_scale": (0.5, 2.0),
    "gyro_bias_rad_s": (-1.0, 1.0),  # each axis
    "accel_bias_m_s2": (-10.0, 10.0),  # each axis
}
"""The ``imu:`` section."""

LIDAR: dict[str, Range] = {
    "noise_sigma_m": (0.0, 1.0),
    "extra_noise_sigma_m": (0.0, 1.0),
    "mount_x_m": (-1.0, 1.0),
    "mount_y_m": (-1.0, 1.0),
    "mount_yaw_rad": (-2.0 * math.pi, 2.0 * math.pi),
}
"""The ``lidar:`` section."""

WORLD_EXTENT_M = 1000.0
"""|x| and |y| of every wall end, cylinder centre and pose at most this [m]."""
FRICTION: Range = (0.01, 2.0)
"""``floor.mu_static`` and ``floor.mu_dynamic``: ice to rubber on rough concrete."""
CYLINDER_RADIUS_M: Range = (0.005, 10.0)
"""A cylinder's radius, placed or dropped [m]."""
TRIGGER_MOVED_M: Range = (0.0, WORLD_EXTENT_M)
"""``when_moved_m`` of a distance trigger [m]."""
EXTENT: Range = (-WORLD_EXTENT_M, WORLD_EXTENT_M)
EXTENT_TEXT = f"[{-WORLD_EXTENT_M:g}, {WORLD_EXTENT_M:g}] m"


def vector(r: Fields, key: str, default: tuple[float, ...], limits: Range) -> tuple[float, ...]:
    """The list ``key`` of ``len(default)`` numbers, each in ``limits``."""
    v = r.vector(key, default, len(default))
    lo, hi = limits
    if not all(lo <= x <= hi for x in v):
        raise r.fail(key, f"expected each number in [{lo:g}, {hi:g}], got {show(list(v))}")
    return v


class Circle(Protocol):
    """A cylinder as :func:`not_on_start` reads it (``jackson.sim.config.Cylinder``)."""

    @property
    def x(self) -> float: ...
    @property
    def y(self) -> float: ...
    @property
    def radius(self) -> float: ...


class Drop(Protocol):
    """A trigger as :func:`not_on_start` reads it (``jackson.sim.config.Trigger``)."""

    @property
    def when_moved_m(self) -> float | None: ...
    @property
    def cylinder(self) -> Circle: ...


def not_on_start(r: Fields, triggers: Sequence[Drop], start: tuple[float, ...]) -> None:
    """Refuse a distance trigger's cylinder that covers every point the robot can be at when
    it fires (its ``when_moved_m`` from the start). A placed cylinder on the start pose is
    refused by the twin, against the robot's footprint (:class:`jackson.sim.twin.Twin`); one
    dropped onto the robot where it happens to be, when it fires
    (:meth:`jackson.sim.world.World.check_triggers`); a timed drop waits for the robot to leave.
    """
    for k, t in enumerate(triggers):
        c, moved = t.cylinder, t.when_moved_m
        if moved is not None and math.hypot(c.x - start[0], c.y - start[1]) + moved < c.radius:
            raise r.fail(
                f"triggers[{k}].add_cylinder",
                f"the cylinder (radius {c.radius:g} m at {c.x:g}, {c.y:g}) covers every place "
                f"the robot can be {moved:g} m from the start ({start[0]:g}, {start[1]:g}): "
                "move it or make it smaller",
            )
