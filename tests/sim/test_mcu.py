"""The MCU emulator on its own: what the firmware does with an MPU-6050 that is not there."""

from __future__ import annotations

from jackson.protocol import (
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    FrameDecoder,
    Hello,
    SetConfig,
    Status,
    Telemetry,
    TelemetryFlags,
    decode_message,
    encode_frame,
)
from jackson.sim.mcu import McuEmulator, SensorSample

NO_IMU = SensorSample(0, 0, False, (0, 0, 0), 0, (0, 0, 0))


def emulator(sent: list[bytes]) -> McuEmulator:
    def write(frame: bytes) -> bool:
        sent.append(frame)
        return True

    return McuEmulator(write, lambda: NO_IMU, imu_present=False)


def error_instants_ms(
    mcu: McuEmulator, until_ms: int, step_ms: int = 10, from_ms: int = 0
) -> list[int]:
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
    mcu = emulator([])
    assert mcu.i2c_errors == 1  # the boot attempt at 0
    # firmware/core/mpu6050.cpp: retry after 50, 100, 200, ... ms, at most 2 s apart
    assert error_instants_ms(mcu, 9200) == [50, 150, 350, 750, 1550, 3150, 5150, 7150, 9150]


def test_the_schedule_does_not_depend_on_how_often_the_emulator_ticks() -> None:
    fine, coarse = emulator([]), emulator([])
    error_instants_ms(fine, 6000, step_ms=10)
    coarse.tick(6_000_000)  # one tick: the polls in between are caught up
    assert coarse.i2c_errors == fine.i2c_errors == 8


def test_set_config_retries_at_the_next_poll() -> None:
    sent: list[bytes] = []
    mcu = emulator(sent)
    error_instants_ms(mcu, 400)  # errors at 0, 50, 150, 350; next retry due at 750
    mcu.receive(encode_frame(SetConfig(accel_fs=1, gyro_fs=1, failsafe_ms=600), 0), 405_000)
    # the driver re-initialises at its next poll (410 ms); the backoff keeps growing: 800 ms
    assert error_instants_ms(mcu, 2000, from_ms=400) == [410, 1210]


def test_telemetry_and_status_report_the_errors() -> None:
    sent: list[bytes] = []
    mcu = emulator(sent)
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
