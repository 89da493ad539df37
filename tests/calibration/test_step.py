"""Step-response identification: each wheel's motor model per direction, and the host's gains.

The fit is checked against steps made from the model itself, then on the twin: a robot file
whose right drive is 8 % weaker than its left (``motor.gain: {left: 1.0, right: 0.92}``),
recorded through the daemon with :class:`WheelStepScript` as its command source; the gains
it identifies, written into the host's configuration, make the figure-eight's two loops the
same size again.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml

from jackson.calibration import runs
from jackson.calibration.procedures import CalibrationError, RunData
from jackson.calibration.procedures.base import check_start
from jackson.calibration.procedures.step import (
    MAX_DEAD_TIME_S,
    DutyStep,
    StepIdentification,
    WheelStepScript,
    find_steps,
    identify_steps,
    step_angle,
    step_plan,
)
from jackson.experiments.trial import TrialSpec, run_trial
from jackson.host.actuation.deadband import DeadbandConfig, wheel_duty
from jackson.host.config import HostConfig, dump_config
from jackson.host.estimation.odometry import RobotGeometry
from jackson.sim.config import ROBOTS_DIR, RobotSpec, load_robot

from ..sil.harness import TwinThread, host_config

GEOMETRY = RobotGeometry()
TPR = GEOMETRY.ticks_per_rev_left
DT_S = 0.005  # [s] 200 Hz telemetry, as the step runs are recorded
HIDDEN_GAIN = (1.0, 0.92)  # the twin's left and right drive
HOST_SILENT_S = 120.0  # [s] of wall time without a HEARTBEAT before the twin moves on alone


# ------------------------------------------------------------------------- model-made steps

TRUE = {  # (side, direction): K [rad/s], d_0, tau [s], t_d [s]
    ("left", "forward"): (10.4, 0.10, 0.030, 0.010),
    ("left", "reverse"): (10.1, 0.12, 0.032, 0.012),
    ("right", "forward"): (9.6, 0.14, 0.028, 0.008),
    ("right", "reverse"): (9.9, 0.11, 0.035, 0.015),
}


def model_run(duties: tuple[float, ...] = (0.35, 0.7), drive_s: float = 1.0) -> RunData:
    """A raw duty run of :func:`step_plan`'s steps, the counts made by the model (floored)."""
    t: list[float] = []
    duty: dict[str, list[float]] = {"left": [], "right": []}
    angle: dict[str, list[float]] = {"left": [], "right": []}
    held = {"left": 0.0, "right": 0.0}
    now = 0.0

    def rest(seconds: float) -> None:
        nonlocal now
        for _ in range(round(seconds / DT_S)):
            t.append(now)
            for side in held:
                duty[side].append(0.0)
                angle[side].append(held[side])
            now += DT_S

    rest(0.5)
    for step in step_plan(duties, drive_s):
        k_frames = round(step.drive_s / DT_S)
        start = dict(held)
        for k in range(k_frames + 1):
            t.append(now)
            for side, d in (("left", step.left), ("right", step.right)):
                sign = 1.0 if d > 0 else -1.0
                gain, d0, tau, t_d = TRUE[(side, "forward" if d > 0 else "reverse")]
                phi = float(step_angle(np.array([k * DT_S]), abs(d), gain, d0, tau, t_d)[0])
                held[side] = start[side] + sign * phi
                duty[side].append(d if k < k_frames else 0.0)
                angle[side].append(held[side])
            now += DT_S
        rest(0.5)
    n = len(t)
    counts = {s: np.floor(np.array(angle[s]) * TPR / (2 * math.pi)).astype(np.int64) for s in held}
    return RunData(
        name="model",
        t_s=np.array(t),
        enc_left=counts["left"],
        enc_right=counts["right"],
        gyro_rad_s=np.full((n, 3), np.nan),
        accel_m_s2=np.full((n, 3), np.nan),
        duty_left=np.array(duty["left"]),
        duty_right=np.array(duty["right"]),
    )


def test_steps_are_found_per_wheel_and_direction() -> None:
    steps = find_steps(model_run(), GEOMETRY)
    assert [(s.side, s.direction, s.duty) for s in steps[:4]] == [
        ("left", "forward", 0.35),
        ("right", "forward", 0.35),
        ("left", "reverse", 0.35),
        ("right", "reverse", 0.35),
    ]
    assert len(steps) == 8
    assert all(s.t_s[0] == 0.0 and s.angle_rad[-1] > 0 for s in steps)


def test_fit_recovers_gain_breakaway_and_lag_from_quantised_counts() -> None:
    ident = identify_steps([model_run()], GEOMETRY)
    for m in ident.models:
        gain, d0, tau, t_d = TRUE[(m.side, m.direction)]
        assert m.breakaway_fitted
        assert m.gain_rad_s == pytest.approx(gain, rel=0.005)
        assert m.breakaway_duty == pytest.approx(d0, abs=0.002)
        assert m.delay_s == pytest.approx(tau + t_d, abs=0.002)
        assert m.time_constant_s == pytest.approx(tau, abs=0.005)
        assert m.rms_residual_rad < 2 * math.pi / TPR  # below one tick: quantisation only
        assert 0 < m.gain_sd_rad_s < 0.05


def test_given_breakaway_is_held_and_one_level_suffices() -> None:
    run = model_run(duties=(0.5,))
    given = DeadbandConfig(0.10, 0.12, 0.14, 0.11)
    ident = identify_steps([run], GEOMETRY, breakaway=given)
    for m in ident.models:
        gain, d0, _, _ = TRUE[(m.side, m.direction)]
        assert not m.breakaway_fitted and m.breakaway_duty == d0
        assert m.gain_rad_s == pytest.approx(gain, rel=0.005)
    with pytest.raises(CalibrationError, match="one duty level"):
        identify_steps([run], GEOMETRY)


def test_host_gains_make_every_wheel_and_direction_reach_the_command() -> None:
    ident = identify_steps([model_run()], GEOMETRY)
    base = DeadbandConfig(
        forward_left=0.10, reverse_left=0.12, forward_right=0.14, reverse_right=0.11
    )
    hg = ident.host_gains(base)
    tops = {
        (m.side, m.direction): m.gain_rad_s * (1 - base.breakaway(m.side, m.direction))
        for m in ident.models
    }
    assert hg.reference == min(tops, key=lambda k: tops[k]) == ("right", "forward")
    assert hg.max_wheel_rad_s == pytest.approx(tops[hg.reference])
    assert hg.gains[hg.reference] == 1.0 and max(hg.gains.values()) == 1.0
    db = hg.apply(base)
    for m in ident.models:
        sign = 1.0 if m.direction == "forward" else -1.0
        for omega in (1.0, 3.0, 6.0):
            duty = abs(wheel_duty(sign * omega, m.side, db))
            speed = m.gain_rad_s * (duty - base.breakaway(m.side, m.direction))
            assert speed == pytest.approx(omega, rel=0.01)  # exact but for the fitted d_0
    updates = hg.yaml_updates()
    assert set(updates) == {
        "deadband.max_wheel_rad_s",
        "deadband.gain.left.forward",
        "deadband.gain.left.reverse",
        "deadband.gain.right.forward",
        "deadband.gain.right.reverse",
    }
    assert updates["deadband.gain.left.reverse"] == round(db.gain("left", "reverse"), 4)


def test_a_wheel_that_does_not_follow_its_step_is_named() -> None:
    run = model_run()
    stuck = dataclasses.replace(run, enc_right=np.zeros_like(run.enc_right))
    with pytest.raises(CalibrationError, match=r"the right wheel's forward step at duty 0\.35"):
        find_steps(stuck, GEOMETRY)


def test_a_missing_direction_is_named() -> None:
    run = model_run()
    forward_only = dataclasses.replace(
        run, duty_left=np.clip(run.duty_left, 0, 1), duty_right=np.clip(run.duty_right, 0, 1)
    )
    with pytest.raises(CalibrationError, match="no reverse step of the left wheel"):
        identify_steps([forward_only], GEOMETRY)


def test_script_waits_for_standstill_before_each_step() -> None:
    script = WheelStepScript([DutyStep(0.5, 0.5, 0.2), DutyStep(-0.3, 0.0, 0.1)], settle_s=0.1)
    counts = 0
    written: list[tuple[float, float]] = []
    t = 0.0
    coast_until = -math.inf
    while not script.done and t < 10.0:
        d = script.step(t, counts, counts)
        written.append(d)
        if d != (0.0, 0.0):
            counts += 1
            coast_until = t + 0.3  # it rolls on for 0.3 s after the brake
        elif t < coast_until:
            counts += 1
        t += DT_S
    assert script.done
    first = written.index((0.5, 0.5))
    assert first == round(0.5 / DT_S)  # still for 0.5 s (longer than the 0.1 s settle)
    assert written[first : first + 40] == [(0.5, 0.5)] * 40
    second = written.index((-0.3, 0.0))
    # braked until the counts stood still 0.5 s: 0.3 s of coasting, then 0.5 s
    assert (second - (first + 40)) * DT_S == pytest.approx(0.8, abs=2 * DT_S)
    assert written[second : second + 20] == [(-0.3, 0.0)] * 20
    assert set(written[second + 20 :]) == {(0.0, 0.0)}


def test_step_plan_drives_both_wheels_or_one_at_a_time() -> None:
    assert step_plan((0.4,), 1.0) == (DutyStep(0.4, 0.4, 1.0), DutyStep(-0.4, -0.4, 1.0))
    single = step_plan((0.4,), 1.0, single_wheel=True)
    assert [(s.left, s.right) for s in single] == [(0.4, 0), (-0.4, 0), (0, 0.4), (0, -0.4)]
    with pytest.raises(ValueError, match="duty level"):
        step_plan((1.2,))


# ------------------------------------------------------------------------- on the twin


def unequal_robot(tmp: Path) -> Path:
    """The bundled robot file with the right drive 8 % weaker, as a file of its own."""
    data = yaml.safe_load((ROBOTS_DIR / "jackson.yaml").read_text())
    data["name"] = "unequal"
    data["motor"]["gain"] = {"left": HIDDEN_GAIN[0], "right": HIDDEN_GAIN[1]}
    path = tmp / "unequal.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@dataclasses.dataclass(frozen=True)
class Identified:
    robot_file: Path
    robot: RobotSpec
    ident: StepIdentification
    out: Path


@pytest.fixture(scope="module")
def identified(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Identified]:
    tmp = tmp_path_factory.mktemp("step")
    robot_file = unequal_robot(tmp)
    robot = load_robot(robot_file)
    # one run: the twin waits for a slow host as long as it takes (stop() ends the wait), so
    # every step starts on the twin's clock where the script put it
    twin = TwinThread(tmp, world="open_floor", robot=robot, heartbeat_timeout_s=HOST_SILENT_S)
    try:
        cfg = host_config(twin.i2c)
        cfg = dataclasses.replace(
            cfg, serial=dataclasses.replace(cfg.serial, telemetry_rate_hz=200)
        )
        folder = runs.duty_run(
            runs.Link(twin.serial, cfg),
            tmp / "steps",
            WheelStepScript(),
            label="wheel steps",
            meta={"calibration": "step"},
        )
    finally:
        twin.stop()
    yield Identified(robot_file, robot, identify_steps([runs.load_run(folder)], cfg.robot), tmp)


def test_twin_gain_ratio_is_recovered_within_2_percent(identified: Identified) -> None:
    ident = identified.ident
    hidden = HIDDEN_GAIN[1] / HIDDEN_GAIN[0]
    errors = {}
    for direction in ("forward", "reverse"):
        k_l = ident.model("left", direction).gain_rad_s
        k_r = ident.model("right", direction).gain_rad_s
        errors[direction] = abs(k_r / k_l - hidden) / hidden
    hg = ident.host_gains(HostConfig().deadband)
    host_ratio = hg.gains[("left", "forward")] / hg.gains[("right", "forward")]
    for m in ident.models:
        print(
            f"{m.side} {m.direction}: K {m.gain_rad_s:.4f} +- {m.gain_sd_rad_s:.4f} rad/s, "
            f"d_0 {m.breakaway_duty:.4f}, tau {m.time_constant_s * 1000:.2f} ms, "
            f"t_d {m.dead_time_s * 1000:.2f} ms, rms {m.rms_residual_rad:.4f} rad"
        )
    print(f"K_R / K_L error {errors}; host gain ratio {host_ratio:.4f} (hidden {hidden})")
    assert max(errors.values()) < 0.02
    assert abs(host_ratio - hidden) / hidden < 0.02
    assert hg.reference[0] == "right"


def test_twin_time_constant_is_the_motors_mechanical_lag(identified: Identified) -> None:
    """The motor's torque lag (time_constant_s) sits inside its back-EMF loop, so the
    angle's settled lag tau + t_d is the mechanical J / k_e, J the wheel's own inertia plus
    its half of the chassis mass (m r^2 / 2): 22.5 ms for the bundled robot."""
    r = identified.robot
    m = r.motor
    k_e = m.stall_torque_nm / m.no_load_rad_s
    inertia = m.wheel_inertia_kg_m2 + r.mass_kg * r.wheel_radius_m.left**2 / 2
    tau_m = inertia / k_e
    for model in identified.ident.models:
        print(f"{model.side} {model.direction}: tau + t_d {model.delay_s * 1000:.2f} ms")
        assert model.time_constant_s > 0.0
        assert model.time_constant_s < tau_m + m.time_constant_s
        assert model.delay_s == pytest.approx(tau_m, rel=0.25)


def figure_eight_loops(identified: Identified, name: str, cfg: HostConfig) -> tuple[float, ...]:
    config = identified.out / f"{name}.yaml"
    config.write_text(yaml.safe_dump(dump_config(cfg), sort_keys=False))
    result = run_trial(
        TrialSpec(
            mission="figure8",
            index=0,
            seed=1,
            robot=str(identified.robot_file),
            world="open_floor",
            out=identified.out / name,
            config=config,
        )
    )
    assert result["completed"]
    return result["gt_loop_diameter_ccw_m"], result["gt_loop_diameter_cw_m"]


def test_identified_gains_remove_the_cw_ccw_asymmetry(identified: Identified) -> None:
    default = HostConfig()
    calibrated = dataclasses.replace(
        default, deadband=identified.ident.host_gains(default.deadband).apply(default.deadband)
    )
    ccw0, cw0 = figure_eight_loops(identified, "default", default)
    ccw1, cw1 = figure_eight_loops(identified, "identified", calibrated)
    print(
        f"figure-eight loops: default gains CCW {ccw0:.4f} m / CW {cw0:.4f} m "
        f"(asymmetry {ccw0 - cw0:+.4f} m); identified CCW {ccw1:.4f} m / CW {cw1:.4f} m "
        f"(asymmetry {ccw1 - cw1:+.4f} m)"
    )
    assert ccw0 - cw0 > 0.2  # the weaker right wheel: wide CCW loops, tight CW ones
    assert abs(ccw1 - cw1) < 0.1 * abs(ccw0 - cw0)
    assert ccw1 == pytest.approx(1.0, abs=0.05) and cw1 == pytest.approx(1.0, abs=0.05)


def test_a_stuck_wheel_well_above_its_breakaway_is_named_as_such() -> None:
    run = model_run()
    stuck = dataclasses.replace(run, enc_right=np.zeros_like(run.enc_right))
    with pytest.raises(CalibrationError, match=r"well above its breakaway duty 0\.1: the wheel"):
        identify_steps([stuck], GEOMETRY, expected=DeadbandConfig())


def test_a_step_with_frames_missing_is_refused() -> None:
    """Seconds without a frame inside a step (a link that lost them) are not fitted."""
    run = model_run()
    first = int(np.flatnonzero(run.duty_left != 0.0)[0])
    keep = np.ones(run.frames, bool)
    keep[first + 20 : first + 120] = False  # 0.5 s of the first step gone
    cut = RunData(
        name="cut",
        t_s=run.t_s[keep],
        enc_left=run.enc_left[keep],
        enc_right=run.enc_right[keep],
        gyro_rad_s=run.gyro_rad_s[keep],
        accel_m_s2=run.accel_m_s2[keep],
        duty_left=run.duty_left[keep],
        duty_right=run.duty_right[keep],
    )
    with pytest.raises(CalibrationError, match=r"0\.5\d s without a frame \(100 frames missing\)"):
        identify_steps([cut], GEOMETRY)


def test_a_fit_that_does_not_follow_a_motor_is_refused() -> None:
    """Counts that lag the model by a jump mid-step (a wheel that slipped, then caught up)
    leave a residual of many ticks: an error, never a model."""
    run = model_run()
    first = int(np.flatnonzero(run.duty_left != 0.0)[0])
    enc = run.enc_left.copy()
    enc[first + 10 : first + 100] = enc[first + 10]  # stalled for 0.45 s, then the counts jump
    with pytest.raises(CalibrationError, match=r"left wheel's forward steps do not follow a first"):
        identify_steps([dataclasses.replace(run, enc_left=enc)], GEOMETRY)


def test_a_step_that_reached_the_motor_late_on_the_mcu_clock_is_refused() -> None:
    """Steps are timed from their frame: a wheel that first moved 1.2 s later (a twin that
    went on without its busy host) is refused, one that moved after 40 ms is fitted."""
    t = np.arange(300) * DT_S
    for delay_s, refused in ((0.04, False), (1.2, True)):
        ticks = np.maximum(np.floor((t - delay_s) * 400.0), 0.0)
        if refused:
            with pytest.raises(CalibrationError, match=r"first moved the wheel 1\.20 s after"):
                check_start("the step", t, ticks, MAX_DEAD_TIME_S)
        else:
            check_start("the step", t, ticks, MAX_DEAD_TIME_S)
