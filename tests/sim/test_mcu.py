"""The twin's MCU (the compiled firmware core, sim/mcu.py) on its own: what the firmware does
with an MPU-6050 that is not there, and its motor interlock line."""

from __future__ import annotations

from jackson.protocol import (
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    FrameDecoder,
    Heartbeat,
    Hello,
    HostState,
    SetConfig,
    Status,
    Telemetry,
    TelemetryFlags,
    decode_message,
    encode_frame,
)
from jackson.sim.mcu import Mcu, SensorSample

NO_IMU = SensorSample(0, 0, False, (0, 0, 0), 0, (0, 0, 0))


def without_imu(sent: list[bytes]) -> Mcu:
    def write(frame: bytes) -> bool:
        sent.append(frame)
        return True

    return Mcu(write, lambda: NO_IMU, imu_present=False)


def error_instants_ms(mcu: Mcu, until_ms: int, step_ms: int = 10, from_ms: int = 0) -> list[int]:
    """Tick every ``step_ms`` after ``from_ms`` and return the instants i2c_errors grew."""
    out = []
    seen = mcu.i2c_errors
    for t in range(from_ms + step_ms, until_ms + 1, step_ms):
        mcu.tick(t * 1000)
        if mcu.i2c_errors != seen:
            out += [t] * (mcu.i2c_errors - seen)
            seen = mcu.i2c_errors
    return out


def test_an_absent_imu_is_retried_with_backoff_from_50_ms_to_2_s() -> None:
    mcu = without_imu([])
    assert mcu.i2c_errors == 1  # the boot attempt at 0
    # firmware/core/mpu6050.cpp: retry after 50, 100, 200, ... ms, at most 2 s apart
    assert error_instants_ms(mcu, 9200) == [50, 150, 350, 750, 1550, 3150, 5150, 7150, 9150]


def test_the_schedule_does_not_depend_on_how_often_the_mcu_ticks() -> None:
    fine, coarse = without_imu([]), without_imu([])
    error_instants_ms(fine, 6000, step_ms=10)
    coarse.tick(6_000_000)  # one tick: the polls in between are caught up
    assert coarse.i2c_errors == fine.i2c_errors == 8


def test_set_config_retries_at_the_next_poll() -> None:
    sent: list[bytes] = []
    mcu = without_imu(sent)
    error_instants_ms(mcu, 400)  # errors at 0, 50, 150, 350; next retry due at 750
    mcu.receive(encode_frame(SetConfig(accel_fs=1, gyro_fs=1, failsafe_ms=600), 0), 405_000)
    mcu.tick(405_000)
    # the driver re-initialises at its next poll (410 ms); the backoff keeps growing: 800 ms
    assert error_instants_ms(mcu, 2000, from_ms=400) == [410, 1210]


def test_telemetry_and_status_report_the_errors() -> None:
    sent: list[bytes] = []
    mcu = without_imu(sent)
    hello = Hello(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH)
    mcu.receive(encode_frame(hello, 0), 0)
    error_instants_ms(mcu, 1000)
    messages = [decode_message(f) for f in FrameDecoder().feed(b"".join(sent))]
    telemetry = {m.t_us // 1000: m for m in messages if isinstance(m, Telemetry)}
    flagged = [t for t, m in sorted(telemetry.items()) if m.flags & TelemetryFlags.I2C_ERRORS]
    # a frame carries I2C_ERRORS when an attempt failed since the frame before
    assert flagged == [50, 150, 350, 750]
    assert not any(m.flags & TelemetryFlags.IMU_OK for m in telemetry.values())
    status = [m for m in messages if isinstance(m, Status)]
    assert status[-1].t_us == 1_000_000 and status[-1].i2c_errors == 5


# ---- the motor interlock line (firmware.cpp update_interlock) ---------------------------------


def session(sent: list[bytes]) -> Mcu:
    mcu = without_imu(sent)
    hello = Hello(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH)
    mcu.receive(encode_frame(hello, 0), 0)
    mcu.tick(0)
    return mcu


def heartbeat(mcu: Mcu, seq: int, t_us: int, state: HostState = HostState.ACTIVE) -> None:
    mcu.receive(encode_frame(Heartbeat(ack_seq=0, host_state=state), seq), t_us)
    mcu.tick(t_us)


def test_interlock_is_released_at_boot_and_until_the_first_heartbeat() -> None:
    mcu = without_imu([])
    assert not mcu.motor_enable
    mcu.receive(encode_frame(Heartbeat(ack_seq=0, host_state=HostState.ACTIVE), 0), 1000)
    mcu.tick(1000)
    assert not mcu.motor_enable  # a heartbeat outside a session counts for nothing
    mcu = session([])
    mcu.tick(300_000)
    assert not mcu.motor_enable
    heartbeat(mcu, 1, 310_000)
    assert mcu.motor_enable


def test_interlock_drops_exactly_failsafe_ms_after_the_last_heartbeat() -> None:
    mcu = session([])
    heartbeat(mcu, 1, 20_000)
    lost = 20_000 + 1000 * mcu.failsafe_ms
    mcu.tick(lost - 1)
    assert mcu.motor_enable
    mcu.tick(lost)
    assert not mcu.motor_enable


def test_next_deadline_stops_at_the_instant_the_line_drops() -> None:
    mcu = session([])
    heartbeat(mcu, 1, 20_000)
    t = 20_000
    while mcu.motor_enable:
        nxt = mcu.next_deadline(t)
        assert nxt is not None
        t = nxt
        mcu.tick(t)
    assert t == 20_000 + 1000 * mcu.failsafe_ms


def test_interlock_drops_at_a_shutdown_heartbeat_and_returns_with_active_ones() -> None:
    mcu = session([])
    heartbeat(mcu, 1, 20_000)
    heartbeat(mcu, 2, 70_000, HostState.SHUTDOWN)
    assert not mcu.motor_enable
    heartbeat(mcu, 3, 120_000)
    assert mcu.motor_enable
    mcu.tick(900_000)
    assert not mcu.motor_enable  # silence
    heartbeat(mcu, 4, 950_000)
    assert mcu.motor_enable  # heartbeats resumed


def test_a_new_hello_releases_the_line_until_its_first_heartbeat() -> None:
    mcu = session([])
    heartbeat(mcu, 1, 20_000)
    hello = Hello(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH)
    mcu.receive(encode_frame(hello, 2), 40_000)
    mcu.tick(40_000)
    assert not mcu.motor_enable
    heartbeat(mcu, 3, 60_000)
    assert mcu.motor_enable


def test_motor_enable_flag_mirrors_the_line_in_telemetry_and_status() -> None:
    sent: list[bytes] = []
    mcu = session(sent)
    line: dict[int, bool] = {}
    for ms in range(0, 3000, 10):
        t = ms * 1000
        if (ms < 1000 or ms >= 2000) and ms % 50 == 0:
            heartbeat(mcu, 1 + ms // 50, t)
        mcu.tick(t)
        line[t] = mcu.motor_enable
    messages = [decode_message(f) for f in FrameDecoder().feed(b"".join(sent))]
    flagged = [m for m in messages if isinstance(m, Telemetry | Status)]
    assert len(flagged) > 55
    for m in flagged:
        assert bool(m.flags & TelemetryFlags.MOTOR_ENABLE) == line[m.t_us], m.t_us
    lost = 950_000 + 1000 * mcu.failsafe_ms  # failsafe_ms after the last heartbeat before 1 s
    assert line[lost - 10_000] and not line[lost] and not line[1_990_000] and line[2_500_000]
