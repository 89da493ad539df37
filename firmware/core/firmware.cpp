#include "firmware.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace jackson::fw {

namespace proto = jackson::protocol;

namespace {

bool reached(uint32_t now, uint32_t t) { return static_cast<int32_t>(now - t) >= 0; }
uint32_t earliest(uint32_t a, uint32_t b) { return static_cast<int32_t>(a - b) <= 0 ? a : b; }

constexpr uint32_t kConfigMagic = 0x4A434647;  // "JCFG"
constexpr uint32_t kCalMagic = 0x4A43414C;     // "JCAL"

struct ConfigBlob {
  uint32_t magic;
  DeviceConfig cfg;
};
struct CalibrationBlob {
  uint32_t magic;
  std::array<float, 9> rotation;
  std::array<float, 3> gyro_bias;
  float accel_scale;
};

bool config_valid(const DeviceConfig& c) {
  return c.telemetry_rate_hz >= kMinRateHz && c.telemetry_rate_hz <= kMaxRateHz &&
         c.failsafe_ms >= kMinFailsafeMs && c.failsafe_ms <= kMaxFailsafeMs && c.accel_fs <= 3 &&
         c.gyro_fs <= 3 && c.direction_flags <= 3;
}

int16_t clamp_duty(int16_t d) { return std::clamp<int16_t>(d, protocol::kDutyMin, protocol::kDutyMax); }

}  // namespace

void Firmware::begin() {
  ConfigBlob cb{};
  if (hal_.storage.load("config", &cb, sizeof cb) && cb.magic == kConfigMagic &&
      config_valid(cb.cfg)) {
    cfg_ = cb.cfg;
  }
  CalibrationBlob cal{};
  if (hal_.storage.load("imu_cal", &cal, sizeof cal) && cal.magic == kCalMagic) {
    const Eigen::Matrix3f r = ImuCalibration::from_row_major(cal.rotation);
    const Eigen::Vector3f b(cal.gyro_bias[0], cal.gyro_bias[1], cal.gyro_bias[2]);
    if (ImuCalibration::valid(r, b, cal.accel_scale)) {
      cal_.rotation = r;
      cal_.gyro_bias_rad_s = b;
      cal_.accel_scale = cal.accel_scale;
      calibrated_ = calibration_stored_ = true;
    }
  }
  apply_config();
  const uint32_t now = hal_.clock.micros();
  next_imu_us_ = now;
  ImuRaw first;
  if (imu_.poll(now, first)) averager_.add(first);  // learn presence at boot
  next_imu_us_ = now + imu_period_us();
  if (hal_.motors != nullptr) hal_.motors->brake();
  motor_enable_ = false;
  if (hal_.motor_enable != nullptr) hal_.motor_enable->set(false);
}

void Firmware::apply_config() {
  left_.set_inverted((cfg_.direction_flags & 1u) != 0);
  right_.set_inverted((cfg_.direction_flags & 2u) != 0);
  if (imu_.accel_fs() != cfg_.accel_fs || imu_.gyro_fs() != cfg_.gyro_fs || !imu_.present()) {
    imu_.configure(cfg_.accel_fs, cfg_.gyro_fs);
  }
}

uint32_t Firmware::imu_period_us() const noexcept {
  return std::min(kImuPeriodUs, telemetry_period_us());
}

uint32_t Firmware::next_deadline() const noexcept {
  // failsafe instants count only while still ahead: once passed they schedule nothing
  const uint32_t now = hal_.clock.micros();
  uint32_t t = next_imu_us_;
  if (session_) {
    t = earliest(t, next_telemetry_us_);
    t = earliest(t, next_status_us_);
    // HOST_LOST: the motor failsafe and the interlock line both drop at this instant
    const uint32_t host_lost = last_heartbeat_us_ + 1000u * cfg_.failsafe_ms;
    if (!reached(now, host_lost)) t = earliest(t, host_lost);
  }
  if (motor_commanded_ && !reached(now, cmd_expiry_us_)) t = earliest(t, cmd_expiry_us_);
  return t;
}

void Firmware::tick() {
  const uint32_t now = hal_.clock.micros();
  receive(now);
  if (reached(now, next_imu_us_)) {
    sample_imu(now);
    next_imu_us_ += imu_period_us();
    if (reached(now, next_imu_us_)) next_imu_us_ = now + imu_period_us();  // fell behind
  }
  update_motors(now);
  update_interlock(now);
  if (!session_) return;
  if (reached(now, next_telemetry_us_)) {
    send_telemetry(now);
    next_telemetry_us_ += telemetry_period_us();
    if (reached(now, next_telemetry_us_)) next_telemetry_us_ = now + telemetry_period_us();
  }
  if (reached(now, next_status_us_)) {
    send_status(now);
    next_status_us_ = now + kStatusPeriodUs;
  }
}

void Firmware::receive(uint32_t now) {
  uint8_t buf[64];
  auto sink = [this, now](const proto::Frame& f) { handle(f, now); };
  size_t n;
  while ((n = hal_.serial.read(buf, sizeof buf)) > 0) decoder_.feed(buf, n, now, sink);
  decoder_.poll(now, sink);
}

void Firmware::sample_imu(uint32_t now) {
  ImuRaw s;
  if (imu_.poll(now, s)) averager_.add(s);
  if (imu_.errors() != i2c_errors_seen_) {
    i2c_errors_seen_ = imu_.errors();
    i2c_error_flag_ = true;
  }
}

bool Firmware::host_alive(uint32_t now) const noexcept {
  return session_ && heartbeat_seen_ && !reached(now, last_heartbeat_us_ + 1000u * cfg_.failsafe_ms);
}

void Firmware::update_motors(uint32_t now) {
  if (hal_.motors == nullptr) return;
  const bool command_live = motor_commanded_ && !reached(now, cmd_expiry_us_);
  if (command_live && host_alive(now)) {
    motor_ = MotorState{cmd_left_, cmd_right_, false, false};
    // the direction flag inverts the output with the count, so both agree on "forward"
    const int16_t l = left_.inverted() ? static_cast<int16_t>(-cmd_left_) : cmd_left_;
    const int16_t r = right_.inverted() ? static_cast<int16_t>(-cmd_right_) : cmd_right_;
    hal_.motors->drive(l, r);
    return;
  }
  const bool failsafe = motor_commanded_;  // a command was in force and has lapsed
  if (!motor_.braked || motor_.failsafe != failsafe) {
    hal_.motors->brake();
  }
  motor_ = MotorState{0, 0, true, failsafe};
}

void Firmware::update_interlock(uint32_t now) {
  // the same notion of a live host as the motor failsafe, minus an orderly SHUTDOWN
  const bool enable = host_alive(now) && !host_shutdown_;
  if (enable == motor_enable_) return;
  motor_enable_ = enable;
  if (hal_.motor_enable != nullptr) hal_.motor_enable->set(enable);
}

uint16_t Firmware::telemetry_flags(uint32_t now) const noexcept {
  using namespace proto::telemetry_flags;
  uint16_t f = 0;
  if (imu_.ok()) f |= kImuOk;
  if (calibrated_) f |= kImuCalibrated;
  if (session_ && !host_alive(now)) f |= kHostLost;
  if (motor_.failsafe) f |= kFailsafeActive;
  if (decoder_.counters().crc_errors + rx_bad_commands_ != rx_errors_at_status_) f |= kRxErrors;
  if (i2c_error_flag_) f |= kI2cErrors;
  if (tx_dropped_flag_) f |= kTxDropped;
  if (hal_.motors != nullptr) f |= kMotorOutput;
  if (motor_enable_) f |= kMotorEnable;
  f = static_cast<uint16_t>(f | (cfg_.accel_fs << kAccelFsShift) | (cfg_.gyro_fs << kGyroFsShift));
  return f;
}

void Firmware::send_telemetry(uint32_t now) {
  PcntSample l, r;
  hal_.encoders.read(l, r);
  proto::Telemetry t;
  t.t_us = now;
  t.enc_left = left_.update(l, hal_.encoders.limit());
  t.enc_right = right_.update(r, hal_.encoders.limit());
  ImuRaw s;
  if (averager_.take_mean(s)) {
    if (calibrated_) cal_.apply(cfg_.gyro_fs, s);
    last_imu_ = s;
  }
  t.accel = last_imu_.accel;
  t.temp = last_imu_.temp;
  t.gyro = last_imu_.gyro;
  t.flags = telemetry_flags(now);
  if (left_.take_overflow_flag() | right_.take_overflow_flag()) {
    t.flags = static_cast<uint16_t>(t.flags | proto::telemetry_flags::kPcntOverflow);
  }
  const uint32_t dropped_before = tx_dropped_;
  const uint8_t seq = tx_seq_;
  send(t);
  if (tx_dropped_ == dropped_before) {
    tx_dropped_flag_ = false;
    i2c_error_flag_ = false;
    telemetry_sent_ = true;
    last_telemetry_seq_ = seq;
  }
}

void Firmware::send_status(uint32_t now) {
  const auto& c = decoder_.counters();
  proto::Status s;
  s.t_us = now;
  s.rx_frames_ok = c.frames_ok;
  s.rx_crc_errors = c.crc_errors;
  s.rx_bad_commands = rx_bad_commands_;
  s.tx_dropped = tx_dropped_;
  s.i2c_errors = imu_.errors();
  s.pcnt_overflows = left_.overflows() + right_.overflows();
  s.telemetry_rate_hz = cfg_.telemetry_rate_hz;
  s.flags = telemetry_flags(now);
  send(s);
  rx_errors_at_status_ = c.crc_errors + rx_bad_commands_;
}

void Firmware::send_info() {
  proto::Info info;
  info.protocol_version = proto::kProtocolVersion;
  info.schema_hash = proto::kSchemaHash;
  info.firmware_version = kFirmwareVersion;
  info.telemetry_rate_hz = cfg_.telemetry_rate_hz;
  info.failsafe_ms = cfg_.failsafe_ms;
  info.accel_fs = cfg_.accel_fs;
  info.gyro_fs = cfg_.gyro_fs;
  info.direction_flags = cfg_.direction_flags;
  uint8_t caps = 0;
  if (imu_.present()) caps |= proto::capabilities::kImuPresent;
  if (hal_.motors != nullptr) caps |= proto::capabilities::kMotorOutput;
  if (calibration_stored_) caps |= proto::capabilities::kCalibrationStored;
  info.capabilities = caps;
  info.imu_rotation = cal_.rotation_row_major();
  info.gyro_bias = {cal_.gyro_bias_rad_s[0], cal_.gyro_bias_rad_s[1], cal_.gyro_bias_rad_s[2]};
  info.accel_scale = cal_.accel_scale;
  info.boot_id = hal_.boot_id;
  send(info);
}

template <class Msg>
void Firmware::send(const Msg& m) {
  uint8_t buf[proto::kMaxFrame];
  const size_t n = proto::encode_frame(m, tx_seq_, buf, sizeof buf);
  ++tx_seq_;  // a dropped frame still consumes its SEQ: the host sees the gap
  if (hal_.serial.write_all_or_nothing(buf, n)) {
    ++frames_sent_;
  } else {
    ++tx_dropped_;
    tx_dropped_flag_ = true;
  }
}

void Firmware::ack(const proto::Frame& f) {
  proto::Ack a;
  a.acked_type = f.type;
  a.acked_seq = f.seq;
  a.acked_crc = f.crc;
  send(a);
}

void Firmware::nack(const proto::Frame& f, proto::NackError e) {
  ++rx_bad_commands_;
  proto::Nack n;
  n.acked_type = f.type;
  n.acked_seq = f.seq;
  n.error = static_cast<uint8_t>(e);
  n.acked_crc = f.crc;
  send(n);
}

bool Firmware::save_config() {
  const ConfigBlob cb{kConfigMagic, cfg_};
  return hal_.storage.save("config", &cb, sizeof cb);
}

bool Firmware::save_calibration() {
  CalibrationBlob cb{};
  cb.magic = kCalMagic;
  cb.rotation = cal_.rotation_row_major();
  cb.gyro_bias = {cal_.gyro_bias_rad_s[0], cal_.gyro_bias_rad_s[1], cal_.gyro_bias_rad_s[2]};
  cb.accel_scale = cal_.accel_scale;
  return hal_.storage.save("imu_cal", &cb, sizeof cb);
}

void Firmware::handle(const proto::Frame& f, uint32_t now) {
  using proto::NackError;
  if (!proto::is_known_type(f.type) || f.type < 0x80) {
    nack(f, NackError::kUnknownType);
    return;
  }
  if (f.type == proto::Heartbeat::kType) {  // not acknowledged (20 Hz)
    proto::Heartbeat hb;
    f.as(hb);
    if (f.len < proto::Heartbeat::kSize || !session_) return;
    heartbeat_seen_ = true;
    ++heartbeats_;
    heartbeat_ack_ = hb.ack_seq;
    last_heartbeat_us_ = now;
    host_shutdown_ = hb.host_state == static_cast<uint8_t>(proto::HostState::kShutdown);
    if (host_shutdown_) {
      motor_commanded_ = false;  // an orderly goodbye: brake without flagging a failsafe
      if (hal_.motors != nullptr) hal_.motors->brake();
      motor_ = MotorState{};
    }
    return;
  }
  if (f.type == proto::Hello::kType && f.len < proto::Hello::kSize) {
    // an older host's HELLO (no session id): its protocol is not ours; INFO lets it say so
    send_info();
    nack(f, NackError::kVersionMismatch);
    session_ = false;
    return;
  }
  // Every other command: the payload must hold all fields, else nothing changes.
  size_t need = 0;
  proto::visit_message(f.type, f.payload, f.len,
                       [&need](const auto& m) { need = std::decay_t<decltype(m)>::kSize; });
  if (f.len < need) {
    nack(f, NackError::kBadLength);
    return;
  }
  switch (f.type) {
    case proto::Hello::kType: {
      proto::Hello h;
      f.as(h);
      if (h.protocol_version != proto::kProtocolVersion || h.schema_hash != proto::kSchemaHash) {
        send_info();  // lets the host name both versions
        nack(f, NackError::kVersionMismatch);
        session_ = false;
        return;
      }
      if (session_ && h.session != 0 && h.session == session_id_) {
        // the same host's HELLO again (it heard nothing for a while): the session goes on as it
        // was, its interlock, telemetry schedule and IMU averaging untouched
        send_info();
        ack(f);
        return;
      }
      session_ = true;
      session_id_ = h.session;
      ++sessions_;
      averager_ = ImuAverager{};  // the first frame averages only samples of this session
      heartbeat_seen_ = false;  // the interlock drops until this session's first HEARTBEAT
      host_shutdown_ = false;
      telemetry_sent_ = false;
      last_heartbeat_us_ = now;
      next_telemetry_us_ = now + telemetry_period_us();
      next_status_us_ = now + kStatusPeriodUs;
      send_info();
      ack(f);
      return;
    }
    case proto::SetRate::kType: {
      proto::SetRate m;
      f.as(m);
      if (m.rate_hz < kMinRateHz || m.rate_hz > kMaxRateHz) {
        nack(f, NackError::kBadValue);
        return;
      }
      cfg_.telemetry_rate_hz = m.rate_hz;
      next_telemetry_us_ = now + telemetry_period_us();
      ack(f);
      return;
    }
    case proto::ZeroCounters::kType: {
      proto::ZeroCounters m;
      f.as(m);
      if (m.mask == 0 || m.mask > 3) {
        nack(f, NackError::kBadValue);
        return;
      }
      PcntSample l, r;
      hal_.encoders.read(l, r);
      left_.update(l, hal_.encoders.limit());
      right_.update(r, hal_.encoders.limit());
      if (m.mask & 1u) left_.zero();
      if (m.mask & 2u) right_.zero();
      ack(f);
      return;
    }
    case proto::SetImuCalibration::kType: {
      proto::SetImuCalibration m;
      f.as(m);
      const Eigen::Matrix3f r = ImuCalibration::from_row_major(m.imu_rotation);
      const Eigen::Vector3f b(m.gyro_bias[0], m.gyro_bias[1], m.gyro_bias[2]);
      if (!ImuCalibration::valid(r, b, m.accel_scale) || m.persist > 1) {
        nack(f, NackError::kBadValue);
        return;
      }
      const ImuCalibration previous = cal_;
      const bool same = calibrated_ && r == cal_.rotation && b == cal_.gyro_bias_rad_s &&
                        m.accel_scale == cal_.accel_scale;
      cal_.rotation = r;
      cal_.gyro_bias_rad_s = b;
      cal_.accel_scale = m.accel_scale;
      if (m.persist == 1) {
        if (!save_calibration()) {
          cal_ = previous;
          nack(f, NackError::kStorage);
          return;
        }
        calibration_stored_ = true;
      }
      calibrated_ = true;
      if (!same) averager_ = ImuAverager{};  // never mix two calibrations' samples in one mean
      ack(f);
      return;
    }
    case proto::RequestInfo::kType:
      send_info();
      send_status(now);
      ack(f);
      return;
    case proto::MotorPwm::kType: {
      if (hal_.motors == nullptr) {
        nack(f, NackError::kNotSupported);
        return;
      }
      proto::MotorPwm m;
      f.as(m);
      cmd_left_ = clamp_duty(m.left);
      cmd_right_ = clamp_duty(m.right);
      motor_commanded_ = true;
      cmd_expiry_us_ = now + 1000u * (m.timeout_ms != 0 ? m.timeout_ms : cfg_.failsafe_ms);
      ack(f);
      update_motors(now);
      return;
    }
    case proto::SetConfig::kType: {
      proto::SetConfig m;
      f.as(m);
      DeviceConfig c = cfg_;
      c.accel_fs = m.accel_fs;
      c.gyro_fs = m.gyro_fs;
      c.direction_flags = m.direction_flags;
      c.failsafe_ms = m.failsafe_ms;
      if (!config_valid(c) || m.persist > 1) {
        nack(f, NackError::kBadValue);
        return;
      }
      const DeviceConfig previous = cfg_;
      cfg_ = c;
      if (m.persist == 1 && !save_config()) {
        cfg_ = previous;
        nack(f, NackError::kStorage);
        return;
      }
      apply_config();
      averager_ = ImuAverager{};  // samples of the old range must not enter the next mean
      ack(f);
      return;
    }
    default:
      nack(f, NackError::kUnknownType);
      return;
  }
}

}  // namespace jackson::fw
