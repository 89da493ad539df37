"""The twin's and the host's mechanisms, each with the patch that switches it off.

:data:`MECHANISMS` lists the twin's imperfections (``sim/robots/jackson_physical.yaml``) and
host settings as plain data; a patch is a nested mapping deep-merged (:func:`deep_merge`) into
the robot file or the host configuration.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from jackson.host.config import DEFAULT_CONFIG
from jackson.host.control.square import SquareConfig


@dataclass(frozen=True)
class Mechanism:
    """A mechanism of the twin (its robot file) or of the host configuration, and the patch
    that switches it off.

    Attributes
    ----------
    name : str
        Identifier, also the ablation's folder name (``tyre_creep_scrub``).
    what : str
        What it does on the robot and which of the paper's figures it reproduces.
    source : str
        Where its value comes from (measured, fitted to which figures).
    robot_patch, config_patch : mapping
        Nested fields deep-merged (:func:`deep_merge`) into the robot YAML and the host
        configuration YAML to switch the mechanism off.
    stage3 : bool
        The ablation runs the maze with it off too.
    """

    name: str
    what: str
    source: str
    robot_patch: Mapping[str, Any] = field(default_factory=dict)
    config_patch: Mapping[str, Any] = field(default_factory=dict)
    stage3: bool = False


BRINGUP_CONFIG = DEFAULT_CONFIG.with_name("jackson_bringup.yaml")
"""The host configuration the campaign runs by default: the paper's robot commanded as its
bringup drove it (the deceleration limits and Stage 3's top speed below)."""


SQUARE_BRINGUP_FIELDS = ("a_dec_m_s2", "heading_tolerance_rad", "settle_rad_s", "w_max_rad_s")
"""The square controller's fields the bringup sets; ``square_controller`` off: their defaults."""

MECHANISMS: tuple[Mechanism, ...] = (
    Mechanism(
        "tyre_creep_scrub",
        "tyre creep and yaw scrub: the robot turns slower than its encoders say, more in wide "
        "arcs than on the spot (a wider effective track)",
        "fitted: the square's raw-odometry heading and closure, the loop diameters, the "
        "durations; the scrub re-identified on 30 trials (seeds 66100-66129)",
        robot_patch={"tyre": {"longitudinal_compliance": 0.0, "scrub_arm_m": 0.0}},
    ),
    Mechanism(
        "caster_drag",
        "a draggy caster: a force against forward motion, none on the spot; it slows the "
        "figure-eight's 0.08 m/s more than the square's 0.15 m/s",
        "fitted: the square's and the figure-eight's durations together",
        robot_patch={"caster_rolling_coeff": 0.0},
        stage3=True,
    ),
    Mechanism(
        "left_drive_weaker",
        "the left drive weaker than the right: CCW loops narrower than CW ones",
        "fitted: the CCW / CW loop diameters (T6)",
        robot_patch={"motor": {"gain": {"left": 1.0}}},
    ),
    Mechanism(
        "gyro_scale",
        "the gyro reads low: each loop the EKF closes at 2 pi turns further on the floor",
        "fitted: the optimism gap (T13) and the floor closure (T6) on 30 trials; within the "
        "MPU-6050's ±3 % sensitivity tolerance",
        robot_patch={"imu": {"yaw_scale": 1.0}},
    ),
    Mechanism(
        "gyro_bias_drift",
        "the gyro bias wanders (a random walk) after the host's start-up bias window",
        "fitted: the SDs of the figure-eight's floor closure and optimism gap",
        robot_patch={"imu": {"gyro_bias_drift_rad_s_per_sqrt_s": 0.0}},
    ),
    Mechanism(
        "actuation_latency",
        "a delay between a command and the motors",
        "measured on the physical robot: the paper's command-transport latency, about 50 ms",
        robot_patch={"actuation_latency_s": 0.0},
        stage3=True,
    ),
    Mechanism(
        "trial_variation",
        "per-trial draws of supply voltage, wheel radii, encoder scales, turn-on gyro bias "
        "and floor friction",
        "fitted: the SDs of every figure (docs/fidelity.md, 'Spreads')",
        robot_patch={
            "variation": {
                "battery_v_sigma": 0.0,
                "wheel_radius_sigma": 0.0,
                "encoder_scale_sigma": 0.0,
                "gyro_bias_sigma_rad_s": 0.0,
                "floor_mu_sigma": 0.0,
            }
        },
    ),
    Mechanism(
        "deceleration_limits",
        "the robot's commands slow down at 0.10 m/s^2 and 1.0 rad/s^2 at most (the host's "
        "limiter, host/config/jackson_bringup.yaml): it stops, and reverses its turn between "
        "the figure-eight's loops, no faster; a finished mission's stop is ramped the same way",
        "the paper's 'conservative physical motor acceleration limits' (Sec. 2.2.3, "
        "Discussion), values not published: 0.10 m/s^2 identified from the figure-eight's EKF "
        "closure, 1.0 rad/s^2 from its final heading residual (T6)",
        config_patch={"limits": {"max_decel_m_s2": 1.0, "max_alpha_decel_rad_s2": 6.0}},
        stage3=True,
    ),
    Mechanism(
        "square_controller",
        "the square's waypoint controller as the paper's bringup ran it (host config square:): "
        "it plans its stops at the robot's 0.10 m/s^2, ends a turn within 0.03 rad (1.7 deg) "
        "without waiting for it to settle, and turns at up to 0.55 rad/s",
        "the paper's 'explicit velocity deceleration bounds and closed-loop final heading "
        "alignment' (Sec. 3.1), values not published: the tolerance identified from the "
        "square's EKF final heading error (T5), the turn rate from its duration (T11)",
        config_patch={"square": {k: getattr(SquareConfig(), k) for k in SQUARE_BRINGUP_FIELDS}},
    ),
    Mechanism(
        "navigation_top_speed",
        "Stage 3's local planner drives at 0.10 m/s at most (navigation.max_vel_x_m_s, "
        "Nav2's max_vel_x); off, it drives up to the limiter's 0.30 m/s",
        "not published: identified from the physical t_nav (22.4 s over 1.958 m, T14)",
        config_patch={"navigation": {"max_vel_x_m_s": None}},
        stage3=True,
    ),
)
"""The mechanisms of ``jackson_physical`` and the host, each with the patch that switches it
off (docs/fidelity.md, "What the robot file holds"). Plain data: append more."""


def deep_merge(base: Mapping[str, Any], patch: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``patch`` merged in: mappings merged key by key, anything else replaced.

    Parameters
    ----------
    base : mapping
        A YAML document (neither argument is changed).
    patch : mapping
        The fields to set, nested as in ``base``.

    Returns
    -------
    dict
        A new document.
    """
    out = dict(base)
    for key, value in patch.items():
        old = out.get(key)
        if isinstance(value, Mapping) and isinstance(old, Mapping):
            out[key] = deep_merge(old, value)
        else:
            out[key] = value
    return out


def dotted(patch: Mapping[str, Any], doc: Mapping[str, Any] | None = None) -> list[str]:
    """A patch as one ``field.sub = value`` per field; with ``doc``, the value it replaces too.

    Parameters
    ----------
    patch : mapping
        A nested patch.
    doc : mapping or None
        The document it patches: each line reads ``field.sub: old -> new`` (``old`` is
        ``default`` for a field the document leaves to the loader's default).

    Returns
    -------
    list of str
        E.g. ``["tyre.scrub_arm_m = 0.0"]``, or ``["tyre.scrub_arm_m: 0.0058 -> 0.0"]``.
    """

    def lines(p: Mapping[str, Any], d: Any, prefix: str) -> list[str]:
        out = []
        for key, value in p.items():
            old = d.get(key, "default") if isinstance(d, Mapping) else "default"
            if isinstance(value, Mapping):
                out += lines(value, old, f"{prefix}{key}.")
            elif doc is None:
                out.append(f"{prefix}{key} = {value}")
            else:
                out.append(f"{prefix}{key}: {old} -> {value}")
        return out

    return lines(patch, doc, "")
