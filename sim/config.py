"""World and robot files of the twin: YAML in, validated frozen dataclasses out.

Robot files (``sim/robots/*.yaml``) hold the twin's *true* parameters, which the host does
not know; world files (``sim/worlds/*.yaml``) hold walls, cylinders, triggered obstacles and
the floor. Every problem is reported as one :class:`ConfigError` line naming the file and the
field, e.g. ``robot jackson.yaml: motor.stall_torque_nm: expected a number in [0.0001, 100],
got -1``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from jackson.common.fields import ConfigError as ConfigError  # re-exported
from jackson.common.fields import Fields, read_yaml, show
from jackson.common.robot import (
    ENVELOPE_X_M,
    ENVELOPE_Y_M,
    LIDAR_RANGE_NOISE_M,
    TICKS_PER_REV,
    WHEEL_RADIUS_M,
    WHEEL_SEPARATION_M,
)
from jackson.sim import bounds
from jackson.sim.faults import PARAMS, SIDED_KINDS, FaultError, FaultSpec
from jackson.sim.tb6612 import LEFT_WIRING, RIGHT_WIRING, MotorWiring

SIM_DIR = Path(__file__).resolve().parent
ROBOTS_DIR = SIM_DIR / "robots"
WORLDS_DIR = SIM_DIR / "worlds"


@dataclass(frozen=True)
class Sides:
    """A value per wheel."""

    left: float
    right: float


@dataclass(frozen=True)
class MotorSpec:
    """DC gear motor at the wheel shaft, driven through the TB6612 from the battery."""

    battery_v: float = 6.0  # 5 x 1.2 V NiMH
    nominal_v: float = 6.0
    no_load_rpm: float = 100.0  # at nominal_v
    stall_torque_nm: float = 0.6  # at nominal_v
    time_constant_s: float = 0.02  # first-order torque response
    deadband_duty: Sides = Sides(0.10, 0.10)  # static breakaway duty at the battery voltage
    gain: Sides = Sides(1.0, 1.0)  # left/right asymmetry of the whole drive
    wheel_inertia_kg_m2: float = 2.0e-4  # wheel plus reflected rotor inertia
    ratings_net_of_friction: bool = False  # no_load_rpm, stall_torque_nm measured at the wheel
    running_friction_fraction: float = 1.0  # Coulomb (running) / breakaway gearbox friction

    def __post_init__(self) -> None:
        if not 0.0 < self.running_friction_fraction <= 1.0:
            raise ValueError(
                "motor.running_friction_fraction: expected a number in (0, 1], "
                f"got {self.running_friction_fraction}"
            )

    @property
    def no_load_rad_s(self) -> float:
        return self.no_load_rpm * 2.0 * math.pi / 60.0


INTERLOCKS = ("pca9685_oe", "tb6612_stby", "none")
"""Where the MCU's motor interlock line goes (docs/firmware.md, "Motor interlock"): the
PCA9685's OE pin (pulled up), the TB6612's STBY (pulled down), or nowhere."""


@dataclass(frozen=True)
class WiringSpec:
    """How the PCA9685 drives the TB6612 on this robot, and where the MCU's interlock line
    goes (one of :data:`INTERLOCKS`; ``none``: nothing stops a host's last duty)."""

    pca9685_address: int = 0x40
    left: MotorWiring = LEFT_WIRING
    right: MotorWiring = RIGHT_WIRING
    stby_channel: int | None = None  # None: STBY tied high (or the interlock's, tb6612_stby)
    interlock: str = "pca9685_oe"


MAX_GYRO_DRIFT = 0.01  # [rad/s/sqrt(s)] far above any MEMS gyro's bias instability


@dataclass(frozen=True)
class ImuSpec:
    """MPU-6050 error model, Eq. 7-8: a = a_true + b_a + eta_a, omega = omega_true + b_w + eta_w."""

    gyro_bias_rad_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_bias_m_s2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gyro_noise_sigma_rad_s: float = 3.999e-4
    accel_noise_sigma_m_s2: float = 1.7976e-2
    gravity_scale: float = 1.0  # the paper's sensor read 9.299 at rest: 0.9479
    yaw_scale: float = 1.0  # gyro z scale error
    present: bool = True
    gyro_bias_drift_rad_s_per_sqrt_s: float = 0.0  # random walk of b_w, each axis

    def __post_init__(self) -> None:
        if not 0.0 <= self.gyro_bias_drift_rad_s_per_sqrt_s <= MAX_GYRO_DRIFT:
            raise ValueError(
                "imu.gyro_bias_drift_rad_s_per_sqrt_s: expected a number in "
                f"[0, {MAX_GYRO_DRIFT:g}], got {self.gyro_bias_drift_rad_s_per_sqrt_s}"
            )


def _check_range(section: str, values: dict[str, tuple[float, float]], obj: object) -> None:
    """ValueError naming the first field of ``obj`` outside its closed range."""
    for name, (lo, hi) in values.items():
        v = getattr(obj, name)
        if not lo <= v <= hi:
            raise ValueError(f"{section}.{name}: expected a number in [{lo:g}, {hi:g}], got {v}")


TYRE_RANGES = {
    "longitudinal_compliance": (0.0, 10.0),
    "cornering_compliance_rad": (0.0, 10.0),
    "scrub_arm_m": (0.0, 0.1),
    "scrub_saturation_curvature_1_m": (0.0, 1000.0),
}


@dataclass(frozen=True)
class TyreSpec:
    """Tyre compliance and scrub (all 0: rigid tyres that roll without slip, today's twin).

    Attributes
    ----------
    longitudinal_compliance : float
        Longitudinal creep: the slip ratio ``(omega r - v) / v`` per unit of the traction
        force over the wheel load, ``kappa = c F_x / N`` (the inverse of the tyre's
        normalised longitudinal stiffness) [1]. 0: no creep.
    cornering_compliance_rad : float
        Lateral slip: the slip angle of the axle per unit of the lateral force over the axle
        load, ``alpha = c F_y / N`` (the inverse of the normalised cornering stiffness)
        [rad]. 0: no side slip.
    scrub_arm_m : float
        Tyre scrub and caster drag in yaw: a moment of at most ``mu_d (N_L + N_R)
        scrub_arm_m`` against the yaw rate, which the wheels must overcome through their
        creep [m]. 0: no yaw friction.
    scrub_saturation_curvature_1_m : float
        Path curvature of a wheel at which its scrub reaches 76 % (tanh 1) of its full
        share [1/m]; 0: the full moment at any turn (Coulomb).
    """

    longitudinal_compliance: float = 0.0
    cornering_compliance_rad: float = 0.0
    scrub_arm_m: float = 0.0
    scrub_saturation_curvature_1_m: float = 0.0

    def __post_init__(self) -> None:
        _check_range("tyre", TYRE_RANGES, self)


VARIATION_RANGES = {
    "battery_v_sigma": (0.0, 1.0),
    "wheel_radius_sigma": (0.0, 0.05),
    "encoder_scale_sigma": (0.0, 0.05),
    "gyro_bias_sigma_rad_s": (0.0, 0.1),
    "floor_mu_sigma": (0.0, 0.3),
    "floor_patch_size_m": (0.01, 5.0),
    "caster_drag_sigma": (0.0, 0.3),
}


@dataclass(frozen=True)
class VariationSpec:
    """Per-trial variation, drawn from the twin's seed at the start of each trial (all sigmas
    0: every trial the same robot on the same floor, today's twin). Each draw is normal,
    truncated at 3 sigma, one per trial (per wheel where it says so).

    Attributes
    ----------
    battery_v_sigma : float
        Supply voltage of the motor rail around ``motor.battery_v`` [V]; the drive torque
        follows it, the gearbox friction does not (a low battery raises the breakaway duty).
    wheel_radius_sigma : float
        Effective rolling radius of each wheel, relative (0.005: 0.5 % SD) [1].
    encoder_scale_sigma : float
        Encoder mounting: each encoder's counts per wheel revolution, relative [1].
    gyro_bias_sigma_rad_s : float
        Turn-on gyro bias added to ``imu.gyro_bias_rad_s``, each axis [rad/s].
    floor_mu_sigma : float
        Friction patches: the floor's mu_s and mu_d times a smooth random field of mean 1
        and this SD, seeded per trial [1].
    floor_patch_size_m : float
        SD of the Gaussian kernel that smooths the field (patches about twice this
        across) [m].
    caster_drag_sigma : float
        The caster's rolling resistance (``caster_rolling_coeff``), relative: its bearing,
        its swivel and what it rolls over differ from day to day [1].
    """

    battery_v_sigma: float = 0.0
    wheel_radius_sigma: float = 0.0
    encoder_scale_sigma: float = 0.0
    gyro_bias_sigma_rad_s: float = 0.0
    floor_mu_sigma: float = 0.0
    floor_patch_size_m: float = 0.3
    caster_drag_sigma: float = 0.0

    def __post_init__(self) -> None:
        _check_range("variation", VARIATION_RANGES, self)


@dataclass(frozen=True)
class LidarMount:
    """The LiDAR's error model and pose on the robot (RPLIDAR A1M8 by default)."""

    enabled: bool = True
    noise_sigma_m: float = LIDAR_RANGE_NOISE_M
    extra_noise_sigma_m: float = 0.0
    dropout_probability: float = 0.0
    mount_x_m: float = 0.0
    mount_y_m: float = 0.0
    mount_yaw_rad: float = 0.0


@dataclass(frozen=True)
class RobotSpec:
    """The twin's true robot."""

    name: str
    mass_kg: float = 2.0
    inertia_kg_m2: float = 0.021  # about z through the axle centre
    wheel_radius_m: Sides = Sides(WHEEL_RADIUS_M, WHEEL_RADIUS_M)
    wheel_separation_m: float = WHEEL_SEPARATION_M  # B, between the contact points
    ticks_per_rev: Sides = Sides(TICKS_PER_REV, TICKS_PER_REV)
    envelope_x_m: tuple[float, float] = ENVELOPE_X_M  # collision envelope, base frame
    envelope_y_m: tuple[float, float] = ENVELOPE_Y_M
    caster_load_fraction: float = 0.2  # share of the weight on the caster
    caster_rolling_coeff: float = 0.02
    actuation_latency_s: float = 0.0
    motor: MotorSpec = field(default_factory=MotorSpec)
    wiring: WiringSpec = field(default_factory=WiringSpec)
    imu: ImuSpec = field(default_factory=ImuSpec)
    lidar: LidarMount = field(default_factory=LidarMount)
    tyre: TyreSpec = field(default_factory=TyreSpec)
    variation: VariationSpec = field(default_factory=VariationSpec)
    faults: tuple[FaultSpec, ...] = ()  # sensor and link faults (jackson.sim.faults)

    def __post_init__(self) -> None:
        if self.variation.battery_v_sigma * 3.0 >= self.motor.battery_v:
            raise ValueError(
                "variation.battery_v_sigma: 3 sigma must stay below motor.battery_v "
                f"({self.motor.battery_v:g}), got {self.variation.battery_v_sigma:g}"
            )


@dataclass(frozen=True)
class Cylinder:
    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class Trigger:
    """Inserts a cylinder once the robot is ``when_moved_m`` from its start position, or at
    ``at_s`` of MCU time; a timed one may leave again at ``remove_at_s``.

    Exactly one of ``when_moved_m`` and ``at_s`` is set. A timed drop never lands on the
    robot: while the robot's body (its radius plus ``DROP_CLEARANCE_M``) overlaps the cylinder
    the drop waits, and a drop still waiting at ``remove_at_s`` never happens
    (:meth:`jackson.sim.world.World.check_triggers`).

    Attributes
    ----------
    when_moved_m : float or None
        Distance of the robot from its start position that inserts the cylinder [m].
    cylinder : Cylinder
        The obstacle.
    at_s : float or None
        MCU time at which the cylinder appears [s].
    remove_at_s : float or None
        MCU time at which it disappears again (None: it stays) [s]; after ``at_s``.
    """

    when_moved_m: float | None
    cylinder: Cylinder
    at_s: float | None = None
    remove_at_s: float | None = None

    def __post_init__(self) -> None:
        if (self.when_moved_m is None) == (self.at_s is None):
            raise ValueError(
                f"trigger: give when_moved_m or at_s, exactly one, got {self.when_moved_m} "
                f"and {self.at_s}"
            )
        if self.remove_at_s is not None and (self.at_s is None or not self.remove_at_s > self.at_s):
            raise ValueError(
                f"trigger: remove_at_s must follow at_s ({self.at_s}), got {self.remove_at_s}"
            )


DROP_CLEARANCE_M = 0.1  # [m] a timed drop waits while the robot is within this of the cylinder


@dataclass(frozen=True)
class PatrolSpec:
    """Where a patrol generator may drop obstacles on a floor, and what it must never reach.

    Attributes
    ----------
    drop_spots : tuple of (float, float)
        Points in wide open space (at least 2.5 m across), where a dropped cylinder of 0.15 m
        radius never cuts a route [m].
    unreachable : tuple of (float, float)
        Points in free space enclosed with no way in (a storeroom without a door, a fenced
        cage): goals the navigator must refuse [m].
    """

    drop_spots: tuple[tuple[float, float], ...] = ()
    unreachable: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True)
class WorldSpec:
    """A floor with walls, cylinders and triggered obstacles.

    ``goal`` (the default goal of ``jackson run maze`` in this world) and ``survey`` (the
    waypoints ``jackson map`` drives through before it returns to the start) are optional;
    without them the Stage 3 goal of the paper is both. ``patrol`` (optional) tells a patrol
    generator where obstacles may drop and which points no route reaches.
    """

    name: str
    mu_static: float = 0.8
    mu_dynamic: float = 0.7
    walls: tuple[tuple[float, float, float, float], ...] = ()
    cylinders: tuple[Cylinder, ...] = ()
    triggers: tuple[Trigger, ...] = ()
    start_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    goal: tuple[float, float] | None = None
    survey: tuple[tuple[float, float], ...] = ()
    patrol: PatrolSpec | None = None


# ------------------------------------------------------------------------- validation


def resolve(name_or_path: str | Path, folder: Path, kind: str = "file") -> Path:
    """A bundled name (``jackson``) or a path to a YAML file. A bare name is the bundled file
    even when the working folder holds a folder of that name (a run folder called ``maze``)."""
    p = Path(name_or_path)
    bundled = folder / f"{name_or_path}.yaml"
    if p.suffix in (".yaml", ".yml") or p.is_file():
        return p
    if p.exists() and not bundled.exists():
        return p  # a folder: read_yaml says so
    if not bundled.exists():
        names = ", ".join(sorted(f.stem for f in folder.glob("*.yaml")))
        raise ConfigError(f"{kind} {name_or_path!r}: no such file, nor a bundled {kind} ({names})")
    return bundled


def load_robot(name_or_path: str | Path) -> RobotSpec:
    """Read and validate a robot file (a bundled name like ``jackson`` or a path)."""
    path = resolve(name_or_path, ROBOTS_DIR, "robot")
    where, data = read_yaml(path, "robot")
    r = Fields(where, data)
    if r.has("track_width_m"):  # the earlier name: the host's is the one
        raise r.fail("track_width_m", "renamed wheel_separation_m (as in the host config)")
    d = RobotSpec(path.stem)  # the defaults: the dataclasses' own
    motor = _motor(r, d.motor)
    wiring = _wiring(r, d.wiring)
    imu = _imu(r, d.imu)
    lidar = _lidar_mount(r, d.lidar)
    tyre = _tyre(r, d.tyre)
    variation = _variation(r, d.variation, motor)
    ex = bounds.vector(r, "envelope_x_m", d.envelope_x_m, bounds.ROBOT["envelope_m"])
    ey = bounds.vector(r, "envelope_y_m", d.envelope_y_m, bounds.ROBOT["envelope_m"])
    for key, (lo, hi) in (("envelope_x_m", ex), ("envelope_y_m", ey)):
        if not lo < 0 < hi:
            raise r.fail(key, f"expected [min < 0, max > 0] around the axle centre, got {[lo, hi]}")
    b = bounds.ROBOT
    spec = RobotSpec(
        name=r.text("name", path.stem),
        mass_kg=r.number("mass_kg", d.mass_kg, *b["mass_kg"]),
        inertia_kg_m2=r.number("inertia_kg_m2", d.inertia_kg_m2, *b["inertia_kg_m2"]),
        wheel_radius_m=Sides(
            *r.sides("wheel_radius_m", d.wheel_radius_m.left, *b["wheel_radius_m"])
        ),
        wheel_separation_m=r.number(
            "wheel_separation_m", d.wheel_separation_m, *b["wheel_separation_m"]
        ),
        ticks_per_rev=Sides(*r.sides("ticks_per_rev", d.ticks_per_rev.left, *b["ticks_per_rev"])),
        envelope_x_m=(ex[0], ex[1]),
        envelope_y_m=(ey[0], ey[1]),
        caster_load_fraction=r.number("caster_load_fraction", d.caster_load_fraction, 0, hi=0.9),
        caster_rolling_coeff=r.number("caster_rolling_coeff", d.caster_rolling_coeff, 0, hi=1.0),
        actuation_latency_s=r.number("actuation_latency_s", d.actuation_latency_s, 0, hi=1.0),
        motor=motor,
        wiring=wiring,
        imu=imu,
        lidar=lidar,
        tyre=tyre,
        variation=variation,
        faults=_faults(r),
    )
    r.finish()
    return spec


def _motor(r: Fields, dm: MotorSpec) -> MotorSpec:
    """The ``motor:`` section (defaults ``dm``)."""
    m = r.section("motor")
    b = bounds.MOTOR
    motor = MotorSpec(
        battery_v=m.number("battery_v", dm.battery_v, *b["battery_v"]),
        nominal_v=m.number("nominal_v", dm.nominal_v, *b["nominal_v"]),
        no_load_rpm=m.number("no_load_rpm", dm.no_load_rpm, *b["no_load_rpm"]),
        stall_torque_nm=m.number("stall_torque_nm", dm.stall_torque_nm, *b["stall_torque_nm"]),
        time_constant_s=m.number("time_constant_s", dm.time_constant_s, *b["time_constant_s"]),
        deadband_duty=Sides(*m.sides("deadband_duty", dm.deadband_duty.left, 0, hi=0.9)),
        gain=Sides(*m.sides("gain", dm.gain.left, 0, lo_open=True, hi=2.0)),
        wheel_inertia_kg_m2=m.number(
            "wheel_inertia_kg_m2", dm.wheel_inertia_kg_m2, *b["wheel_inertia_kg_m2"]
        ),
        ratings_net_of_friction=m.boolean("ratings_net_of_friction", dm.ratings_net_of_friction),
        running_friction_fraction=m.number(
            "running_friction_fraction", dm.running_friction_fraction, 0, 1.0, lo_open=True
        ),
    )
    m.finish()
    return motor


def _wiring(r: Fields, dw: WiringSpec) -> WiringSpec:
    """The ``wiring:`` section (defaults ``dw``): PCA9685 channels and the interlock line."""
    w = r.section("wiring")

    def wheel(key: str, default: MotorWiring) -> MotorWiring:
        if not w.has(key):
            w.used.add(key)
            return default
        s = w.section(key)
        out = MotorWiring(
            s.integer("pwm", default.pwm, 0, 15),
            s.integer("in1", default.in1, 0, 15),
            s.integer("in2", default.in2, 0, 15),
        )
        s.finish()
        return out

    wiring = WiringSpec(
        pca9685_address=w.integer("pca9685_address", dw.pca9685_address, 0x03, 0x77),
        left=wheel("left", dw.left),
        right=wheel("right", dw.right),
        stby_channel=w.optional_integer("stby_channel", 0, 15),
        interlock=w.text("interlock", dw.interlock),
    )
    if wiring.interlock not in INTERLOCKS:
        raise w.fail(
            "interlock", f"expected one of {', '.join(INTERLOCKS)}, got {wiring.interlock}"
        )
    if wiring.interlock == "tb6612_stby" and wiring.stby_channel is not None:
        raise w.fail(
            "interlock",
            f"tb6612_stby wires STBY to the MCU, but stby_channel is {wiring.stby_channel}",
        )
    w.finish()
    return wiring


def _imu(r: Fields, di: ImuSpec) -> ImuSpec:
    """The ``imu:`` section (defaults ``di``)."""
    i = r.section("imu")
    b = bounds.IMU
    imu = ImuSpec(
        gyro_bias_rad_s=_v3(
            bounds.vector(i, "gyro_bias_rad_s", di.gyro_bias_rad_s, b["gyro_bias_rad_s"])
        ),
        accel_bias_m_s2=_v3(
            bounds.vector(i, "accel_bias_m_s2", di.accel_bias_m_s2, b["accel_bias_m_s2"])
        ),
        gyro_noise_sigma_rad_s=i.number(
            "gyro_noise_sigma_rad_s", di.gyro_noise_sigma_rad_s, *b["gyro_noise_sigma_rad_s"]
        ),
        accel_noise_sigma_m_s2=i.number(
            "accel_noise_sigma_m_s2", di.accel_noise_sigma_m_s2, *b["accel_noise_sigma_m_s2"]
        ),
        gravity_scale=i.number("gravity_scale", di.gravity_scale, *b["gravity_scale"]),
        yaw_scale=i.number("yaw_scale", di.yaw_scale, *b["yaw_scale"]),
        present=i.boolean("present", di.present),
        gyro_bias_drift_rad_s_per_sqrt_s=i.number(
            "gyro_bias_drift_rad_s_per_sqrt_s",
            di.gyro_bias_drift_rad_s_per_sqrt_s,
            0,
            MAX_GYRO_DRIFT,
        ),
    )
    i.finish()
    return imu


def _lidar_mount(r: Fields, dl: LidarMount) -> LidarMount:
    """The ``lidar:`` section (defaults ``dl``)."""
    li = r.section("lidar")
    b = bounds.LIDAR
    lidar = LidarMount(
        enabled=li.boolean("enabled", dl.enabled),
        noise_sigma_m=li.number("noise_sigma_m", dl.noise_sigma_m, *b["noise_sigma_m"]),
        extra_noise_sigma_m=li.number(
            "extra_noise_sigma_m", dl.extra_noise_sigma_m, *b["extra_noise_sigma_m"]
        ),
        dropout_probability=li.number("dropout_probability", dl.dropout_probability, 0, hi=1.0),
        mount_x_m=li.number("mount_x_m", dl.mount_x_m, *b["mount_x_m"]),
        mount_y_m=li.number("mount_y_m", dl.mount_y_m, *b["mount_y_m"]),
        mount_yaw_rad=li.number("mount_yaw_rad", dl.mount_yaw_rad, *b["mount_yaw_rad"]),
    )
    li.finish()
    return lidar


def _tyre(r: Fields, dt: TyreSpec) -> TyreSpec:
    """The ``tyre:`` section (defaults ``dt``), each field in its :data:`TYRE_RANGES`."""
    ty = r.section("tyre")
    tyre = TyreSpec(
        **{k: ty.number(k, getattr(dt, k), lo, hi) for k, (lo, hi) in TYRE_RANGES.items()}
    )
    ty.finish()
    return tyre


def _variation(r: Fields, dv: VariationSpec, motor: MotorSpec) -> VariationSpec:
    """The ``variation:`` section (defaults ``dv``), each field in its
    :data:`VARIATION_RANGES`; the battery's 3 sigma stays below ``motor.battery_v``."""
    va = r.section("variation")
    variation = VariationSpec(
        **{k: va.number(k, getattr(dv, k), lo, hi) for k, (lo, hi) in VARIATION_RANGES.items()}
    )
    if variation.battery_v_sigma * 3.0 >= motor.battery_v:
        raise va.fail(
            "battery_v_sigma",
            f"3 sigma must stay below motor.battery_v ({motor.battery_v:g}), "
            f"got {variation.battery_v_sigma:g}",
        )
    va.finish()
    return variation


def _faults(r: Fields) -> tuple[FaultSpec, ...]:
    """The ``faults:`` list: mappings ``{kind, at_s, duration_s?, side?, <params>}``."""
    out = []
    for k, item in enumerate(r.items("faults")):
        name = f"faults[{k}]"
        if not isinstance(item, Mapping):
            expected = "expected {kind, at_s, duration_s?, side?, <parameters>}"
            raise r.fail(name, f"{expected}, got {show(item)}")
        f = Fields(r.where, item, f"{r.prefix}{name}.")
        kind = item.get("kind")
        if kind not in PARAMS:
            raise f.fail("kind", f"expected one of {', '.join(PARAMS)}, got {show(kind)}")
        f.used.add("kind")
        if not f.has("at_s"):
            raise f.fail("at_s", "missing (the onset on MCU time, in seconds)")
        at_s = f.number("at_s", 0.0, 0)
        duration = f.optional_number("duration_s", 0, lo_open=True)
        side = None
        if kind in SIDED_KINDS:
            f.used.add("side")
            side = item.get("side")
        params = {key: f.number(key, p.default) for key, p in PARAMS[kind].items()}
        unknown = sorted(str(key) for key in item if key not in f.used)
        if unknown:
            sided = ["side"] if kind in SIDED_KINDS else []
            keys = ", ".join(["kind", "at_s", "duration_s", *sided])
            keys += "".join(f", {key}" for key in PARAMS[kind])
            raise f.fail(unknown[0], f"unknown field for {kind} (valid: {keys})")
        try:
            out.append(FaultSpec(str(kind), at_s, duration, side, params))
        except FaultError as exc:  # "fault KIND: FIELD: problem"
            field_name, _, problem = str(exc).split(": ", 1)[1].partition(": ")
            raise f.fail(field_name, problem) from None
    return tuple(out)


def _v3(v: tuple[float, ...]) -> tuple[float, float, float]:
    return (v[0], v[1], v[2])


MIN_WALL_M = 0.001  # [m] shortest wall: a point is no wall, and the raycaster divides by length


def load_world(name_or_path: str | Path) -> WorldSpec:
    """Read and validate a world file (a bundled name like ``open_floor`` or a path)."""
    path = resolve(name_or_path, WORLDS_DIR, "world")
    where, data = read_yaml(path, "world")
    r = Fields(where, data)
    f = r.section("floor")
    d = WorldSpec(path.stem)  # the defaults: the dataclass's own
    mu_s = f.number("mu_static", d.mu_static, *bounds.FRICTION)
    mu_d = f.number("mu_dynamic", d.mu_dynamic, *bounds.FRICTION)
    f.finish()
    if mu_d > mu_s:
        raise r.fail("floor.mu_dynamic", f"must not exceed mu_static ({mu_s:g}), got {mu_d:g}")
    walls = []
    for k, w in enumerate(r.items("walls")):
        if (
            not isinstance(w, list)
            or len(w) != 4
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in w)
        ):
            raise r.fail(f"walls[{k}]", f"expected [x1, y1, x2, y2] in metres, got {show(w)}")
        if not all(math.isfinite(x) and abs(x) <= bounds.WORLD_EXTENT_M for x in w):
            raise r.fail(f"walls[{k}]", f"expected numbers in {bounds.EXTENT_TEXT}, got {show(w)}")
        if math.hypot(w[2] - w[0], w[3] - w[1]) < MIN_WALL_M:
            raise r.fail(
                f"walls[{k}]", f"zero length (under {MIN_WALL_M * 1000:g} mm), got {show(w)}"
            )
        walls.append((float(w[0]), float(w[1]), float(w[2]), float(w[3])))

    cylinders = []
    for k, c in enumerate(r.items("cylinders")):
        if not isinstance(c, Mapping):
            raise r.fail(f"cylinders[{k}]", f"expected {{x, y, radius}}, got {show(c)}")
        cylinders.append(_cylinder(Fields(where, c, f"cylinders[{k}].")))
    triggers = [_trigger(r, k, t) for k, t in enumerate(r.items("triggers"))]
    start = r.vector("start_pose", d.start_pose, 3)
    if not all(abs(x) <= bounds.WORLD_EXTENT_M for x in start[:2]):
        raise r.fail(
            "start_pose", f"expected x and y in {bounds.EXTENT_TEXT}, got {show(list(start))}"
        )
    bounds.not_on_start(r, triggers, start)
    goal = None
    if r.has("goal"):
        gx, gy = bounds.vector(r, "goal", (0.0, 0.0), bounds.EXTENT)
        goal = (gx, gy)
    survey = _points(r, "survey")
    patrol = None
    if r.has("patrol"):
        p = r.section("patrol")
        patrol = PatrolSpec(_points(p, "drop_spots"), _points(p, "unreachable"))
        p.finish()
    spec = WorldSpec(
        name=r.text("name", path.stem),
        mu_static=mu_s,
        mu_dynamic=mu_d,
        walls=tuple(walls),
        cylinders=tuple(cylinders),
        triggers=tuple(triggers),
        start_pose=(start[0], start[1], start[2]),
        goal=goal,
        survey=survey,
        patrol=patrol,
    )
    r.finish()
    return spec


def _cylinder(reader: Fields) -> Cylinder:
    """A ``{x, y, radius}`` mapping."""
    c = Cylinder(
        reader.number("x", math.nan, *bounds.EXTENT),
        reader.number("y", math.nan, *bounds.EXTENT),
        reader.number("radius", math.nan, *bounds.CYLINDER_RADIUS_M),
    )
    for key in ("x", "y", "radius"):
        if not reader.has(key):
            raise reader.fail(key, "missing")
    reader.finish()
    return c


def _trigger(r: Fields, k: int, t: object) -> Trigger:
    """``triggers[k]``: ``{when_moved_m, add_cylinder}`` or ``{at_s, remove_at_s?,
    add_cylinder}``."""
    if not isinstance(t, Mapping):
        expected = "expected {when_moved_m or at_s, remove_at_s?, add_cylinder}"
        raise r.fail(f"triggers[{k}]", f"{expected}, got {show(t)}")
    tr = Fields(r.where, t, f"{r.prefix}triggers[{k}].")
    if tr.has("when_moved_m") and tr.has("at_s"):
        raise tr.fail("at_s", "give when_moved_m or at_s, not both")
    if not tr.has("when_moved_m") and not tr.has("at_s"):
        raise tr.fail("when_moved_m", "missing (or at_s, the MCU time of a timed drop)")
    if not tr.has("add_cylinder"):
        raise tr.fail("add_cylinder", "missing")
    if tr.data.get("remove_at_s") is not None and not tr.has("at_s"):
        raise tr.fail("remove_at_s", "only a timed drop (at_s) is removed, not when_moved_m")
    moved = (
        tr.number("when_moved_m", 0.0, *bounds.TRIGGER_MOVED_M) if tr.has("when_moved_m") else None
    )
    at_s = tr.number("at_s", 0.0, 0) if tr.has("at_s") else None
    remove_at_s = tr.optional_number("remove_at_s", 0)
    if at_s is not None and remove_at_s is not None and not remove_at_s > at_s:
        raise tr.fail("remove_at_s", f"expected a time after at_s ({at_s:g}), got {remove_at_s:g}")
    trigger = Trigger(moved, _cylinder(tr.section("add_cylinder")), at_s, remove_at_s)
    tr.finish()
    return trigger


def _points(r: Fields, key: str) -> tuple[tuple[float, float], ...]:
    """The list ``key`` of ``[x, y]`` points in metres, each finite."""
    out = []
    for k, w in enumerate(r.items(key)):
        if (
            not isinstance(w, list)
            or len(w) != 2
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in w)
            or not all(math.isfinite(x) for x in w)
        ):
            raise r.fail(f"{key}[{k}]", f"expected [x, y] in metres, got {show(w)}")
        out.append((float(w[0]), float(w[1])))
    return tuple(out)
