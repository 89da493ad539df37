// The firmware core end to end on fakes: handshake, scheduler, commands, failsafe, health.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "fakes.hpp"

using namespace jackson::fw;
using namespace jackson::fw::test;
namespace proto = jackson::protocol;

namespace {

proto::Nack nack_of(const std::vector<Sent>& sent) {
  const auto n = only<proto::Nack>(sent);
  EXPECT_EQ(n.size(), 1u);
  return n.empty() ? proto::Nack{} : n[0].as<proto::Nack>();
}

bool acked(const std::vector<Sent>& sent, uint8_t type, uint8_t seq) {
  for (const auto& s : only<proto::Ack>(sent)) {
    const auto a = s.as<proto::Ack>();
    if (a.acked_type == type && a.acked_seq == seq) return true;
  }
  return false;
}

void heartbeat(Bench& b, uint8_t seq, uint8_t ack_seq = 0) {
  proto::Heartbeat hb;
  hb.ack_seq = ack_seq;
  hb.host_state = static_cast<uint8_t>(proto::HostState::kActive);
  b.serial.host_sends(hb, seq);
}

}  // namespace

TEST(Firmware, SendsNothingBeforeHello) {
  Bench b;
  b.fw.begin();
  b.run_for(2'000'000);
  EXPECT_TRUE(b.take_sent().empty());
}

TEST(Firmware, HelloIsAnsweredWithInfoAndAck) {
  Bench b;
  b.fw.begin();
  const auto sent = b.hello(5);
  const auto info = only<proto::Info>(sent);
  ASSERT_EQ(info.size(), 1u);
  const auto i = info[0].as<proto::Info>();
  EXPECT_EQ(i.protocol_version, proto::kProtocolVersion);
  EXPECT_EQ(i.schema_hash, proto::kSchemaHash);
  EXPECT_EQ(i.telemetry_rate_hz, 20);
  EXPECT_EQ(i.failsafe_ms, proto::kFailsafeMsDefault);  // until the host's SET_CONFIG
  EXPECT_TRUE(i.capabilities & proto::capabilities::kImuPresent);
  EXPECT_TRUE(i.capabilities & proto::capabilities::kMotorOutput);
  EXPECT_TRUE(acked(sent, proto::Hello::kType, 5));
  EXPECT_TRUE(b.fw.session_active());
}

TEST(Firmware, HelloWithAnotherSchemaIsRefusedAndNoTelemetryFollows) {
  Bench b;
  b.fw.begin();
  proto::Hello h;
  h.protocol_version = proto::kProtocolVersion;
  h.schema_hash = proto::kSchemaHash ^ 0x1u;
  b.serial.host_sends(h, 0);
  b.fw.tick();
  const auto sent = b.take_sent();
  EXPECT_EQ(only<proto::Info>(sent).size(), 1u);  // so the host can name both versions
  EXPECT_EQ(nack_of(sent).error, static_cast<uint8_t>(proto::NackError::kVersionMismatch));
  b.run_for(1'000'000);
  EXPECT_TRUE(only<proto::Telemetry>(b.take_sent()).empty());
}

TEST(Firmware, TelemetryAt20HzByDefault) {
  Bench b;
  b.fw.begin();
  b.hello();
  b.run_for(1'000'000);
  const auto t = only<proto::Telemetry>(b.take_sent());
  EXPECT_EQ(t.size(), 20u);
  for (size_t i = 1; i < t.size(); ++i) {
    EXPECT_EQ(t[i].as<proto::Telemetry>().t_us - t[i - 1].as<proto::Telemetry>().t_us, 50'000u);
  }
}

TEST(Firmware, SetRateTo200Hz) {
  Bench b;
  b.fw.begin();
  b.hello();
  proto::SetRate r;
  r.rate_hz = 200;
  b.serial.host_sends(r, 1);
  b.fw.tick();
  EXPECT_TRUE(acked(b.take_sent(), proto::SetRate::kType, 1));
  b.run_for(1'000'000, 500);
  const auto t = only<proto::Telemetry>(b.take_sent());
  EXPECT_EQ(t.size(), 200u);
  EXPECT_EQ(t[1].as<proto::Telemetry>().t_us - t[0].as<proto::Telemetry>().t_us, 5'000u);
}

TEST(Firmware, SetRateOutOfRangeIsNackedAndChangesNothing) {
  Bench b;
  b.fw.begin();
  b.hello();
  for (uint16_t bad : {uint16_t{0}, uint16_t{501}}) {
    proto::SetRate r;
    r.rate_hz = bad;
    b.serial.host_sends(r, 2);
    b.fw.tick();
    EXPECT_EQ(nack_of(b.take_sent()).error, static_cast<uint8_t>(proto::NackError::kBadValue));
  }
  EXPECT_EQ(b.fw.config().telemetry_rate_hz, 20);
  EXPECT_EQ(b.fw.rx_bad_commands(), 2u);
}

TEST(Firmware, TelemetryCarriesCountsAndTheMeanImuSample) {
  Bench b;
  b.fw.begin();
  b.hello();
  b.enc.set_total(123456, -654321);
  b.run_for(100'000);
  const auto t = only<proto::Telemetry>(b.take_sent());
  ASSERT_FALSE(t.empty());
  const auto m = t.back().as<proto::Telemetry>();
  EXPECT_EQ(m.enc_left, 123456);
  EXPECT_EQ(m.enc_right, -654321);
  EXPECT_EQ(m.accel, (std::array<int16_t, 3>{100, -200, 16384}));
  EXPECT_EQ(m.temp, -1700);
  EXPECT_EQ(m.gyro, (std::array<int16_t, 3>{10, -20, 30}));
  EXPECT_TRUE(m.flags & proto::telemetry_flags::kImuOk);
  EXPECT_FALSE(m.flags & proto::telemetry_flags::kImuCalibrated);
  // the jump past the 16-bit limit shows once, in the first frame after it
  EXPECT_TRUE(t.front().as<proto::Telemetry>().flags & proto::telemetry_flags::kPcntOverflow);
  EXPECT_FALSE(m.flags & proto::telemetry_flags::kPcntOverflow);
}

TEST(Firmware, MissingImuNeverDelaysTelemetry) {
  Bench b;
  b.i2c.present = false;
  b.fw.begin();
  const auto info = only<proto::Info>(b.hello());
  EXPECT_FALSE(info[0].as<proto::Info>().capabilities & proto::capabilities::kImuPresent);
  b.enc.set_total(10, 20);
  b.run_for(1'000'000);
  const auto t = only<proto::Telemetry>(b.take_sent());
  EXPECT_EQ(t.size(), 20u);
  const auto m = t.back().as<proto::Telemetry>();
  EXPECT_EQ(m.enc_left, 10);
  EXPECT_FALSE(m.flags & proto::telemetry_flags::kImuOk);
  int flagged = 0;
  for (const auto& f : t) flagged += (f.as<proto::Telemetry>().flags & proto::telemetry_flags::kI2cErrors) ? 1 : 0;
  EXPECT_GE(flagged, 3);  // every frame after a failed retry
  // bounded I2C traffic: backoff, not a transaction every millisecond
  EXPECT_LT(b.i2c.transactions, 30);
}

TEST(Firmware, ZeroCountersIsASoftwareOffset) {
  Bench b;
  b.fw.begin();
  b.hello();
  b.enc.set_total(5000, 7000);
  proto::ZeroCounters z;
  z.mask = 1;
  b.serial.host_sends(z, 3);
  b.fw.tick();
  EXPECT_TRUE(acked(b.take_sent(), proto::ZeroCounters::kType, 3));
  b.enc.set_total(5100, 7100);
  b.run_for(60'000);
  const auto m = only<proto::Telemetry>(b.take_sent()).back().as<proto::Telemetry>();
  EXPECT_EQ(m.enc_left, 100);
  EXPECT_EQ(m.enc_right, 7100);
  z.mask = 4;
  b.serial.host_sends(z, 4);
  b.fw.tick();
  EXPECT_EQ(nack_of(b.take_sent()).error, static_cast<uint8_t>(proto::NackError::kBadValue));
}

TEST(Firmware, CalibrationIsAppliedOnceFlaggedPersistedAndReported) {
  Bench b;
  b.fw.begin();
  b.hello();
  proto::SetImuCalibration c;
  c.imu_rotation = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  c.gyro_bias = {0, 0, 0};
  c.accel_scale = 2.0f;
  c.persist = 1;
  b.serial.host_sends(c, 7);
  b.fw.tick();
  EXPECT_TRUE(acked(b.take_sent(), proto::SetImuCalibration::kType, 7));
  b.run_for(60'000);
  const auto m = only<proto::Telemetry>(b.take_sent()).back().as<proto::Telemetry>();
  EXPECT_TRUE(m.flags & proto::telemetry_flags::kImuCalibrated);
  EXPECT_EQ(m.accel, (std::array<int16_t, 3>{400, 200, 32767}));  // rotated, x2, saturated
  EXPECT_EQ(m.gyro, (std::array<int16_t, 3>{20, 10, 30}));
  // a second board boots from the same storage with the calibration in place
  Bench b2;
  b2.storage = b.storage;
  b2.fw.begin();
  const auto info = only<proto::Info>(b2.hello())[0].as<proto::Info>();
  EXPECT_TRUE(info.capabilities & proto::capabilities::kCalibrationStored);
  EXPECT_EQ(info.imu_rotation[1], -1.0f);
  EXPECT_EQ(info.accel_scale, 2.0f);
}

TEST(Firmware, TheSameCalibrationAgainKeepsTheFramesAverage) {
  // a host that says HELLO again re-sends its calibration: a frame's mean must not lose the
  // samples taken before it (a new calibration does restart the mean)
  auto frame_gyro_x = [](bool same) {
    Bench b;
    b.fw.begin();
    b.hello();
    proto::SetImuCalibration c;
    c.imu_rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    c.gyro_bias = {0, 0, 0};
    c.accel_scale = 1.0f;
    b.serial.host_sends(c, 1);
    b.fw.tick();
    b.run_for(60'000);  // the first frame; the second is due 50 ms after it
    b.take_sent();
    b.i2c.set_sample({100, -200, 16384}, -1700, {1000, -20, 30});
    b.run_for(20'000);
    if (!same) c.accel_scale = 1.5f;
    b.serial.host_sends(c, 2);
    b.fw.tick();
    b.run_for(40'000);
    return only<proto::Telemetry>(b.take_sent()).back().as<proto::Telemetry>().gyro[0];
  };
  EXPECT_LT(frame_gyro_x(true), 1000);  // samples of 10 before the repeat are in the mean
  EXPECT_EQ(frame_gyro_x(false), 1000);  // a new calibration: only its own samples
}

TEST(Firmware, InvalidCalibrationIsNackedAndStorageFailureLeavesNothingChanged) {
  Bench b;
  b.fw.begin();
  b.hello();
  proto::SetImuCalibration c;
  c.imu_rotation = {1, 0, 0, 0, 1, 0, 0, 0, -1};  // a reflection
  c.accel_scale = 1.0f;
  b.serial.host_sends(c, 1);
  b.fw.tick();
  EXPECT_EQ(nack_of(b.take_sent()).error, static_cast<uint8_t>(proto::NackError::kBadValue));
  c.imu_rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  c.persist = 1;
  b.storage.fail = true;
  b.serial.host_sends(c, 2);
  b.fw.tick();
  EXPECT_EQ(nack_of(b.take_sent()).error, static_cast<uint8_t>(proto::NackError::kStorage));
  EXPECT_FALSE(b.fw.calibrated());
}

TEST(Firmware, SetConfigChangesRangesDirectionAndFailsafe) {
  Bench b;
  b.fw.begin();
  b.hello();
  b.enc.set_total(100, 100);
  b.run_for(60'000);
  proto::SetConfig c;
  c.accel_fs = 2;
  c.gyro_fs = 3;
  c.direction_flags = 2;
  c.failsafe_ms = 300;
  b.serial.host_sends(c, 9);
  b.fw.tick();
  EXPECT_TRUE(acked(b.take_sent(), proto::SetConfig::kType, 9));
  b.enc.set_total(150, 150);
  b.run_for(60'000);
  const auto m = only<proto::Telemetry>(b.take_sent()).back().as<proto::Telemetry>();
  EXPECT_EQ((m.flags >> 8) & 3, 2);
  EXPECT_EQ((m.flags >> 10) & 3, 3);
  EXPECT_EQ(b.i2c.regs[0x1C], 2 << 3);
  EXPECT_EQ(b.i2c.regs[0x1B], 3 << 3);
  EXPECT_EQ(m.enc_left, 150);
  EXPECT_EQ(m.enc_right, -50);  // inverted from where it stood: counts backwards, no jump
  EXPECT_EQ(b.fw.config().failsafe_ms, 300);
  c.failsafe_ms = 20;  // below the minimum
  b.serial.host_sends(c, 10);
  b.fw.tick();
  EXPECT_EQ(nack_of(b.take_sent()).error, static_cast<uint8_t>(proto::NackError::kBadValue));
}

TEST(Firmware, RequestInfoGetsInfoStatusAndAck) {
  Bench b;
  b.fw.begin();
  b.hello();
  b.serial.host_sends(proto::RequestInfo{}, 4);
  b.fw.tick();
  const auto sent = b.take_sent();
  EXPECT_EQ(only<proto::Info>(sent).size(), 1u);
  EXPECT_EQ(only<proto::Status>(sent).size(), 1u);
  EXPECT_TRUE(acked(sent, proto::RequestInfo::kType, 4));
}

TEST(Firmware, MalformedAndUnknownCommandsAreNackedAndCounted) {
  Bench b;
  b.fw.begin();
  b.hello();
  // SET_RATE with an empty payload
  const uint8_t body[] = {proto::kProtocolVersion, proto::SetRate::kType, 11, 0};
  std::vector<uint8_t> f = {proto::kSync0, proto::kSync1};
  f.insert(f.end(), body, body + 4);
  const uint32_t crc = proto::crc32c(body, 4);
  for (int i = 0; i < 4; ++i) f.push_back(static_cast<uint8_t>(crc >> (8 * i)));
  b.serial.rx = f;
  b.fw.tick();
  auto n = nack_of(b.take_sent());
  EXPECT_EQ(n.error, static_cast<uint8_t>(proto::NackError::kBadLength));
  EXPECT_EQ(n.acked_seq, 11);
  // a type the schema lacks
  const uint8_t body2[] = {proto::kProtocolVersion, 0xF0, 12, 1, 0x42};
  std::vector<uint8_t> g = {proto::kSync0, proto::kSync1};
  g.insert(g.end(), body2, body2 + 5);
  const uint32_t crc2 = proto::crc32c(body2, 5);
  for (int i = 0; i < 4; ++i) g.push_back(static_cast<uint8_t>(crc2 >> (8 * i)));
  b.serial.rx = g;
  b.fw.tick();
  n = nack_of(b.take_sent());
  EXPECT_EQ(n.error, static_cast<uint8_t>(proto::NackError::kUnknownType));
  EXPECT_EQ(n.acked_type, 0xF0);
  // a device-to-host message sent to the device
  b.serial.host_sends(proto::Telemetry{}, 13);
  b.fw.tick();
  EXPECT_EQ(nack_of(b.take_sent()).error, static_cast<uint8_t>(proto::NackError::kUnknownType));
  // garbage: counted, never fatal
  b.serial.rx = {0xA5, 0x5A, 0x01, 0x82, 0x00, 0x02, 0x14, 0x00, 0xDE, 0xAD, 0xBE, 0xEF};
  b.fw.tick();
  EXPECT_EQ(b.fw.rx_counters().crc_errors, 1u);
  EXPECT_EQ(b.fw.rx_bad_commands(), 3u);
  b.run_for(60'000);
  const auto m = only<proto::Telemetry>(b.take_sent()).back().as<proto::Telemetry>();
  EXPECT_TRUE(m.flags & proto::telemetry_flags::kRxErrors);
}

TEST(Firmware, MotorPwmIsClampedAndDirectionCorrected) {
  Bench b;
  b.fw.begin();
  b.hello();
  heartbeat(b, 1);
  proto::MotorPwm m;
  m.left = 12000;
  m.right = -4000;
  b.serial.host_sends(m, 2);
  b.fw.tick();
  EXPECT_TRUE(acked(b.take_sent(), proto::MotorPwm::kType, 2));
  EXPECT_EQ(b.motors.left, 10000);
  EXPECT_EQ(b.motors.right, -4000);
  proto::SetConfig c;
  c.failsafe_ms = 600;
  c.direction_flags = 1;  // left wheel wired backwards: count and output both flip
  b.serial.host_sends(c, 3);
  b.serial.host_sends(m, 4);
  b.fw.tick();
  EXPECT_EQ(b.motors.left, -10000);
  EXPECT_EQ(b.fw.motors().left, 10000);  // still "forward" in the robot's frame
}

TEST(Firmware, MotorPwmWithoutMotorOutputIsNotSupported) {
  Bench b(false);
  b.fw.begin();
  b.hello();
  b.serial.host_sends(proto::MotorPwm{}, 1);
  b.fw.tick();
  EXPECT_EQ(nack_of(b.take_sent()).error, static_cast<uint8_t>(proto::NackError::kNotSupported));
}

TEST(Firmware, FailsafeBrakesWhenHeartbeatsStop) {
  Bench b;
  b.fw.begin();
  b.hello();
  heartbeat(b, 1);
  proto::MotorPwm m;
  m.left = 5000;
  m.right = 5000;
  m.timeout_ms = 5000;  // the command itself would last 5 s
  b.serial.host_sends(m, 2);
  b.fw.tick();
  ASSERT_FALSE(b.motors.braked);
  const uint32_t last_heartbeat = b.clock.t;
  while (!b.motors.braked && b.clock.t - last_heartbeat < 2'000'000) b.run_for(1000);
  EXPECT_TRUE(b.motors.braked);
  // at the default failsafe (0.2 s), to the millisecond tick
  EXPECT_EQ(b.clock.t - last_heartbeat, 1000u * proto::kFailsafeMsDefault);
  EXPECT_TRUE(b.fw.motors().failsafe);
  b.run_for(50'000);
  const auto t = only<proto::Telemetry>(b.take_sent()).back().as<proto::Telemetry>();
  EXPECT_TRUE(t.flags & proto::telemetry_flags::kHostLost);
  EXPECT_TRUE(t.flags & proto::telemetry_flags::kFailsafeActive);
}

TEST(Firmware, FailsafeBrakesWhenMotorCommandsStop) {
  Bench b;
  b.fw.begin();
  b.hello();
  proto::MotorPwm m;
  m.left = 3000;
  b.serial.host_sends(m, 1);
  heartbeat(b, 2);
  b.fw.tick();
  const uint32_t sent_at = b.clock.t;
  for (int i = 0; i < 30 && !b.motors.braked; ++i) {  // heartbeats keep coming, commands do not
    heartbeat(b, static_cast<uint8_t>(3 + i));
    b.run_for(50'000);
  }
  EXPECT_TRUE(b.motors.braked);
  EXPECT_LE(b.clock.t - sent_at, 1000u * proto::kFailsafeMsDefault + 50'000u);
  EXPECT_GE(b.clock.t - sent_at, 1000u * proto::kFailsafeMsDefault);
}

TEST(Firmware, ShutdownHeartbeatBrakesAtOnce) {
  Bench b;
  b.fw.begin();
  b.hello();
  heartbeat(b, 1);
  proto::MotorPwm m;
  m.left = 3000;
  b.serial.host_sends(m, 2);
  b.fw.tick();
  ASSERT_FALSE(b.motors.braked);
  proto::Heartbeat bye;
  bye.host_state = static_cast<uint8_t>(proto::HostState::kShutdown);
  b.serial.host_sends(bye, 3);
  b.fw.tick();
  EXPECT_TRUE(b.motors.braked);
  EXPECT_FALSE(b.fw.motors().failsafe);
}

// ---- motor interlock (docs/firmware.md, "Motor interlock") ----------------------------------

namespace {

bool flag_set(const Sent& s, uint16_t bit) {
  if (s.type == proto::Telemetry::kType) return (s.as<proto::Telemetry>().flags & bit) != 0;
  return (s.as<proto::Status>().flags & bit) != 0;
}

/// A session with one heartbeat, on the PCA9685 path (no MCU motor output).
Bench& live_session(Bench& b, uint32_t session = 0) {
  b.fw.begin();
  b.hello(0, session);
  heartbeat(b, 1);
  b.fw.tick();
  b.take_sent();
  return b;
}

}  // namespace

TEST(Interlock, ReleasedAtBootAndBeforeTheFirstHeartbeat) {
  Bench b(false);
  b.fw.begin();
  EXPECT_FALSE(b.enable.enabled);  // begin() sets the pull resistor's state explicitly
  EXPECT_EQ(b.enable.changes, (std::vector<bool>{false}));
  b.run_for(100'000);
  b.hello();
  b.run_for(100'000);  // a session, but no heartbeat yet
  EXPECT_FALSE(b.enable.enabled);
  EXPECT_FALSE(b.fw.motor_enable());
  EXPECT_EQ(b.enable.changes.size(), 1u);  // set() only on changes
  for (const auto& t : only<proto::Telemetry>(b.take_sent())) {
    EXPECT_FALSE(flag_set(t, proto::telemetry_flags::kMotorEnable));
  }
}

TEST(Interlock, HeartbeatBeforeHelloDoesNotAssert) {
  Bench b(false);
  b.fw.begin();
  heartbeat(b, 0);
  b.fw.tick();
  b.run_for(10'000);
  EXPECT_FALSE(b.enable.enabled);
}

TEST(Interlock, AssertedInTheTickThatReceivesTheFirstHeartbeat) {
  Bench b(false);
  b.fw.begin();
  b.hello();
  b.run_for(10'000);
  heartbeat(b, 1);
  b.fw.tick();
  EXPECT_TRUE(b.enable.enabled);
  EXPECT_EQ(b.enable.at_us.back(), b.clock.t);
  EXPECT_EQ(b.enable.changes, (std::vector<bool>{false, true}));
}

TEST(Interlock, DropsExactlyWhenFailsafeMsPassWithoutHeartbeat) {
  Bench b(false);
  live_session(b);
  const uint32_t last_hb = b.clock.t;
  const uint32_t lost = last_hb + 1000u * b.fw.config().failsafe_ms;
  b.run_for(lost - last_hb - 1000);  // to 1 ms before the deadline
  EXPECT_TRUE(b.enable.enabled);
  b.clock.t = lost - 1;
  b.fw.tick();
  EXPECT_TRUE(b.enable.enabled);  // 1 us before the deadline: still live
  b.clock.t = lost;
  b.fw.tick();
  EXPECT_FALSE(b.enable.enabled);
  EXPECT_EQ(b.enable.at_us.back(), lost);
  EXPECT_EQ(b.enable.changes, (std::vector<bool>{false, true, false}));
}

TEST(Interlock, HeartbeatsAreCountedAndTheLostInstantIsFailsafeMsAfterTheLast) {
  // what a simulator reads to stop at the drop and to tell a host that came back
  Bench b(false);
  b.fw.begin();
  heartbeat(b, 0);  // outside a session: not taken
  b.fw.tick();
  EXPECT_EQ(b.fw.heartbeats(), 0u);
  b.hello();
  b.run_for(20'000);
  heartbeat(b, 1);
  b.fw.tick();
  heartbeat(b, 2);
  b.fw.tick();
  EXPECT_EQ(b.fw.heartbeats(), 2u);
  EXPECT_EQ(b.fw.sessions(), 1u);
  EXPECT_EQ(b.fw.last_heartbeat_us(), b.clock.t);
  EXPECT_EQ(b.fw.host_lost_us(), b.clock.t + 1000u * b.fw.config().failsafe_ms);
  const uint32_t lost = b.fw.host_lost_us();
  b.clock.t = lost;
  b.fw.tick();
  EXPECT_FALSE(b.enable.enabled);
  EXPECT_TRUE(b.fw.telemetry_flags(lost) & proto::telemetry_flags::kHostLost);
  EXPECT_FALSE(b.fw.telemetry_flags(lost) & proto::telemetry_flags::kMotorEnable);
}

TEST(Interlock, EverySessionAHelloBeginsIsCountedTheSameHostsRepeatIsNot) {
  // a simulator tells that a host is there by it, before the session's first HEARTBEAT
  Bench b(false);
  b.fw.begin();
  EXPECT_EQ(b.fw.sessions(), 0u);
  b.hello(0, 7);
  EXPECT_EQ(b.fw.sessions(), 1u);
  b.hello(1, 7);  // the same host again, its session going on
  EXPECT_EQ(b.fw.sessions(), 1u);
  b.hello(2, 8);  // a new host before any frame of the old session went out
  EXPECT_EQ(b.fw.sessions(), 2u);
  b.hello(3, 0);  // a host without a session id: a session each time
  b.hello(4, 0);
  EXPECT_EQ(b.fw.sessions(), 4u);
  EXPECT_EQ(b.fw.heartbeats(), 0u);
}

TEST(Interlock, NextDeadlineIncludesTheInstantTheLineDrops) {
  // a lockstep run ticks only at next_deadline(): it must stop at the drop, not at the next frame
  Bench b(false);
  live_session(b);
  const uint32_t lost = b.clock.t + 1000u * b.fw.config().failsafe_ms;
  for (int i = 0; i < 1000 && b.enable.enabled; ++i) {
    b.clock.t = b.fw.next_deadline();
    b.fw.tick();
  }
  EXPECT_FALSE(b.enable.enabled);
  EXPECT_EQ(b.enable.at_us.back(), lost);
}

TEST(Interlock, NextDeadlineFindsTheDropBetweenTelemetryFramesAtAnyFailsafe) {
  Bench b(false);
  b.fw.begin();
  b.hello();
  proto::SetConfig c;
  c.failsafe_ms = 333;  // not a multiple of the 50 ms telemetry or 10 ms IMU period
  b.serial.host_sends(c, 1);
  b.fw.tick();
  b.clock.t += 3'000;
  heartbeat(b, 2);
  b.fw.tick();
  ASSERT_TRUE(b.enable.enabled);
  const uint32_t lost = b.clock.t + 333'000u;
  while (b.enable.enabled) {
    b.clock.t = b.fw.next_deadline();
    b.fw.tick();
  }
  EXPECT_EQ(b.enable.at_us.back(), lost);
}

TEST(Interlock, ShutdownHeartbeatReleasesAtOnce) {
  Bench b(false);
  live_session(b);
  b.run_for(20'000);
  proto::Heartbeat bye;
  bye.host_state = static_cast<uint8_t>(proto::HostState::kShutdown);
  b.serial.host_sends(bye, 2);
  b.fw.tick();
  EXPECT_FALSE(b.enable.enabled);
  EXPECT_EQ(b.enable.at_us.back(), b.clock.t);
  b.run_for(200'000);  // further SHUTDOWN heartbeats keep it released
  b.serial.host_sends(bye, 3);
  b.run_for(200'000);
  EXPECT_FALSE(b.enable.enabled);
  heartbeat(b, 4);  // an ACTIVE host again
  b.fw.tick();
  EXPECT_TRUE(b.enable.enabled);
}

TEST(Interlock, AssertedAgainWhenHeartbeatsResume) {
  Bench b(false);
  live_session(b);
  b.run_for(700'000);
  ASSERT_FALSE(b.enable.enabled);
  heartbeat(b, 2);
  b.fw.tick();
  EXPECT_TRUE(b.enable.enabled);
  EXPECT_EQ(b.enable.changes, (std::vector<bool>{false, true, false, true}));
}

TEST(Interlock, NewHelloReleasesUntilItsFirstHeartbeat) {
  Bench b(false);
  live_session(b);
  b.run_for(20'000);
  b.hello(5);  // the host reconnects: the old session's heartbeats no longer count
  EXPECT_FALSE(b.enable.enabled);
  heartbeat(b, 6);
  b.fw.tick();
  EXPECT_TRUE(b.enable.enabled);
}

TEST(Interlock, TheSameSessionsHelloChangesNothing) {
  Bench b(false);
  live_session(b, 0x5E55u);
  b.run_for(70'000);  // telemetry 50 ms after the HELLO
  const auto before = only<proto::Telemetry>(b.take_sent());
  ASSERT_EQ(before.size(), 1u);
  const auto again = b.hello(5, 0x5E55u);  // the host heard nothing for a while: HELLO again
  EXPECT_EQ(only<proto::Info>(again).size(), 1u);
  EXPECT_TRUE(acked(again, proto::Hello::kType, 5));
  EXPECT_TRUE(b.enable.enabled);  // the interlock holds
  EXPECT_EQ(b.enable.changes, (std::vector<bool>{false, true}));
  b.run_for(100'000);
  const auto t = only<proto::Telemetry>(b.take_sent());
  ASSERT_EQ(t.size(), 2u);
  // on the session's schedule (a new session's would be 50 ms after the HELLO, not the frame)
  EXPECT_EQ(t[0].as<proto::Telemetry>().t_us - before[0].as<proto::Telemetry>().t_us, 50'000u);
  EXPECT_EQ(t[1].as<proto::Telemetry>().t_us - t[0].as<proto::Telemetry>().t_us, 50'000u);
}

TEST(Interlock, AnotherSessionsHelloStartsOver) {
  Bench b(false);
  live_session(b, 0x5E55u);
  b.run_for(20'000);
  ASSERT_TRUE(b.enable.enabled);
  b.hello(5, 0x5E56u);  // another connection
  EXPECT_FALSE(b.enable.enabled);
  b.hello(6, 0x5E55u);  // the first id is not the session in progress any more
  b.hello(7, 0x5E55u);  // but now it is: answered, and nothing restarts
  heartbeat(b, 8);
  b.fw.tick();
  EXPECT_TRUE(b.enable.enabled);
  b.hello(9, 0x5E55u);
  EXPECT_TRUE(b.enable.enabled);
}

TEST(Firmware, HelloWithoutASessionIdIsAnotherSchema) {
  Bench b;
  b.fw.begin();
  // the HELLO of the schema before the session id: version and hash only (5 bytes)
  std::vector<uint8_t> body = {proto::kProtocolVersion, proto::Hello::kType, 3, 5,
                               proto::kProtocolVersion};
  for (int i = 0; i < 4; ++i) body.push_back(static_cast<uint8_t>(0xc8da2512u >> (8 * i)));
  const uint32_t crc = proto::crc32c(body.data(), body.size());
  std::vector<uint8_t> f = {proto::kSync0, proto::kSync1};
  f.insert(f.end(), body.begin(), body.end());
  for (int i = 0; i < 4; ++i) f.push_back(static_cast<uint8_t>(crc >> (8 * i)));
  b.serial.rx = f;
  b.fw.tick();
  const auto sent = b.take_sent();
  EXPECT_EQ(only<proto::Info>(sent).size(), 1u);  // so that host can name both hashes
  EXPECT_EQ(nack_of(sent).error, static_cast<uint8_t>(proto::NackError::kVersionMismatch));
  EXPECT_FALSE(b.fw.session_active());
}

TEST(Interlock, TelemetryAndStatusFlagMirrorTheLine) {
  Bench b(false);
  b.fw.begin();
  b.hello();
  uint8_t seq = 1;
  uint32_t checked = 0;
  // 3 s: heartbeats for 1 s, silence for 1 s, heartbeats again for 1 s
  for (uint32_t ms = 0; ms < 3000; ++ms) {
    if ((ms < 1000 || ms >= 2000) && ms % 50 == 0) heartbeat(b, seq++);
    b.clock.t += 1000;
    b.fw.tick();
    for (const auto& s : b.take_sent()) {
      if (s.type != proto::Telemetry::kType && s.type != proto::Status::kType) continue;
      EXPECT_EQ(flag_set(s, proto::telemetry_flags::kMotorEnable), b.enable.enabled) << ms;
      ++checked;
    }
  }
  EXPECT_GT(checked, 55u);
  EXPECT_EQ(b.enable.changes, (std::vector<bool>{false, true, false, true}));
}

TEST(Interlock, MotorPathKeepsItsOwnFailsafeBesideTheLine) {
  Bench b(true);  // the MCU drives the motors and holds the line
  b.fw.begin();
  b.hello();
  heartbeat(b, 1);
  proto::MotorPwm m;
  m.left = 5000;
  m.right = -5000;
  m.timeout_ms = 2000;
  b.serial.host_sends(m, 2);
  b.fw.tick();
  EXPECT_TRUE(b.enable.enabled);
  EXPECT_FALSE(b.motors.braked);
  b.run_for(600'000);
  EXPECT_FALSE(b.enable.enabled);
  EXPECT_TRUE(b.motors.braked);
  EXPECT_TRUE(b.fw.motors().failsafe);
}

TEST(Interlock, UnwiredLineStillReportsTheRule) {
  FakeClock clock;
  FakeEncoders enc;
  FakeI2c i2c;
  FakeSerial serial;
  FakeStorage storage;
  Hal hal{clock, enc, i2c, serial, storage, nullptr};  // boot_id and motor_enable defaulted
  Firmware fw(hal);
  fw.begin();
  proto::Hello h;
  h.protocol_version = proto::kProtocolVersion;
  h.schema_hash = proto::kSchemaHash;
  serial.host_sends(h, 0);
  fw.tick();
  proto::Heartbeat hb;
  serial.host_sends(hb, 1);
  fw.tick();
  EXPECT_TRUE(fw.motor_enable());
}

TEST(Firmware, FullTxBufferDropsAndCountsWithoutBlocking) {
  Bench b;
  b.fw.begin();
  b.hello();
  b.serial.full = true;
  b.run_for(500'000);
  EXPECT_EQ(b.fw.tx_dropped(), 10u);
  b.serial.full = false;
  b.run_for(50'000);
  const auto sent = b.take_sent();
  const auto t = only<proto::Telemetry>(sent);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_TRUE(t[0].as<proto::Telemetry>().flags & proto::telemetry_flags::kTxDropped);
  EXPECT_EQ(b.host_decoder.counters().seq_lost, 10u);  // the host sees exactly what was lost
}

TEST(Firmware, EveryHostMessageVectorIsAnswered) {
  std::ifstream in(std::string(JACKSON_VECTORS_DIR) + "/messages.json");
  const auto doc = nlohmann::json::parse(in);
  int answered = 0;
  for (const auto& v : doc.at("vectors")) {
    const std::string hex = v.at("hex");
    std::vector<uint8_t> bytes;
    for (size_t i = 0; i + 1 < hex.size(); i += 2) {
      bytes.push_back(static_cast<uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
    }
    if (bytes[3] < 0x80 || bytes[3] == proto::Hello::kType) continue;
    Bench b;
    b.fw.begin();
    b.hello();
    b.serial.rx = bytes;
    b.fw.tick();
    const auto sent = b.take_sent();
    SCOPED_TRACE(v.at("name").get<std::string>());
    if (bytes[3] == proto::Heartbeat::kType) {
      uint8_t ack = 0;
      EXPECT_TRUE(b.fw.last_heartbeat_ack(ack));
      EXPECT_EQ(ack, v.at("fields").at("ack_seq").get<int>());
    } else {
      EXPECT_EQ(only<proto::Ack>(sent).size() + only<proto::Nack>(sent).size(), 1u);
    }
    ++answered;
  }
  EXPECT_EQ(answered, 7);  // every host-to-device message but HELLO
}
