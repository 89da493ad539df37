"""The twin's imperfections: motor ratings net of friction, tyre creep and scrub, per-trial
variation (supply, wheel radii, encoders, gyro bias, friction patches) and gyro bias drift.

Each is off by default and, off, leaves a trajectory bit for bit as it was; on, it changes
what it models, and a seed reproduces a trial bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from jackson.sim.config import (
    ConfigError,
    RobotSpec,
    Sides,
    TyreSpec,
    VariationSpec,
    WorldSpec,
    load_robot,
    load_world,
)
from jackson.sim.mcu import SensorSample
from jackson.sim.robot import WheelDrive
from jackson.sim.twin import Truth, Twin, draw_trial
from jackson.sim.world import FrictionField, periodic_gaussian

FLOOR = WorldSpec(name="test_floor", mu_static=0.8, mu_dynamic=0.7)
TOP_SPEED_M_S = 100.0 * 2.0 * math.pi / 60.0 * 0.033  # REFERENCE: 100 RPM x r 0.033 m

# every new field at its "off" value, as a robot file would spell it
OFF_FIELDS: dict[str, dict[str, object]] = {
    "motor": {"ratings_net_of_friction": False, "running_friction_fraction": 1.0},
    "imu": {"gyro_bias_drift_rad_s_per_sqrt_s": 0.0},
    "tyre": {
        "longitudinal_compliance": 0.0,
        "cornering_compliance_rad": 0.0,
        "scrub_arm_m": 0.0,
        "scrub_saturation_curvature_1_m": 0.0,
    },
    "variation": {
        "battery_v_sigma": 0.0,
        "wheel_radius_sigma": 0.0,
        "encoder_scale_sigma": 0.0,
        "gyro_bias_sigma_rad_s": 0.0,
        "floor_mu_sigma": 0.0,
        "floor_patch_size_m": 0.3,
        "caster_drag_sigma": 0.0,
    },
}
# one "on" value per field (scrub only shows with creep, so it brings some)
ON_FIELDS: dict[tuple[str, str], dict[str, object]] = {
    ("motor", "ratings_net_of_friction"): {"ratings_net_of_friction": True},
    ("motor", "running_friction_fraction"): {"running_friction_fraction": 0.5},
    ("imu", "gyro_bias_drift_rad_s_per_sqrt_s"): {"gyro_bias_drift_rad_s_per_sqrt_s": 1e-3},
    ("tyre", "longitudinal_compliance"): {"longitudinal_compliance": 0.2},
    ("tyre", "cornering_compliance_rad"): {"cornering_compliance_rad": 0.5},
    ("tyre", "scrub_arm_m"): {"scrub_arm_m": 0.01},
    ("tyre", "scrub_saturation_curvature_1_m"): {
        "scrub_arm_m": 0.01,
        "longitudinal_compliance": 0.1,
        "scrub_saturation_curvature_1_m": 5.0,
    },
    ("variation", "battery_v_sigma"): {"battery_v_sigma": 0.2},
    ("variation", "wheel_radius_sigma"): {"wheel_radius_sigma": 0.01},
    ("variation", "encoder_scale_sigma"): {"encoder_scale_sigma": 0.01},
    ("variation", "gyro_bias_sigma_rad_s"): {"gyro_bias_sigma_rad_s": 0.01},
    ("variation", "floor_mu_sigma"): {"floor_mu_sigma": 0.2},
    ("variation", "caster_drag_sigma"): {"caster_drag_sigma": 0.2},
}


def robot(**changes: object) -> RobotSpec:
    base = dataclasses.replace(load_robot("jackson"), name="test")
    return dataclasses.replace(base, **changes)  # type: ignore[arg-type]


def with_tyre(**fields: float) -> RobotSpec:
    return robot(tyre=TyreSpec(**fields))


def with_variation(**fields: float) -> RobotSpec:
    return robot(variation=VariationSpec(**fields))


def drive(d: float) -> WheelDrive:
    return WheelDrive(d, 1.0)


def robot_file(tmp_path: Path, name: str, sections: dict[str, dict[str, object]]) -> Path:
    """jackson.yaml with fields added to (or set in) its sections."""
    data = yaml.safe_load((Path(__file__).parents[2] / "sim/robots/jackson.yaml").read_text())
    for section, fields in sections.items():
        data.setdefault(section, {}).update(fields)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def short_drive(
    spec: RobotSpec, world: WorldSpec = FLOOR, seed: int = 3
) -> tuple[list[Truth], list[SensorSample]]:
    """Ahead, an arc, a turn on the spot, a brake and a full-duty dash, sensors at 20 Hz."""
    tw = Twin(world, spec, lidar=False, seed=seed)
    samples = []
    for left, right, periods in ((0.6, 0.6, 20), (0.3, 0.7, 20), (-0.5, 0.5, 20), (1.0, 1.0, 20)):
        tw.command(drive(left), drive(right))
        for _ in range(periods):
            tw.advance(0.05)
            samples.append(tw.sensors())
    tw.command(WheelDrive.brake(), WheelDrive.brake())
    tw.advance(0.5)
    samples.append(tw.sensors())
    return list(tw.truth_log), samples


# ------------------------------------------------------------------------------- off


def test_every_new_field_off_is_todays_twin_bit_for_bit(tmp_path: Path) -> None:
    today = short_drive(load_robot("jackson"))
    explicit = load_robot(robot_file(tmp_path, "explicit_off", OFF_FIELDS))
    assert dataclasses.replace(explicit, name="jackson") == load_robot("jackson")
    assert short_drive(explicit) == today


@pytest.mark.parametrize("key", list(ON_FIELDS), ids=lambda k: ".".join(k))
def test_each_field_off_is_bit_identical_and_on_changes_the_trial(
    tmp_path: Path, key: tuple[str, str]
) -> None:
    section, name = key
    off = load_robot(robot_file(tmp_path, "off", {section: {name: OFF_FIELDS[section][name]}}))
    on = load_robot(robot_file(tmp_path, "on", {section: ON_FIELDS[key]}))
    today = short_drive(load_robot("jackson"))
    assert short_drive(off) == today
    assert short_drive(on) != today


def test_the_physical_robot_file_carries_its_fitted_imperfections() -> None:
    # jackson_physical is fitted to the paper's Tables 5-7 (docs/fidelity.md): tyre scrub,
    # ratings at the wheel, gyro drift and per-trial variation on; two seeds, two trials
    physical = load_robot("jackson_physical")
    assert physical.tyre != TyreSpec()
    assert physical.variation != VariationSpec()
    assert physical.motor.ratings_net_of_friction
    assert physical.imu.gyro_bias_drift_rad_s_per_sqrt_s > 0.0
    assert draw_trial(physical, 1) == draw_trial(physical, 1)
    assert draw_trial(physical, 1) != draw_trial(physical, 2)


# ------------------------------------------------------------------------- the motor


def full_duty_speed(spec: RobotSpec) -> float:
    tw = Twin(FLOOR, spec, lidar=False)
    tw.command(drive(1.0), drive(1.0))
    tw.advance(3.0)
    return tw.truth().vx


def test_ratings_net_of_friction_reach_the_physical_top_speed() -> None:
    today = full_duty_speed(robot())
    assert today == pytest.approx(0.9 * TOP_SPEED_M_S, rel=0.01)  # Coulomb = breakaway: 10 % low
    for fraction in (1.0, 0.5):
        net = robot(
            motor=dataclasses.replace(
                robot().motor, ratings_net_of_friction=True, running_friction_fraction=fraction
            )
        )
        speed = full_duty_speed(net)
        assert speed == pytest.approx(TOP_SPEED_M_S, rel=0.02)
        assert speed < TOP_SPEED_M_S  # less the caster's rolling resistance


def test_breakaway_stays_at_the_deadband_duty_with_ratings_net_of_friction() -> None:
    net = robot(motor=dataclasses.replace(robot().motor, ratings_net_of_friction=True))
    tw = Twin(FLOOR, net, lidar=False)
    tw.command(drive(0.095), drive(0.095))
    tw.advance(2.0)
    assert tw.truth().x == 0.0
    tw.command(drive(0.12), drive(0.12))
    tw.advance(2.0)
    assert tw.truth().x > 0.005


def test_running_friction_below_breakaway_keeps_a_turning_wheel_going() -> None:
    def coast_at(duty: float, fraction: float) -> float:
        spec = robot(motor=dataclasses.replace(robot().motor, running_friction_fraction=fraction))
        tw = Twin(FLOOR, spec, lidar=False)
        tw.command(drive(0.3), drive(0.3))
        tw.advance(1.0)
        tw.command(drive(duty), drive(duty))  # below the 0.10 breakaway duty
        tw.advance(2.0)
        return tw.truth().vx

    assert coast_at(0.09, 1.0) == 0.0  # running = breakaway: it stops
    assert coast_at(0.09, 0.5) > 0.01  # it keeps rolling, as a real gearbox does
    # ... but a wheel at rest still needs the breakaway duty
    spec = robot(motor=dataclasses.replace(robot().motor, running_friction_fraction=0.5))
    tw = Twin(FLOOR, spec, lidar=False)
    tw.command(drive(0.09), drive(0.09))
    tw.advance(2.0)
    assert tw.truth().x == 0.0


# -------------------------------------------------------------------------- the tyres


def steady_turn(spec: RobotSpec, left: float, right: float) -> tuple[float, float]:
    """(true yaw rate, the no-slip yaw rate of the wheels) after 5 s at constant duties."""
    tw = Twin(FLOOR, spec, lidar=False)
    tw.command(drive(left), drive(right))
    tw.advance(5.0)
    r = tw.robot
    return tw.truth().wz, (r.omega_r * r.r_r - r.omega_l * r.r_l) / spec.wheel_separation_m


def test_rigid_tyres_turn_at_the_wheels_yaw_rate() -> None:
    wz, no_slip = steady_turn(robot(), -0.5, 0.5)
    assert wz == pytest.approx(no_slip, rel=1e-9)


def test_scrub_with_creep_turns_slower_than_the_wheels_say() -> None:
    for left, right in ((-0.5, 0.5), (0.3, 0.45), (0.45, 0.3)):
        wz, no_slip = steady_turn(
            with_tyre(longitudinal_compliance=0.1, scrub_arm_m=0.01), left, right
        )
        assert abs(wz) < abs(no_slip) * 0.995
        assert wz * no_slip > 0


def test_in_place_turn_loses_the_brush_model_share_of_its_angle() -> None:
    # both wheels push the scrub moment M = a mu_d 2N through their creep c F v / N:
    # the turn loses 2 c a mu_d / B of the wheels' yaw rate
    c, a = 0.1, 0.01
    wz, no_slip = steady_turn(with_tyre(longitudinal_compliance=c, scrub_arm_m=a), -0.5, 0.5)
    expected = 1.0 - 2.0 * c * a * FLOOR.mu_dynamic / robot().wheel_separation_m
    assert wz / no_slip == pytest.approx(expected, rel=1e-3)


def test_scrub_saturation_lets_a_wide_arc_scrub_less_than_a_pivot() -> None:
    def loss(spec: RobotSpec, left: float, right: float) -> float:
        wz, no_slip = steady_turn(spec, left, right)
        return 1.0 - wz / no_slip

    coulomb = with_tyre(longitudinal_compliance=0.1, scrub_arm_m=0.01)
    rolling = with_tyre(
        longitudinal_compliance=0.1, scrub_arm_m=0.01, scrub_saturation_curvature_1_m=20.0
    )
    assert loss(rolling, 0.3, 0.45) < 0.5 * loss(coulomb, 0.3, 0.45)
    # on the spot each wheel's path curvature is 2/B: tanh(2 / (B phi_s)) of the full share
    share = math.tanh(2.0 / (robot().wheel_separation_m * 20.0))
    assert loss(rolling, -0.5, 0.5) == pytest.approx(share * loss(coulomb, -0.5, 0.5), rel=1e-3)


def test_cornering_compliance_gives_the_slip_angle_of_the_centripetal_force() -> None:
    c = 0.5
    spec = with_tyre(cornering_compliance_rad=c)
    tw = Twin(FLOOR, spec, lidar=False)
    tw.command(drive(0.3), drive(0.6))
    tw.advance(5.0)
    t = tw.truth()
    axle_load = spec.mass_kg * 9.81 * (1.0 - spec.caster_load_fraction)
    slip_angle = c * spec.mass_kg * t.vx * t.wz / axle_load  # alpha = c F_y / N
    # outwards of the turn; the truth's body frame has turned by one step's yaw since
    turned = t.wz * tw.dt
    assert t.vy == pytest.approx(-(slip_angle + turned) * t.vx, rel=0.02)
    rigid = Twin(FLOOR, robot(), lidar=False)
    rigid.command(drive(0.3), drive(0.6))
    rigid.advance(5.0)
    r = rigid.truth()
    assert r.vy == pytest.approx(-r.wz * rigid.dt * r.vx, rel=0.02)
    assert abs(r.vy) < 0.5 * abs(t.vy)


# ------------------------------------------------------------------ per-trial variation

TRIAL = dict(
    battery_v_sigma=0.2,
    wheel_radius_sigma=0.005,
    encoder_scale_sigma=0.005,
    gyro_bias_sigma_rad_s=0.002,
    floor_mu_sigma=0.1,
    caster_drag_sigma=0.2,
)


def test_a_seed_reproduces_a_varied_trial_bit_for_bit() -> None:
    spec = dataclasses.replace(
        with_variation(**TRIAL),
        tyre=TyreSpec(longitudinal_compliance=0.1, scrub_arm_m=0.01),
        imu=dataclasses.replace(robot().imu, gyro_bias_drift_rad_s_per_sqrt_s=1e-4),
    )
    a, b, other = short_drive(spec, seed=5), short_drive(spec, seed=5), short_drive(spec, seed=6)
    assert a == b
    assert a[0] != other[0] and a[1] != other[1]
    assert draw_trial(spec, 5) == draw_trial(spec, 5)
    one, two = draw_trial(spec, 5), draw_trial(spec, 6)
    for name in (
        "battery_v",
        "wheel_radius_m",
        "encoder_scale",
        "gyro_bias_rad_s",
        "floor",
        "caster_rolling_coeff",
    ):
        assert getattr(one, name) != getattr(two, name), name


def test_variation_leaves_the_sensor_noise_stream_alone() -> None:
    # the noise of a seed is the same with or without variation: a trial differs only
    # by what was drawn for it
    plain = Twin(FLOOR, robot(), lidar=False, seed=9)
    varied = Twin(FLOOR, with_variation(battery_v_sigma=0.2), lidar=False, seed=9)
    for tw in (plain, varied):
        tw.advance(0.05)
    assert plain.sensors() == varied.sensors()  # at rest: noise only


def test_trial_draws_have_the_configured_spread() -> None:
    spec = with_variation(**TRIAL)
    draws = [draw_trial(spec, seed) for seed in range(400)]
    battery = np.array([d.battery_v for d in draws])
    radius = np.array([d.wheel_radius_m.left for d in draws]) / 0.033 - 1.0
    ticks = np.array([d.encoder_scale.right for d in draws]) - 1.0
    bias = np.array([d.gyro_bias_rad_s[2] for d in draws])
    caster = np.array([d.caster_rolling_coeff for d in draws]) / spec.caster_rolling_coeff - 1.0
    # the SD of 400 draws is within 10 % of sigma with probability > 0.99 (3-sigma truncation
    # takes 1.5 % off)
    assert battery.mean() == pytest.approx(6.0, abs=0.03)
    assert battery.std() == pytest.approx(0.2, rel=0.1)
    assert radius.std() == pytest.approx(0.005, rel=0.1)
    assert ticks.std() == pytest.approx(0.005, rel=0.1)
    assert bias.std() == pytest.approx(0.002, rel=0.1)
    assert caster.std() == pytest.approx(0.2, rel=0.1)
    assert np.abs(caster).max() <= 3 * 0.2 + 1e-12
    assert np.abs(battery - 6.0).max() <= 3 * 0.2 + 1e-12


@pytest.mark.parametrize("seed", range(4))
def test_the_floors_smoothing_is_scipys_gaussian_filter_bit_for_bit(seed: int) -> None:
    from scipy.ndimage import gaussian_filter, gaussian_filter1d

    rng = np.random.default_rng(seed)
    noise = rng.standard_normal((128, 128))
    ours = periodic_gaussian(periodic_gaussian(noise, 4, 0), 4, 1)
    assert np.array_equal(ours, gaussian_filter(noise, 4, mode="wrap"))
    # other sizes and widths, a kernel wider than the tile included
    for _ in range(10):
        a = rng.standard_normal((int(rng.integers(3, 60)), int(rng.integers(3, 60))))
        sigma, axis = float(rng.uniform(0.3, 8.0)), int(rng.integers(0, 2))
        assert np.array_equal(
            periodic_gaussian(a, sigma, axis), gaussian_filter1d(a, sigma, axis, mode="wrap")
        )


def test_friction_field_has_the_configured_spread_and_patch_size() -> None:
    field = FrictionField.random(np.random.default_rng(1), 0.1, 0.3)
    cells = np.array(field.cells)
    assert cells.mean() == pytest.approx(1.0, abs=1e-3)
    assert cells.std() == pytest.approx(0.1, rel=0.02)
    assert field.resolution_m == pytest.approx(0.075)
    # neighbouring cells are close (patches), cells a metre apart are not
    step = np.abs(np.diff(cells, axis=0)).mean()
    far = np.abs(cells - np.roll(cells, 13, axis=0)).mean()
    assert step < 0.03 < far
    # periodic: the floor never ends
    tile = len(field.cells) * field.resolution_m
    assert field.factor(0.31, -0.47) == field.factor(0.31 + tile, -0.47 - 2 * tile)


def test_friction_patches_change_how_a_hard_start_slips() -> None:
    low = load_world("low_friction")

    def slid(spec: RobotSpec, seed: int) -> float:
        tw = Twin(low, spec, lidar=False, seed=seed)
        tw.command(drive(1.0), drive(1.0))  # a hard step from rest: the wheels spin
        tw.advance(0.5)
        r = tw.robot
        return (r.angle_l * r.r_l + r.angle_r * r.r_r) / 2.0 - tw.truth().x

    uniform = {slid(robot(), seed) for seed in (1, 2, 3)}
    assert len(uniform) == 1  # one floor for all seeds
    patches = with_variation(floor_mu_sigma=0.25, floor_patch_size_m=0.05)
    slides = {slid(patches, seed) for seed in (1, 2, 3)}
    assert len(slides) == 3
    assert min(slides) > 0.0


def test_supply_voltage_scales_the_drive_not_the_friction() -> None:
    spec = with_variation(battery_v_sigma=0.3)
    seed = next(s for s in range(100) if draw_trial(spec, s).battery_v < 5.8)
    low = Twin(FLOOR, spec, lidar=False, seed=seed)
    nominal = Twin(FLOOR, robot(), lidar=False, seed=seed)
    ratio = low.trial.battery_v / 6.0
    assert low.robot.tau_drive_l == pytest.approx(nominal.robot.tau_drive_l * ratio, rel=1e-12)
    assert low.robot.tau_c_l == nominal.robot.tau_c_l
    for tw in (low, nominal):
        tw.command(drive(1.0), drive(1.0))
        tw.advance(3.0)
    assert low.truth().vx < nominal.truth().vx * (ratio + 0.005)


def test_the_casters_drag_slows_forward_motion_only() -> None:
    spec = with_variation(caster_drag_sigma=0.3)
    seed = next(s for s in range(100) if draw_trial(spec, s).caster_rolling_coeff > 0.025)
    draggy = Twin(FLOOR, spec, lidar=False, seed=seed)
    nominal = Twin(FLOOR, robot(), lidar=False, seed=seed)
    ratio = draggy.trial.caster_rolling_coeff / robot().caster_rolling_coeff
    assert draggy.robot.f_caster == pytest.approx(nominal.robot.f_caster * ratio, rel=1e-12)
    for tw in (draggy, nominal):
        tw.command(drive(0.2), drive(0.2))
        tw.advance(3.0)
    assert draggy.truth().vx < nominal.truth().vx - 1e-4
    spun = []
    for tw in (
        Twin(FLOOR, spec, lidar=False, seed=seed),
        Twin(FLOOR, robot(), lidar=False, seed=seed),
    ):
        tw.command(drive(-0.5), drive(0.5))
        tw.advance(2.0)
        spun.append(tw.truth().wz)
    assert spun[0] == pytest.approx(spun[1], rel=1e-9)  # on the spot the caster only swivels


def test_encoder_mounting_and_wheel_radius_act_per_wheel() -> None:
    spec = with_variation(wheel_radius_sigma=0.01, encoder_scale_sigma=0.01)
    tw = Twin(FLOOR, spec, lidar=False, seed=4)
    cond = tw.trial
    assert cond.wheel_radius_m != Sides(0.033, 0.033)
    assert (tw.robot.r_l, tw.robot.r_r) == (cond.wheel_radius_m.left, cond.wheel_radius_m.right)
    tw.command(drive(0.5), drive(-0.4))
    tw.advance(3.0)
    s = tw.sensors()
    rl, rr = tw.robot.angle_l / (2 * math.pi), tw.robot.angle_r / (2 * math.pi)
    assert s.enc_left == math.floor(rl * 621 * cond.encoder_scale.left)
    assert s.enc_right == math.floor(rr * 621 * cond.encoder_scale.right)
    assert s.enc_left != math.floor(rl * 621) or s.enc_right != math.floor(rr * 621)


def test_gyro_bias_drifts_as_a_random_walk_of_the_configured_sigma() -> None:
    sigma, seconds, n = 2e-4, 30.0, 300
    spec = robot(imu=dataclasses.replace(robot().imu, gyro_bias_drift_rad_s_per_sqrt_s=sigma))
    finals = []
    for seed in range(n):
        tw = Twin(FLOOR, spec, lidar=False, seed=seed, record_truth=False)
        for _ in range(round(seconds * 20)):
            tw.advance(0.05)
            tw.sensors()
        finals.append(tw.imu.gyro_bias_rad_s)
    bias = np.array(finals)
    # SD sigma sqrt(T) per axis; 900 values: the SD's sampling error is about 2.4 %
    assert bias.std() == pytest.approx(sigma * math.sqrt(seconds), rel=0.08)
    assert np.abs(bias.mean()) < 3 * sigma * math.sqrt(seconds / bias.size)
    # and the gyro reads it: a robot at rest, the mean of its last samples
    tw = Twin(FLOOR, spec, lidar=False, seed=0)
    gyro_z = []
    for _ in range(400):
        tw.advance(0.05)
        gyro_z.append(tw.sensors().gyro[2])
    mean_rad_s = np.mean(gyro_z[-40:]) / 131.0 * math.pi / 180.0
    assert mean_rad_s == pytest.approx(tw.imu.gyro_bias_rad_s[2], abs=1.5e-4)


# --------------------------------------------------------------------- robot-file errors


@pytest.mark.parametrize(
    ("section", "fields", "message"),
    [
        ("motor", {"running_friction_fraction": 0}, r"motor\.running_friction_fraction: "),
        ("motor", {"ratings_net_of_friction": 1}, r"motor\.ratings_net_of_friction: expected"),
        ("tyre", {"scrub_arm_m": -0.01}, r"tyre\.scrub_arm_m: expected a number in \[0, 0\.1\]"),
        ("tyre", {"slip": 1}, r"tyre\.slip: unknown field"),
        ("variation", {"battery_v_sigma": 1.5}, r"variation\.battery_v_sigma: expected"),
        ("variation", {"floor_patch_size_m": 0}, r"variation\.floor_patch_size_m: expected"),
        ("imu", {"gyro_bias_drift_rad_s_per_sqrt_s": 1}, r"imu\.gyro_bias_drift_rad_s_per"),
    ],
)
def test_a_bad_imperfection_gets_one_line(
    tmp_path: Path, section: str, fields: dict[str, object], message: str
) -> None:
    with pytest.raises(ConfigError, match=f"^robot bad.yaml: {message}") as info:
        load_robot(robot_file(tmp_path, "bad", {section: fields}))
    assert "\n" not in str(info.value)


def test_battery_sigma_must_keep_the_supply_positive(tmp_path: Path) -> None:
    path = robot_file(tmp_path, "bad", {"motor": {"battery_v": 1.0}})
    data = yaml.safe_load(path.read_text())
    data["variation"] = {"battery_v_sigma": 0.5}
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=r"variation\.battery_v_sigma: 3 sigma must stay below"):
        load_robot(path)
    with pytest.raises(ValueError, match="running_friction_fraction"):
        dataclasses.replace(robot().motor, running_friction_fraction=1.5)
