// The firmware core: everything the ESP32-S3 does, independent of the board.
#pragma once

#include <array>
#include <cstdint>

#include "encoder.hpp"
#include "hal.hpp"
#include "imu_calibration.hpp"
#include "jackson/protocol/frame.hpp"
#include "mpu6050.hpp"

namespace jackson::fw {

constexpr std::array<uint8_t, 3> kFirmwareVersion = {0, 1, 0};

/// Device configuration, changed by SET_CONFIG and SET_RATE, persisted on request.
struct DeviceConfig {
  uint16_t telemetry_rate_hz = protocol::kTelemetryRateHzDefault;  ///< protocol/schema.yaml
  uint16_t failsafe_ms = protocol::kFailsafeMsDefault;
  uint8_t accel_fs = 0;         ///< +-2 g
  uint8_t gyro_fs = 0;          ///< +-250 deg/s
  uint8_t direction_flags = 0;  ///< bit 0 inverts left, bit 1 inverts right
};

constexpr uint16_t kMinRateHz = protocol::kTelemetryRateHzMin;  ///< limits: protocol/schema.yaml
constexpr uint16_t kMaxRateHz = protocol::kTelemetryRateHzMax;
constexpr uint16_t kMinFailsafeMs = protocol::kFailsafeMsMin;
constexpr uint16_t kMaxFailsafeMs = protocol::kFailsafeMsMax;
constexpr uint32_t kImuPeriodUs = 10'000;    ///< 100 Hz IMU sampling (faster if telemetry is)
constexpr uint32_t kStatusPeriodUs = 1'000'000;

/// What the motor output is doing, for telemetry and for the POSIX feed.
struct MotorState {
  int16_t left = 0;   ///< duty applied, 1e-4 units (0 when braked)
  int16_t right = 0;
  bool braked = true;
  bool failsafe = false;  ///< braked because commands or heartbeats stopped
};

/// Owns the protocol decoder, the sensors' state, the telemetry scheduler, the command handler
/// and the motor failsafe. Call begin() once, then tick() as often as possible (the ESP32 loop
/// runs it every millisecond; the POSIX build at every deadline of next_deadline()).
class Firmware {
 public:
  explicit Firmware(Hal& hal) : hal_(hal), imu_(hal.i2c) {}

  /// Loads configuration and calibration from storage and sets up the IMU.
  void begin();
  /// Receives, samples, schedules and sends whatever is due at the HAL clock's time.
  void tick();
  /// The next time tick() has something scheduled (telemetry, IMU sample, status, failsafe).
  uint32_t next_deadline() const noexcept;

  bool session_active() const noexcept { return session_; }
  const MotorState& motors() const noexcept { return motor_; }
  const DeviceConfig& config() const noexcept { return cfg_; }
  const protocol::DecoderCounters& rx_counters() const noexcept { return decoder_.counters(); }
  uint32_t rx_bad_commands() const noexcept { return rx_bad_commands_; }
  uint32_t tx_dropped() const noexcept { return tx_dropped_; }
  uint32_t frames_sent() const noexcept { return frames_sent_; }
  /// SEQ of the last telemetry frame sent, and whether one was sent at all.
  bool last_telemetry_seq(uint8_t& seq) const noexcept {
    seq = last_telemetry_seq_;
    return telemetry_sent_;
  }
  /// ack_seq of the newest HEARTBEAT, and whether one arrived in this session.
  bool last_heartbeat_ack(uint8_t& seq) const noexcept {
    seq = heartbeat_ack_;
    return heartbeat_seen_;
  }
  bool calibrated() const noexcept { return calibrated_; }
  /// The interlock line as last set through Hal::motor_enable: asserted exactly while a
  /// session's HEARTBEATs arrive within failsafe_ms and the newest is not SHUTDOWN.
  bool motor_enable() const noexcept { return motor_enable_; }
  /// When the next telemetry frame is due (meaningful during a session).
  uint32_t next_telemetry_us() const noexcept { return next_telemetry_us_; }
  /// When the newest HEARTBEAT (or the HELLO) arrived, and the instant the host counts as lost
  /// without another: failsafe_ms later (the motor failsafe and the interlock line drop then).
  uint32_t last_heartbeat_us() const noexcept { return last_heartbeat_us_; }
  uint32_t host_lost_us() const noexcept { return last_heartbeat_us_ + 1000u * cfg_.failsafe_ms; }
  /// HEARTBEATs taken in sessions since boot (a simulator tells a host that came back by it).
  uint32_t heartbeats() const noexcept { return heartbeats_; }
  /// Sessions a HELLO began since boot (a new session id, or the first HELLO after none): a
  /// simulator tells by it that a host is there before its first HEARTBEAT.
  uint32_t sessions() const noexcept { return sessions_; }
  /// The flags a TELEMETRY or STATUS frame sent at `now` carries (PCNT_OVERFLOW aside).
  uint16_t telemetry_flags(uint32_t now) const noexcept;
  const Mpu6050& imu() const noexcept { return imu_; }

 private:
  void receive(uint32_t now);
  void handle(const protocol::Frame& f, uint32_t now);
  void sample_imu(uint32_t now);
  void update_motors(uint32_t now);
  void update_interlock(uint32_t now);
  /// A session's HEARTBEATs arrive within failsafe_ms (the motor failsafe and interlock rule).
  bool host_alive(uint32_t now) const noexcept;
  void send_telemetry(uint32_t now);
  void send_status(uint32_t now);
  void send_info();
  void ack(const protocol::Frame& f);
  void nack(const protocol::Frame& f, protocol::NackError e);
  template <class Msg>
  void send(const Msg& m);
  void apply_config();
  bool save_config();
  bool save_calibration();
  uint32_t telemetry_period_us() const noexcept { return 1'000'000u / cfg_.telemetry_rate_hz; }
  uint32_t imu_period_us() const noexcept;

  Hal& hal_;
  Mpu6050 imu_;
  ImuAverager averager_;
  ImuRaw last_imu_{};
  ImuCalibration cal_;
  bool calibrated_ = false;
  bool calibration_stored_ = false;
  DeviceConfig cfg_;
  EncoderAccumulator left_, right_;
  protocol::FrameDecoder decoder_{true};

  bool session_ = false;
  uint32_t session_id_ = 0;  ///< the HELLO's session id of the session in progress (0: none given)
  uint8_t tx_seq_ = 0;
  uint32_t frames_sent_ = 0;
  uint32_t tx_dropped_ = 0;
  uint32_t rx_bad_commands_ = 0;
  bool tx_dropped_flag_ = false;
  bool i2c_error_flag_ = false;
  uint32_t i2c_errors_seen_ = 0;
  uint32_t rx_errors_at_status_ = 0;
  bool telemetry_sent_ = false;
  uint8_t last_telemetry_seq_ = 0;
  bool heartbeat_seen_ = false;
  uint8_t heartbeat_ack_ = 0;
  uint32_t heartbeats_ = 0;
  uint32_t sessions_ = 0;
  uint32_t last_heartbeat_us_ = 0;
  bool host_shutdown_ = false;  ///< the newest HEARTBEAT said SHUTDOWN
  bool motor_enable_ = false;

  uint32_t next_telemetry_us_ = 0;
  uint32_t next_imu_us_ = 0;
  uint32_t next_status_us_ = 0;

  bool motor_commanded_ = false;
  int16_t cmd_left_ = 0;
  int16_t cmd_right_ = 0;
  uint32_t cmd_expiry_us_ = 0;
  MotorState motor_;
};

}  // namespace jackson::fw
