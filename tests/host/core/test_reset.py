"""An MCU reset (INFO with another boot_id) is re-anchored: no phantom motion, time goes on."""

from __future__ import annotations

from jackson.host.actuation.output import NullOutput
from jackson.host.config import DEFAULT_CONFIG, load_config
from jackson.host.core import HostCore
from jackson.protocol import (
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    Frame,
    FrameDecoder,
    Info,
    Message,
    Telemetry,
    TelemetryFlags,
    encode_frame,
)


def frame(msg: Message, seq: int = 0) -> Frame:
    (f,) = FrameDecoder().feed(encode_frame(msg, seq))
    return f


def info(boot_id: int) -> Info:
    return Info(
        protocol_version=PROTOCOL_VERSION,
        schema_hash=SCHEMA_HASH,
        telemetry_rate_hz=20,
        failsafe_ms=600,
        imu_rotation=(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        accel_scale=1.0,
        boot_id=boot_id,
    )


def drive(core: HostCore, t0_us: int, counts0: int, frames: int, step: int) -> None:
    for k in range(frames):
        n = counts0 + k * step
        core.on_frame(
            frame(
                Telemetry(
                    t_us=t0_us + 50_000 * k, enc_left=n, enc_right=n, flags=TelemetryFlags.IMU_OK
                )
            )
        )


def test_a_reset_is_not_motion_and_time_never_goes_back() -> None:
    core = HostCore(load_config(DEFAULT_CONFIG), NullOutput(), lambda m: None)
    core.on_frame(frame(info(0x1111)))
    drive(core, 5_000_000, 0, 40, 10)  # 2 s driving straight: 390 ticks
    x_before = core.odometry.state.x_m
    t_before = core.t_s
    assert x_before > 0.1
    core.on_frame(frame(info(0x2222)))  # the MCU rebooted: counts and clock restart
    drive(core, 300_000, 0, 20, 0)  # standing still after the reset, 0.3 s into its new life
    assert core.mcu_resets == 1
    assert core.odometry.state.x_m == x_before  # the drop from 390 to 0 ticks is not motion
    assert core.t_s is not None and t_before is not None and core.t_s > t_before
    drive(core, 2_000_000, 0, 20, 10)  # and it drives on from there
    assert core.odometry.state.x_m > x_before


def test_a_reconnect_to_the_same_boot_keeps_counting() -> None:
    core = HostCore(load_config(DEFAULT_CONFIG), NullOutput(), lambda m: None)
    core.on_frame(frame(info(0x1111)))
    drive(core, 0, 0, 20, 10)
    core.on_frame(frame(info(0x1111)))  # the same MCU run after a USB replug
    drive(core, 3_000_000, 400, 20, 10)  # 210 ticks travelled while unplugged: real motion
    assert core.mcu_resets == 0
    x = core.odometry.state.x_m
    assert abs(x - 2 * 3.14159 * 0.033 * (400 + 190) / 621) < 0.01


class _Duties:
    """A duty source that records the counts it is given."""

    done = False

    def __init__(self) -> None:
        self.counts: list[tuple[int, int]] = []

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        self.counts.append((enc_left, enc_right))
        return 0.2, 0.2


def test_after_a_reset_health_and_the_raw_duty_path_see_a_new_origin_not_a_jump() -> None:
    # one front end: the health monitor's ticks and dt, and the raw-duty path's cumulative
    # counts, are re-anchored with the odometry (before, they saw -390 ticks in 0 s)
    seen: list[tuple[tuple[int, int], float]] = []
    for duty in (False, True):
        source = _Duties() if duty else None
        core = HostCore(
            load_config(DEFAULT_CONFIG), NullOutput(), lambda m: None, duty_source=source
        )
        hm = core.health
        assert hm is not None
        real = hm.update

        def spy(inp, real=real):  # type: ignore[no-untyped-def]
            seen.append((inp.ticks, inp.dt_s))
            return real(inp)

        hm.update = spy  # type: ignore[method-assign]
        core.on_frame(frame(info(0x1111)))
        drive(core, 5_000_000, 0, 40, 10)  # 390 ticks
        seen.clear()
        core.on_frame(frame(info(0x2222)))
        drive(core, 300_000, 0, 3, 10)  # the new boot's counts: 0, 10, 20
        assert seen[0] == ((0, 0), 0.0)  # the new origin: no motion, no time
        assert seen[1][0] == (10, 10) and abs(seen[1][1] - 0.05) < 1e-9
        if source is not None:
            assert source.counts[-4:] == [(390, 390), (390, 390), (400, 400), (410, 410)]
