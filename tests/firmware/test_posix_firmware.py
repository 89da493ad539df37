"""End to end: the compiled firmware core on Linux, over a real pty, read by the Python codec."""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import pytest

from jackson.protocol import (
    Ack,
    Heartbeat,
    HostState,
    Info,
    MotorPwm,
    Nack,
    SetImuCalibration,
    SetRate,
    Telemetry,
    TelemetryFlags,
    ZeroCounters,
    check_peer,
    hello,
)
from jackson.protocol.messages import FAILSAFE_MS_DEFAULT

from .posix_firmware import PosixFirmware, imu_registers

PERIOD_US = 50_000
FAILSAFE_US = 1000 * FAILSAFE_MS_DEFAULT  # the device's failsafe until a SET_CONFIG


@pytest.fixture
def fw() -> Iterator[PosixFirmware]:
    f = PosixFirmware("--motors")
    yield f
    f.close()


def start_session(fw: PosixFirmware, t_us: int = 100_000) -> int:
    fw.step(t_us)
    fw.send(hello())
    fw.step(t_us + 1_000)
    got = fw.receive()
    infos = [m for m in got if isinstance(m, Info)]
    assert len(infos) == 1
    check_peer(infos[0])
    assert any(isinstance(m, Ack) for m in got)
    return t_us + 1_000


def test_nothing_is_sent_before_hello(fw: PosixFirmware) -> None:
    for k in range(1, 11):
        fw.step(k * PERIOD_US)
    assert fw.receive() == []


def test_counts_and_imu_values_come_out_as_fed(fw: PosixFirmware) -> None:
    t0 = start_session(fw)
    regs = imu_registers((120, -80, 16300), -1700, (15, -25, 655))
    fed: dict[int, tuple[int, int]] = {}
    for k in range(1, 41):
        t = t0 + k * PERIOD_US
        left, right = 31 * k * k, -29 * k * k  # accelerating; crosses the 30000 PCNT limit
        fw.step(t, left, right, True, regs)
        fed[t] = (left, right)
    tel = [m for m in fw.receive() if isinstance(m, Telemetry)]
    assert len(tel) == 40
    for m in tel:
        assert (m.enc_left, m.enc_right) == fed[m.t_us]
        assert m.accel == (120, -80, 16300)
        assert m.gyro == (15, -25, 655)
        assert m.temp == -1700
        assert m.flags & TelemetryFlags.IMU_OK
    assert [b.t_us - a.t_us for a, b in itertools.pairwise(tel)] == [PERIOD_US] * 39
    assert max(m.enc_left for m in tel) > 30_000


def test_commands_are_acknowledged_and_take_effect(fw: PosixFirmware) -> None:
    t = start_session(fw)
    seq = fw.send(SetRate(rate_hz=100))
    t += 1_000
    fw.step(t, 500, 500)
    got = fw.receive()
    assert Ack(acked_type=SetRate.TYPE, acked_seq=seq, acked_crc=fw.last_crc) in got
    fw.step(t + 100_000, 500, 500)
    tel = [m for m in fw.receive() if isinstance(m, Telemetry)]
    assert len(tel) == 10  # 100 Hz
    seq = fw.send(ZeroCounters(mask=3))
    fw.step(t + 101_000, 500, 500)
    assert Ack(acked_type=ZeroCounters.TYPE, acked_seq=seq, acked_crc=fw.last_crc) in fw.receive()
    fw.step(t + 120_000, 520, 490)
    tel = [m for m in fw.receive() if isinstance(m, Telemetry)]
    assert (tel[-1].enc_left, tel[-1].enc_right) == (20, -10)
    bad = fw.send(SetRate(rate_hz=0))
    fw.step(t + 121_000, 520, 490)
    assert (
        Nack(acked_type=SetRate.TYPE, acked_seq=bad, error=2, acked_crc=fw.last_crc) in fw.receive()
    )


def test_calibration_turns_raw_into_flagged_base_frame_values(fw: PosixFirmware) -> None:
    t = start_session(fw)
    regs = imu_registers((1000, 0, 15531), 0, (0, 131, 0))
    fw.send(
        SetImuCalibration(
            imu_rotation=(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
            gyro_bias=(0.0, 0.0, 0.0),
            accel_scale=9.81 / 9.299,
            persist=0,
        )
    )
    fw.step(t + 1_000, 0, 0, True, regs)
    fw.step(t + 60_000, 0, 0, True, regs)
    tel = [m for m in fw.receive() if isinstance(m, Telemetry)]
    assert tel[-1].flags & TelemetryFlags.IMU_CALIBRATED
    assert tel[-1].gyro == (-131, 0, 0)
    assert tel[-1].accel[1] == round(1000 * 9.81 / 9.299)
    assert abs(tel[-1].accel[2] - 16384) <= 1


def test_missing_imu_is_flagged_and_telemetry_keeps_its_rate(fw: PosixFirmware) -> None:
    t = start_session(fw)
    for k in range(1, 21):
        fw.step(t + k * PERIOD_US, k, k, imu_ok=False)
    tel = [m for m in fw.receive() if isinstance(m, Telemetry)]
    assert len(tel) == 20
    assert not tel[-1].flags & TelemetryFlags.IMU_OK
    assert tel[-1].enc_left == 20


def test_motor_failsafe_brakes_failsafe_ms_after_the_last_heartbeat(fw: PosixFirmware) -> None:
    t = start_session(fw)
    fw.send(MotorPwm(left=5000, right=-2500, timeout_ms=5000))
    hb = fw.send(Heartbeat(ack_seq=0, host_state=HostState.ACTIVE))
    reply = fw.wait_heartbeat(0)  # processes both at the current feed time t
    assert reply.heartbeat_ack == 0
    assert (reply.motor_left, reply.motor_right, reply.braked) == (5000, -2500, False)
    assert hb >= 0
    last = t
    reply = fw.step(last + FAILSAFE_US - 1000)
    assert not reply.braked
    reply = fw.step(last + FAILSAFE_US)
    assert reply.braked and reply.failsafe
    assert (reply.motor_left, reply.motor_right) == (0, 0)
    fw.step(last + FAILSAFE_US + PERIOD_US)
    tel = [m for m in fw.receive() if isinstance(m, Telemetry)]
    assert tel[-1].flags & TelemetryFlags.HOST_LOST
    assert tel[-1].flags & TelemetryFlags.FAILSAFE_ACTIVE


def test_interlock_line_on_the_status_line_follows_the_heartbeats(fw: PosixFirmware) -> None:
    assert not fw.step(50_000).motor_enable  # released at boot
    t = start_session(fw)
    assert not fw.step(t + 10_000).motor_enable  # a session, no heartbeat yet
    fw.send(Heartbeat(ack_seq=0, host_state=HostState.ACTIVE))
    reply = fw.wait_heartbeat(0)
    assert reply.motor_enable
    last = reply.t_us
    assert fw.step(last + FAILSAFE_US - 1000).motor_enable
    # the drop is one of the core's deadlines: the status at failsafe_ms shows it released
    reply = fw.step(last + FAILSAFE_US)
    assert not reply.motor_enable
    fw.step(last + FAILSAFE_US + PERIOD_US)  # one telemetry frame after the drop
    tel = [m for m in fw.receive() if isinstance(m, Telemetry)]
    assert tel[-1].t_us > last + FAILSAFE_US
    assert not tel[-1].flags & TelemetryFlags.MOTOR_ENABLE
    assert all(m.flags & TelemetryFlags.MOTOR_ENABLE for m in tel if m.t_us < last + FAILSAFE_US)
    fw.send(Heartbeat(ack_seq=0, host_state=HostState.ACTIVE))
    assert fw.wait_heartbeat(0).motor_enable  # heartbeats again
    fw.send(Heartbeat(ack_seq=1, host_state=HostState.SHUTDOWN))
    assert not fw.wait_heartbeat(1).motor_enable  # an orderly goodbye


def test_garbage_on_the_link_is_counted_not_fatal(fw: PosixFirmware) -> None:
    t = start_session(fw)
    fw.port.write(bytes([0xA5, 0x5A, 0x01, 0x82, 0x00, 0x02, 0x14, 0x00, 1, 2, 3, 4]) * 3)
    reply = fw.step(t + PERIOD_US)
    assert reply.rx_crc_errors == 3
    assert reply.session
    seq = fw.send(SetRate(rate_hz=20))
    fw.step(t + PERIOD_US + 1_000)
    assert Ack(acked_type=SetRate.TYPE, acked_seq=seq, acked_crc=fw.last_crc) in fw.receive()


def test_client_can_close_and_reopen_the_port(fw: PosixFirmware) -> None:
    t = start_session(fw)
    fw.port.close()
    for k in range(1, 5):
        fw.step(t + k * PERIOD_US, k, k)
    fw.port.open()
    fw.port.reset_input_buffer()
    fw.step(t + 5 * PERIOD_US, 5, 5)
    tel = [m for m in fw.receive() if isinstance(m, Telemetry)]
    assert tel and tel[-1].enc_left == 5


def test_a_new_sessions_hello_ends_the_wait_for_the_old_sessions_frame(
    fw: PosixFirmware,
) -> None:
    """Lockstep waits for a frame's HEARTBEAT; a HELLO with another session id means that
    frame's host is gone (the new host never acknowledges it): the wait ends at once, not at
    its timeout (ten minutes here, beyond the test's own limit)."""
    fw.step(100_000)
    fw.send(hello(0x1111))
    reply = fw.step(100_000 + 3 * PERIOD_US)  # the first session's first telemetry frames
    assert reply.session and reply.telemetry_seq >= 0
    fw.send(hello(0x2222))  # the next host, before any HEARTBEAT of the first
    reply = fw.wait_heartbeat(reply.telemetry_seq, timeout_ms=600_000)
    assert reply.session and reply.telemetry_seq == -1  # the new session, none of its frames yet
    assert reply.heartbeat_ack == -1
