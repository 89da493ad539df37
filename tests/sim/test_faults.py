"""Sensor and link faults of the twin: each kind does what it says where the MCU or the host
sees it, seeded and bit-reproducible, and a twin without faults is the twin of before."""

from __future__ import annotations

import hashlib
import json
import math
import os
import select
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
import yaml
from numpy.typing import NDArray

from jackson.experiments.trial import TrialSpec, run_trial
from jackson.host.lidar.rplidar import RevolutionAssembler
from jackson.host.recording import KIND_RX, read_log
from jackson.main import main
from jackson.protocol import (
    FrameDecoder,
    Status,
    Telemetry,
    TelemetryFlags,
    decode_message,
)
from jackson.protocol.messages import GYRO_LSB_PER_DPS
from jackson.protocol.rplidar import Command, encode_request
from jackson.sim.config import ROBOTS_DIR, ConfigError, RobotSpec, load_robot, load_world
from jackson.sim.faults import (
    FAULT_KINDS,
    FaultError,
    FaultSpec,
    fault_window,
    format_fault,
    parse_fault,
)
from jackson.sim.lidar import LidarSpec
from jackson.sim.mcu import SensorSample
from jackson.sim.robot import WheelDrive
from jackson.sim.rplidar import RplidarEmulator
from jackson.sim.twin import Twin

from .test_firmware_in_the_loop import scenario
from .twin_process import TwinProcess

GYRO_LSB_PER_RAD_S = GYRO_LSB_PER_DPS[0] * 180.0 / math.pi  # at +-250 deg/s


# ------------------------------------------------------------------------------ syntax


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "imu_bias_step@20:magnitude_rad_s=0.05",
            FaultSpec("imu_bias_step", 20.0, params={"magnitude_rad_s": 0.05}),
        ),
        ("encoder_dropout@15+5:side=left", FaultSpec("encoder_dropout", 15.0, 5.0, "left")),
        ("frame_loss@0:probability=0.05", FaultSpec("frame_loss", 0.0)),
        ("imu_dead@10", FaultSpec("imu_dead", 10.0)),
        ("imu_spike@1e+1+2.5:rate_hz=3", FaultSpec("imu_spike", 10.0, 2.5, params={"rate_hz": 3})),
        ("wheel_slip@3:side=right", FaultSpec("wheel_slip", 3.0, 2.0, "right", {"mu_scale": 0.1})),
        ("lidar_dropout@.5", FaultSpec("lidar_dropout", 0.5, params={"probability": 0.3})),
    ],
)
def test_parse_fault_reads_the_cli_syntax_and_round_trips(text: str, expected: FaultSpec) -> None:
    spec = parse_fault(text)
    assert spec == expected
    assert parse_fault(format_fault(spec)) == spec
    assert hash(parse_fault(format_fault(spec))) == hash(spec)
    assert set(spec.params) == set(expected.params)  # every parameter, defaults filled in


def test_fault_window_is_onset_to_end() -> None:
    assert fault_window(parse_fault("encoder_dropout@15+5:side=left")) == (15.0, 20.0)
    assert fault_window(parse_fault("imu_dead@10")) == (10.0, math.inf)
    assert fault_window(parse_fault("wheel_slip@1:side=left")) == (1.0, 3.0)  # 2 s default
    assert sorted(FAULT_KINDS) == sorted(
        {parse_fault(f"{k}@1:side=left" if "_slip" in k or "encoder" in k else f"{k}@1").kind
         for k in FAULT_KINDS}
    )  # fmt: skip


@pytest.mark.parametrize(
    ("text", "names"),
    [
        ("imu_spik@3", "valid kinds: imu_dead"),
        ("imu_dead", "KIND@AT_S"),
        ("@3", "no kind"),
        ("imu_dead@-1", "AT_S >= 0"),
        ("imu_dead@3+0", "duration_s"),
        ("imu_dead@soon", "KIND@AT_S"),
        ("imu_dead@3:rate_hz=1", "imu_dead takes no keys"),
        ("imu_spike@3:rate=1", "valid keys: rate_hz, magnitude_rad_s"),
        ("imu_spike@3:rate_hz=0", "rate_hz: expected a number > 0"),
        ("imu_spike@3:rate_hz=nan", "rate_hz: expected a number > 0"),
        ("frame_loss@1:probability=1.5", "probability: expected a number in [0, 1]"),
        ("frame_loss@1:probability", "expected key=value"),
        ("frame_loss@1:probability=0.1,probability=0.2", "given twice"),
        ("encoder_dropout@3", "side: expected left or right"),
        ("wheel_slip@3:side=middle", "side: expected left or right"),
        ("imu_stuck@3:side=left", "imu_stuck takes no keys"),
    ],
)
def test_parse_fault_refuses_garbage_in_one_line(text: str, names: str) -> None:
    with pytest.raises(FaultError) as err:
        parse_fault(text)
    message = str(err.value)
    assert "\n" not in message and names in message
    assert isinstance(err.value, ValueError)


def robot_file(tmp_path: Path, faults: object) -> Path:
    data = yaml.safe_load((ROBOTS_DIR / "jackson.yaml").read_text())
    data["faults"] = faults
    path = tmp_path / "faulty.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_robot_file_faults_are_read() -> None:
    assert load_robot("jackson").faults == ()


def test_robot_file_faults_list(tmp_path: Path) -> None:
    robot = load_robot(
        robot_file(
            tmp_path,
            [
                {"kind": "imu_bias_step", "at_s": 20, "magnitude_rad_s": -0.02},
                {"kind": "encoder_dropout", "at_s": 15, "duration_s": 5, "side": "right"},
                {"kind": "frame_loss", "at_s": 0},
            ],
        )
    )
    assert robot.faults == (
        parse_fault("imu_bias_step@20:magnitude_rad_s=-0.02"),
        parse_fault("encoder_dropout@15+5:side=right"),
        parse_fault("frame_loss@0"),
    )


@pytest.mark.parametrize(
    ("faults", "names"),
    [
        ([{"kind": "imu_deadd", "at_s": 1}], "faults[0].kind: expected one of imu_dead"),
        ([{"kind": "imu_dead"}], "faults[0].at_s: missing"),
        ([{"kind": "imu_dead", "at_s": -2}], "faults[0].at_s: expected a number >= 0"),
        ([{"kind": "imu_dead", "at_s": 1, "duration_s": 0}], "faults[0].duration_s"),
        ([{"kind": "imu_dead", "at_s": 1, "rate_hz": 1}], "faults[0].rate_hz: unknown field"),
        (
            [{"kind": "frame_loss", "at_s": 1}, {"kind": "frame_loss", "at_s": 1, "p": 0.1}],
            "faults[1].p: unknown field for frame_loss (valid: kind, at_s, duration_s, "
            "probability)",
        ),
        ([{"kind": "frame_loss", "at_s": 1, "probability": 2}], "faults[0].probability"),
        ([{"kind": "wheel_slip", "at_s": 1}], "faults[0].side: expected left or right"),
        ([{"kind": "imu_dead", "at_s": 1, "side": "left"}], "faults[0].side: unknown field"),
        (["imu_dead@3"], "faults[0]: expected {kind, at_s"),
        ({"kind": "imu_dead"}, "faults: expected a list"),
    ],
)
def test_robot_file_faults_refused_when_wrong(tmp_path: Path, faults: object, names: str) -> None:
    with pytest.raises(ConfigError) as err:
        load_robot(robot_file(tmp_path, faults))
    message = str(err.value)
    assert message.startswith("robot faulty.yaml: ") and "\n" not in message
    assert names in message


@pytest.mark.parametrize("command", [["sim"], ["run", "square"]])
def test_a_bad_fault_on_the_command_line_is_one_line(
    command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_:
        main([*command, "--fault", "imu_dead@3:rate_hz=1"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "argument --fault" in err and "imu_dead takes no keys" in err


# ---------------------------------------------------------------- the sensors the MCU reads

FLOOR = load_world("open_floor")
Reading = tuple[float, SensorSample, float, float]  # t, sample, true wheel angles l, r


def readings(
    faults: Sequence[FaultSpec],
    seconds: float,
    drive: tuple[float, float] = (0.0, 0.0),
    robot: RobotSpec | None = None,
    seed: int = 3,
) -> tuple[Twin, list[Reading]]:
    """The twin's sensors at 20 Hz under constant duties (0: braked, at rest)."""
    tw = Twin(FLOOR, robot or load_robot("jackson"), lidar=False, seed=seed, faults=faults)
    left, right = drive
    tw.command(WheelDrive(left, 1.0), WheelDrive(right, 1.0))
    out = []
    for _ in range(round(seconds * 20)):
        tw.advance(0.05)
        out.append((tw.t_s, tw.sensors(), tw.robot.angle_l, tw.robot.angle_r))
    return tw, out


def registers(s: SensorSample) -> tuple[object, ...]:
    return (s.accel, s.temp, s.gyro)


def test_a_stuck_imu_repeats_its_last_registers_with_imu_ok() -> None:
    _, healthy = readings([], 4.0, (0.5, 0.3))
    _, stuck = readings([parse_fault("imu_stuck@1+2")], 4.0, (0.5, 0.3))
    before = [s for t, s, *_ in stuck if t < 1.0 - 1e-9]
    during = [s for t, s, *_ in stuck if 1.0 - 1e-9 <= t < 3.0 - 1e-9]
    assert len(during) == 40
    assert all(registers(s) == registers(before[-1]) and s.imu_ok for s in during)
    # healthy, the registers change every sample (noise); outside the window nothing differs
    assert len({registers(s) for t, s, *_ in healthy if 1.0 - 1e-9 <= t < 3.0 - 1e-9}) == 40
    outside = [(a, b) for a, b in zip(healthy, stuck, strict=True) if not 1 - 1e-9 <= a[0] < 3]
    assert all(a[1] == b[1] for a, b in outside)


def test_a_dead_imu_reads_without_imu_ok() -> None:
    _, healthy = readings([], 3.0)
    _, dead = readings([parse_fault("imu_dead@1+1")], 3.0)
    window = [1.0 - 1e-9 <= t < 2.0 - 1e-9 for t, *_ in dead]
    assert [not s.imu_ok for _, s, *_ in dead] == window
    assert [registers(s) for _, s, *_ in dead] == [registers(s) for _, s, *_ in healthy]


def test_a_bias_step_shifts_the_mean_gyro_z_by_its_magnitude() -> None:
    step = parse_fault("imu_bias_step@2:magnitude_rad_s=0.05")
    _, healthy = readings([], 6.0)
    _, biased = readings([step], 6.0)
    gz = np.array([s.gyro[2] for _, s, *_ in biased], dtype=float) / GYRO_LSB_PER_RAD_S
    t = np.array([t for t, *_ in biased])
    shift = gz[t >= 2.0 - 1e-9].mean() - gz[t < 2.0 - 1e-9].mean()
    assert shift == pytest.approx(0.05, abs=5e-4)  # noise 4e-4 rad/s, one LSB 1.3e-4 rad/s
    # the same noise draws: sample by sample the step and nothing else (one LSB of rounding)
    diff = [b[1].gyro[2] - a[1].gyro[2] for a, b in zip(healthy, biased, strict=True)]
    lsb = 0.05 * GYRO_LSB_PER_RAD_S
    assert all(d == 0 for d, (t, *_) in zip(diff, healthy, strict=True) if t < 2.0 - 1e-9)
    assert all(abs(d - lsb) <= 1 for d, (t, *_) in zip(diff, healthy, strict=True) if t >= 2.0)


def test_spikes_come_at_their_poisson_rate_one_sample_each() -> None:
    spike = parse_fault("imu_spike@1+60:rate_hz=3,magnitude_rad_s=2")
    _, healthy = readings([], 61.5)
    tw, spiky = readings([spike], 61.5)
    assert tw.faults is not None
    n = tw.faults.record()[0]["spikes"]
    assert abs(n - 180) < 3 * math.sqrt(180)  # Poisson: mean and variance 3 /s x 60 s
    # the same noise draws: a sample differs by the spikes that fell in its period
    diff = np.array([b[1].gyro[2] - a[1].gyro[2] for a, b in zip(healthy, spiky, strict=True)])
    hit = np.flatnonzero(diff)
    spikes = np.abs(diff[hit]) / (2.0 * GYRO_LSB_PER_RAD_S)
    assert np.allclose(spikes, np.round(spikes), atol=0.01)  # 1 (or 2 alike in one period)
    cancelled = n - round(spikes.sum())  # two of opposite sign in one period: none seen
    assert cancelled % 2 == 0 and 0 <= cancelled <= 0.1 * n
    assert (diff > 0).any() and (diff < 0).any()  # random sign
    times = np.array([t for t, *_ in spiky])[hit]
    assert times.min() >= 1.0 and times.max() < 61.0 + 0.05


def test_a_cut_encoder_holds_its_count_while_the_wheel_turns() -> None:
    cut = parse_fault("encoder_dropout@1+2:side=left")
    _, healthy = readings([], 4.0, (0.5, 0.5))
    _, faulty = readings([cut], 4.0, (0.5, 0.5))
    tpr = load_robot("jackson").ticks_per_rev.left
    held = faulty[18][1].enc_left  # the last reading before 1 s (at 0.95 s)
    during = [r for r in faulty if 1.0 - 1e-9 <= r[0] < 3.0 - 1e-9]
    assert all(s.enc_left == held for _, s, *_ in during)
    turned = (during[-1][2] - during[0][2]) / (2 * math.pi) * tpr
    assert turned > 300  # ... while the wheel turned this many counts
    # the right encoder and the wheel itself are untouched; after the cut the count moves on,
    # behind by what it missed
    assert [r[1].enc_right for r in faulty] == [r[1].enc_right for r in healthy]
    assert [r[2] for r in faulty] == [r[2] for r in healthy]
    after = [(a[1].enc_left - b[1].enc_left) for a, b in zip(healthy, faulty, strict=True)
             if a[0] >= 3.0 - 1e-9]  # fmt: skip
    assert len(set(after)) == 1 and after[0] == healthy[58][1].enc_left - held  # at 2.95 s


def test_wheel_slip_spins_the_wheel_over_the_floor() -> None:
    slip = parse_fault("wheel_slip@1+1:side=left")
    robot = load_robot("jackson")
    r, h = robot.wheel_radius_m.left, robot.wheel_separation_m / 2.0

    def start(faults: Sequence[FaultSpec]) -> tuple[list[float], list[float], float]:
        """Each wheel's floor speed over its rim speed at each physics step of the first
        0.2 s of a start at 0.6 duty at 1 s, and the heading at 2 s."""
        tw = Twin(FLOOR, robot, lidar=False, faults=faults)
        tw.advance(1.0)
        tw.command(WheelDrive(0.6, 1.0), WheelDrive(0.6, 1.0))
        tw.advance(1.0)
        left, right = [], []
        for s in tw.truth_log:
            if 1.0 < s.t_s <= 1.2 and min(s.omega_left, s.omega_right) > 0.5:
                left.append((s.vx - h * s.wz) / (s.omega_left * r))
                right.append((s.vx + h * s.wz) / (s.omega_right * r))
        return left, right, tw.truth().yaw

    left, right, yaw = start([slip])
    assert min(left) < 0.1 and np.mean(left) < 0.5  # the left wheel spins over the floor
    assert min(right) > 0.999  # the right one grips ...
    assert yaw > 0.1  # ... and pulls the robot round the slipping wheel
    left, right, yaw = start([])
    assert min(left) > 0.999 and min(right) > 0.999 and abs(yaw) < 1e-9


def test_lidar_noise_and_dropout_act_on_the_scans() -> None:
    world = load_world("square_room")
    robot = load_robot("jackson")
    faults = [
        parse_fault("lidar_noise@1+1:sigma_m=0.05"),
        parse_fault("lidar_dropout@3:probability=0.3"),
    ]
    healthy = Twin(world, robot, seed=2)
    faulty = Twin(world, robot, seed=2, faults=faults)
    for tw in (healthy, faulty):
        tw.advance(63.0)
    by_time = {round(s.t_s, 6): s.ranges for s in healthy.scans}
    noise = []
    for s in faulty.scans:
        ref = by_time[round(s.t_s, 6)]
        if 1.0 <= s.t_s < 2.0:
            ok = np.isfinite(ref) & np.isfinite(s.ranges)
            noise.append(s.ranges[ok] - ref[ok])
        else:
            assert np.array_equal(s.ranges, ref)
    sd = float(np.concatenate(noise).std())
    assert sd == pytest.approx(0.05, rel=0.03)
    after = [t for t in by_time if t >= 3.0]
    lost = len(faulty.lost_scans)
    assert lost == faulty.scans_lost == len(by_time) - len(faulty.scans)
    assert abs(lost / len(after) - 0.3) < 3 * math.sqrt(0.3 * 0.7 / len(after))
    assert min(faulty.lost_scans) >= 3.0
    record = faulty.faults.record() if faulty.faults is not None else []
    assert record[1]["revolutions_lost"] == lost
    assert 1.0 <= record[0]["first_s"] < 1.0 + 0.135  # the first scan in the window


def test_a_lost_revolution_puts_nothing_on_the_lidar_line() -> None:
    spec = LidarSpec()
    emulator = RplidarEmulator(spec, device_standard_scan=False)
    fd = os.open(emulator.path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        os.write(fd, encode_request(Command.SCAN))
        select.select([emulator.fileno()], [], [], 5.0)
        assert emulator.serve(0.0) == 1
        lost = {3, 4, 7}  # turns k end at k periods: these are lost, the others read 2 m

        def ranges(end_s: float) -> NDArray[np.float64] | None:
            k = round(end_s / spec.scan_period_s)
            return None if k in lost else np.full(spec.beams, 2.0)

        assembler = RevolutionAssembler()
        revolutions = []
        for k in range(1, 11):  # one turn at a time, read as the host does
            assert emulator.advance(k * spec.scan_period_s, ranges) == 1
            while True:
                emulator.link.flush()
                if not select.select([fd], [], [], 0.05)[0]:
                    break
                revolutions += assembler.feed(os.read(fd, 65536))
        assert emulator.revolutions_lost == 3 and emulator.revolutions_written == 7
        assert emulator.revolutions_dropped == 0
        # the host sees the 7 turns sent, each whole (a lost turn's S node starts the next)
        assert assembler.decoder.malformed_bytes == 0
        assert len(revolutions) == 7
        assert all(r.nodes == spec.beams and np.allclose(r.ranges_m, 2.0) for r in revolutions)
    finally:
        os.close(fd)
        emulator.close()


# -------------------------------------------------------------------- seeds and streams


def test_same_seed_same_faults_bit_for_bit_and_each_fault_on_its_own_stream() -> None:
    spike = parse_fault("imu_spike@0.5:rate_hz=3")
    others = [parse_fault("imu_bias_step@2"), parse_fault("frame_loss@0"), spike]
    a, ra = readings([spike], 5.0, (0.4, 0.6))
    b, rb = readings([spike], 5.0, (0.4, 0.6))
    assert ra == rb and a.faults is not None and b.faults is not None
    assert a.faults.record() == b.faults.record()
    # adding faults (in any order) changes neither the spikes' draws nor the twin's noise
    c, rc = readings(others, 5.0, (0.4, 0.6))
    assert c.faults is not None
    assert c.faults.record()[2]["spikes"] == a.faults.record()[0]["spikes"] > 0
    before = [(x[1].gyro[2], y[1].gyro[2]) for x, y in zip(ra, rc, strict=True) if x[0] < 2.0]
    assert all(p == q for p, q in before)
    # another seed, other spikes
    d, _ = readings([spike], 5.0, (0.4, 0.6), seed=4)
    assert d.faults is not None and d.faults.record() != a.faults.record()


def digest(robot: RobotSpec) -> str:
    """Ground truth, sensors and scans of a short drive in the square room, hashed."""
    tw = Twin(load_world("square_room"), robot, seed=4, lidar=True)
    samples = []
    for left, right, periods in ((0.6, 0.6, 20), (0.3, 0.7, 20), (-0.5, 0.5, 20), (1.0, 1.0, 10)):
        tw.command(WheelDrive(left, 1.0), WheelDrive(right, 1.0))
        for _ in range(periods):
            tw.advance(0.05)
            samples.append(tw.sensors())
    scans = [(s.t_s, s.ranges.tobytes()) for s in tw.scans]
    return hashlib.sha256(repr((list(tw.truth_log), samples, scans)).encode()).hexdigest()[:16]


def test_without_faults_the_twin_is_the_twin_of_before() -> None:
    # REFERENCE: the digests of the same drive, and the bytes the host received in the
    # firmware-in-the-loop scenario, measured on the twin before faults existed (the wire's
    # since the device's power-up failsafe became 200 ms: its INFO carries failsafe_ms; and
    # since HELLO carries a session id: the INFO's schema hash and the HELLO's ACK, whose
    # acked_crc is the longer HELLO's CRC, are the only bytes that changed; and since each
    # beam of a scan is cast from the pose at its own instant of the turn: the drive's scans;
    # and since jackson_physical was re-identified on 30 trials: its drive and its wire)
    assert digest(load_robot("jackson")) == "d7f275dcbcc8fc5f"
    assert digest(load_robot("jackson_physical")) == "c9c77e0e659aa657"
    wire = scenario("jackson_physical")
    assert hashlib.sha256(wire).hexdigest()[:16] == "4f0c04d159578a03"


# --------------------------------------------------------- both MCUs, and the serial line


def imu_ok_and_errors(stream: bytes) -> tuple[list[tuple[float, bool]], list[int]]:
    messages = [decode_message(f) for f in FrameDecoder().feed(stream)]
    telemetry = [
        (m.t_us / 1e6, bool(m.flags & TelemetryFlags.IMU_OK))
        for m in messages
        if isinstance(m, Telemetry)
    ]
    return telemetry, [m.i2c_errors for m in messages if isinstance(m, Status)]


def test_the_mcu_in_process_and_the_firmware_process_see_the_same_sensor_faults() -> None:
    faults = [
        "imu_dead@1+0.4",
        "imu_stuck@1.8+0.4",
        "imu_spike@0:rate_hz=5",
        "imu_bias_step@2.2",
        "encoder_dropout@0.7+1:side=left",
        "wheel_slip@0.3+1:side=right",
    ]
    args = [a for f in faults for a in ("--fault", f)]
    in_process = scenario("jackson_physical", *args)
    process = scenario("jackson_physical", *args, "--firmware")
    assert in_process == process
    telemetry, errors = imu_ok_and_errors(process)
    dead = [t for t, ok in telemetry if not ok]
    # from the onset until the driver's first retry after the window (its backoff: 50, 100,
    # 200, 400 ms after three failed reads at 0.96-0.98 s: 1.73 s), no IMU_OK
    assert dead[0] == pytest.approx(1.0) and 1.7 <= dead[-1] < 1.73
    assert all(ok == (t < 1.0 - 1e-9 or t > dead[-1]) for t, ok in telemetry)
    # STATUS's I2C errors at 1, 2, 3 s: the three reads before 1 s, then the failed retries
    assert errors[:3] == [3, 6, 6]
    messages = [decode_message(f) for f in FrameDecoder().feed(process)]
    stuck = [m for m in messages if isinstance(m, Telemetry) and 1.8 <= m.t_us / 1e6 < 2.199]
    assert len({(m.accel, m.temp, m.gyro) for m in stuck}) == 1 and len(stuck) == 20


def test_lost_and_corrupted_frames_on_the_line() -> None:
    twin = TwinProcess(
        "--no-lidar",
        "--seed",
        "2",
        "--fault",
        "frame_loss@0.5+3:probability=0.2",
        "--fault",
        "corrupt_bytes@0.5+3:probability=0.2",
    )
    host = twin.host()
    try:
        host.connect()
        frames = host.run(100, lambda t: (0.3, 0.3))  # the run goes on past the window
    finally:
        host.close()
        code, out, _ = twin.stop()
    assert code == 0
    seen = {round(t.t_us / 50_000) for t in frames}
    missing = sorted(set(range(min(seen), max(seen) + 1)) - seen)
    assert missing and 0.5 <= missing[0] * 0.05 and missing[-1] * 0.05 < 3.5
    assert all(k in seen for k in range(71, max(seen) + 1))  # none lost after the window
    assert host.decoder.counters.crc_errors > 0  # corrupted frames reached the host, refused
    lines = [ln for ln in out.splitlines() if ln.startswith("fault: ") and "acted" in ln]
    lost = int(lines[0].split("acted from 0.500 s, ")[1].split(" frames lost")[0])
    corrupted = int(lines[1].split("acted from 0.500 s, ")[1].split(" frames corrupted")[0])
    # what the host missed is what the line lost or spoiled, each about a fifth (within 3 SD
    # of a binomial draw) of the 60 frames in the window
    assert len(missing) == lost + corrupted
    assert abs(lost - 0.2 * 60) <= 3 * math.sqrt(60 * 0.2 * 0.8)
    kept = 60 - lost
    assert abs(corrupted - 0.2 * kept) <= 3 * math.sqrt(kept * 0.2 * 0.8)
    assert host.decoder.counters.crc_errors + host.decoder.counters.oversize >= corrupted - 2


def test_link_faults_need_the_mcu_in_process(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--firmware", "--fault", "frame_loss@0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "frame_loss@0:probability=0.05" in err and "--firmware" in err


# ------------------------------------------------------------------------ end to end


def test_a_square_with_a_dead_imu_records_the_fault(tmp_path: Path) -> None:
    out = tmp_path / "run"
    spec = TrialSpec(
        "square", 0, 0, "jackson_physical", "square_room", out, faults=(parse_fault("imu_dead@10"),)
    )
    result = run_trial(spec)
    (fault,) = result["faults"]
    assert fault["kind"] == "imu_dead" and fault["at_s"] == 10.0 and fault["end_s"] is None
    assert fault["first_s"] == pytest.approx(10.0)
    metrics = json.loads((out / "metrics.json").read_text())
    meta = json.loads((out / "meta.json").read_text())
    assert metrics["faults"] == result["faults"] and meta["faults"][0]["fault"] == "imu_dead@10"
    assert metrics["sim_s"] > 10.5  # the run went on past the fault, as the host decides
    # what the host received: IMU_OK until the fault, never after it
    telemetry = [
        Telemetry.unpack(r.payload[2:])
        for r in read_log(out)
        if r.kind == KIND_RX and r.payload[0] == Telemetry.TYPE
    ]
    ok = [(t.t_us / 1e6, bool(t.flags & TelemetryFlags.IMU_OK)) for t in telemetry]
    assert all(flag == (t < 10.0 - 1e-9) for t, flag in ok)
    assert any(t > 10.0 for t, _ in ok)
