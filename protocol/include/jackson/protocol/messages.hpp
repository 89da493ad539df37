// Message structs generated from protocol/schema.yaml (schema 0xd0cfa9fd).
// Do not edit: change the schema and run `python -m jackson.protocol.codegen`.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "jackson/protocol/wire.hpp"

namespace jackson::protocol {

constexpr uint8_t kProtocolVersion = 1;
constexpr uint32_t kSchemaHash = 0xd0cfa9fdu;
constexpr size_t kMaxPayload = 120;
constexpr uint32_t kPartialTimeoutUs = 20000;

enum class NackError : uint8_t {
  kBadLength = 1,
  kBadValue = 2,
  kUnknownType = 3,
  kVersionMismatch = 4,
  kNotSupported = 5,
  kStorage = 6,
};

enum class LogLevel : uint8_t {
  kDebug = 0,
  kInfo = 1,
  kWarn = 2,
  kError = 3,
};

enum class HostState : uint8_t {
  kIdle = 0,
  kActive = 1,
  kShutdown = 2,
};

namespace telemetry_flags {
constexpr uint16_t kImuOk = 1u << 0;
constexpr uint16_t kImuCalibrated = 1u << 1;
constexpr uint16_t kHostLost = 1u << 2;
constexpr uint16_t kFailsafeActive = 1u << 3;
constexpr uint16_t kPcntOverflow = 1u << 4;
constexpr uint16_t kRxErrors = 1u << 5;
constexpr uint16_t kI2cErrors = 1u << 6;
constexpr uint16_t kTxDropped = 1u << 7;
constexpr uint16_t kMotorOutput = 1u << 12;
constexpr uint16_t kMotorEnable = 1u << 13;
constexpr unsigned kAccelFsShift = 8;
/// ACCEL_FS: bits 8-9.
constexpr uint8_t accel_fs(uint16_t flags) noexcept {
  return static_cast<uint8_t>((flags >> 8) & 0x3u);
}
constexpr unsigned kGyroFsShift = 10;
/// GYRO_FS: bits 10-11.
constexpr uint8_t gyro_fs(uint16_t flags) noexcept {
  return static_cast<uint8_t>((flags >> 10) & 0x3u);
}
}  // namespace telemetry_flags

namespace capabilities {
constexpr uint16_t kImuPresent = 1u << 0;
constexpr uint16_t kMotorOutput = 1u << 1;
constexpr uint16_t kCalibrationStored = 1u << 2;
}  // namespace capabilities

constexpr std::array<float, 4> kAccelLsbPerG = {16384.0f, 8192.0f, 4096.0f, 2048.0f};
constexpr std::array<float, 4> kGyroLsbPerDps = {131.0f, 65.5f, 32.8f, 16.4f};
constexpr float kGravityMS2 = 9.81f;
constexpr float kTempLsbPerC = 340.0f;
constexpr float kTempOffsetC = 36.53f;
constexpr int32_t kTelemetryRateHzMin = 1;
constexpr int32_t kTelemetryRateHzMax = 500;
constexpr int32_t kFailsafeMsMin = 50;
constexpr int32_t kFailsafeMsMax = 10000;
constexpr int32_t kDutyMin = -10000;
constexpr int32_t kDutyMax = 10000;
constexpr float kGyroBiasRadSMin = -0.5f;
constexpr float kGyroBiasRadSMax = 0.5f;
constexpr float kAccelScaleMin = 0.5f;
constexpr float kAccelScaleMax = 2.0f;
constexpr int32_t kTelemetryRateHzDefault = 20;
constexpr int32_t kFailsafeMsDefault = 200;

/// Sensor snapshot, sent at the telemetry rate (20 Hz by default) once the host has sent HELLO. Encoder counts are cumulative since boot or the last ZERO_COUNTERS, so a lost frame loses no distance.
struct Telemetry {
  static constexpr uint8_t kType = 0x01;
  static constexpr const char* kName = "telemetry";
  static constexpr size_t kSize = 28;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 28;
  uint32_t t_us = 0;
  int32_t enc_left = 0;
  int32_t enc_right = 0;
  uint16_t flags = 0;
  std::array<int16_t, 3> accel{};
  int16_t temp = 0;
  std::array<int16_t, 3> gyro{};

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, t_us);
    o += wire::put(out + o, enc_left);
    o += wire::put(out + o, enc_right);
    o += wire::put(out + o, flags);
    o += wire::put(out + o, accel);
    o += wire::put(out + o, temp);
    o += wire::put(out + o, gyro);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, t_us);
    o += wire::get(buf + o, enc_left);
    o += wire::get(buf + o, enc_right);
    o += wire::get(buf + o, flags);
    o += wire::get(buf + o, accel);
    o += wire::get(buf + o, temp);
    o += wire::get(buf + o, gyro);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("t_us", t_us);
    f("enc_left", enc_left);
    f("enc_right", enc_right);
    f("flags", flags);
    f("accel", accel);
    f("temp", temp);
    f("gyro", gyro);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("t_us", t_us);
    f("enc_left", enc_left);
    f("enc_right", enc_right);
    f("flags", flags);
    f("accel", accel);
    f("temp", temp);
    f("gyro", gyro);
    (void)f;
  }
};

/// Link and health counters, sent at 1 Hz and after REQUEST_INFO. All counters are cumulative since boot.
struct Status {
  static constexpr uint8_t kType = 0x02;
  static constexpr const char* kName = "status";
  static constexpr size_t kSize = 32;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 32;
  uint32_t t_us = 0;
  uint32_t rx_frames_ok = 0;
  uint32_t rx_crc_errors = 0;
  uint32_t rx_bad_commands = 0;
  uint32_t tx_dropped = 0;
  uint32_t i2c_errors = 0;
  uint32_t pcnt_overflows = 0;
  uint16_t telemetry_rate_hz = 0;
  uint16_t flags = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, t_us);
    o += wire::put(out + o, rx_frames_ok);
    o += wire::put(out + o, rx_crc_errors);
    o += wire::put(out + o, rx_bad_commands);
    o += wire::put(out + o, tx_dropped);
    o += wire::put(out + o, i2c_errors);
    o += wire::put(out + o, pcnt_overflows);
    o += wire::put(out + o, telemetry_rate_hz);
    o += wire::put(out + o, flags);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, t_us);
    o += wire::get(buf + o, rx_frames_ok);
    o += wire::get(buf + o, rx_crc_errors);
    o += wire::get(buf + o, rx_bad_commands);
    o += wire::get(buf + o, tx_dropped);
    o += wire::get(buf + o, i2c_errors);
    o += wire::get(buf + o, pcnt_overflows);
    o += wire::get(buf + o, telemetry_rate_hz);
    o += wire::get(buf + o, flags);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("t_us", t_us);
    f("rx_frames_ok", rx_frames_ok);
    f("rx_crc_errors", rx_crc_errors);
    f("rx_bad_commands", rx_bad_commands);
    f("tx_dropped", tx_dropped);
    f("i2c_errors", i2c_errors);
    f("pcnt_overflows", pcnt_overflows);
    f("telemetry_rate_hz", telemetry_rate_hz);
    f("flags", flags);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("t_us", t_us);
    f("rx_frames_ok", rx_frames_ok);
    f("rx_crc_errors", rx_crc_errors);
    f("rx_bad_commands", rx_bad_commands);
    f("tx_dropped", tx_dropped);
    f("i2c_errors", i2c_errors);
    f("pcnt_overflows", pcnt_overflows);
    f("telemetry_rate_hz", telemetry_rate_hz);
    f("flags", flags);
    (void)f;
  }
};

/// Identity and configuration, the answer to HELLO and REQUEST_INFO. The host refuses a device whose protocol_version or schema_hash differs from its own.
struct Info {
  static constexpr uint8_t kType = 0x03;
  static constexpr const char* kName = "info";
  static constexpr size_t kSize = 72;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 72;
  uint8_t protocol_version = 0;
  uint32_t schema_hash = 0;
  std::array<uint8_t, 3> firmware_version{};
  uint16_t telemetry_rate_hz = 0;
  uint16_t failsafe_ms = 0;
  uint8_t accel_fs = 0;
  uint8_t gyro_fs = 0;
  uint8_t direction_flags = 0;
  uint8_t capabilities = 0;
  std::array<float, 9> imu_rotation{};
  std::array<float, 3> gyro_bias{};
  float accel_scale = 0;
  uint32_t boot_id = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, protocol_version);
    o += wire::put(out + o, schema_hash);
    o += wire::put(out + o, firmware_version);
    o += wire::put(out + o, telemetry_rate_hz);
    o += wire::put(out + o, failsafe_ms);
    o += wire::put(out + o, accel_fs);
    o += wire::put(out + o, gyro_fs);
    o += wire::put(out + o, direction_flags);
    o += wire::put(out + o, capabilities);
    o += wire::put(out + o, imu_rotation);
    o += wire::put(out + o, gyro_bias);
    o += wire::put(out + o, accel_scale);
    o += wire::put(out + o, boot_id);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, protocol_version);
    o += wire::get(buf + o, schema_hash);
    o += wire::get(buf + o, firmware_version);
    o += wire::get(buf + o, telemetry_rate_hz);
    o += wire::get(buf + o, failsafe_ms);
    o += wire::get(buf + o, accel_fs);
    o += wire::get(buf + o, gyro_fs);
    o += wire::get(buf + o, direction_flags);
    o += wire::get(buf + o, capabilities);
    o += wire::get(buf + o, imu_rotation);
    o += wire::get(buf + o, gyro_bias);
    o += wire::get(buf + o, accel_scale);
    o += wire::get(buf + o, boot_id);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("protocol_version", protocol_version);
    f("schema_hash", schema_hash);
    f("firmware_version", firmware_version);
    f("telemetry_rate_hz", telemetry_rate_hz);
    f("failsafe_ms", failsafe_ms);
    f("accel_fs", accel_fs);
    f("gyro_fs", gyro_fs);
    f("direction_flags", direction_flags);
    f("capabilities", capabilities);
    f("imu_rotation", imu_rotation);
    f("gyro_bias", gyro_bias);
    f("accel_scale", accel_scale);
    f("boot_id", boot_id);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("protocol_version", protocol_version);
    f("schema_hash", schema_hash);
    f("firmware_version", firmware_version);
    f("telemetry_rate_hz", telemetry_rate_hz);
    f("failsafe_ms", failsafe_ms);
    f("accel_fs", accel_fs);
    f("gyro_fs", gyro_fs);
    f("direction_flags", direction_flags);
    f("capabilities", capabilities);
    f("imu_rotation", imu_rotation);
    f("gyro_bias", gyro_bias);
    f("accel_scale", accel_scale);
    f("boot_id", boot_id);
    (void)f;
  }
};

/// A host command was carried out.
struct Ack {
  static constexpr uint8_t kType = 0x04;
  static constexpr const char* kName = "ack";
  static constexpr size_t kSize = 6;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 6;
  uint8_t acked_type = 0;
  uint8_t acked_seq = 0;
  uint32_t acked_crc = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, acked_type);
    o += wire::put(out + o, acked_seq);
    o += wire::put(out + o, acked_crc);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, acked_type);
    o += wire::get(buf + o, acked_seq);
    o += wire::get(buf + o, acked_crc);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("acked_type", acked_type);
    f("acked_seq", acked_seq);
    f("acked_crc", acked_crc);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("acked_type", acked_type);
    f("acked_seq", acked_seq);
    f("acked_crc", acked_crc);
    (void)f;
  }
};

/// A host command was refused; nothing changed on the device.
struct Nack {
  static constexpr uint8_t kType = 0x05;
  static constexpr const char* kName = "nack";
  static constexpr size_t kSize = 7;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 7;
  uint8_t acked_type = 0;
  uint8_t acked_seq = 0;
  uint8_t error = 0;
  uint32_t acked_crc = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, acked_type);
    o += wire::put(out + o, acked_seq);
    o += wire::put(out + o, error);
    o += wire::put(out + o, acked_crc);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, acked_type);
    o += wire::get(buf + o, acked_seq);
    o += wire::get(buf + o, error);
    o += wire::get(buf + o, acked_crc);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("acked_type", acked_type);
    f("acked_seq", acked_seq);
    f("error", error);
    f("acked_crc", acked_crc);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("acked_type", acked_type);
    f("acked_seq", acked_seq);
    f("error", error);
    f("acked_crc", acked_crc);
    (void)f;
  }
};

/// Human-readable text from the device.
struct Log {
  static constexpr uint8_t kType = 0x06;
  static constexpr const char* kName = "log";
  static constexpr size_t kSize = 1;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 101;
  uint8_t level = 0;
  Text<100> text{};

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, level);
    o += wire::put(out + o, text);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, level);
    text.assign(n > kSize ? in + kSize : in, n > kSize ? n - kSize : 0);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("level", level);
    f("text", text);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("level", level);
    f("text", text);
    (void)f;
  }
};

/// First message of a session. The device answers INFO and ACK (NACK VERSION_MISMATCH when version or hash differ) and starts telemetry. A HELLO carrying the session in progress resumes it: answered the same way, nothing restarts (the host's HELLO after a silence on a link it still holds).
struct Hello {
  static constexpr uint8_t kType = 0x80;
  static constexpr const char* kName = "hello";
  static constexpr size_t kSize = 9;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 9;
  uint8_t protocol_version = 0;
  uint32_t schema_hash = 0;
  uint32_t session = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, protocol_version);
    o += wire::put(out + o, schema_hash);
    o += wire::put(out + o, session);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, protocol_version);
    o += wire::get(buf + o, schema_hash);
    o += wire::get(buf + o, session);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("protocol_version", protocol_version);
    f("schema_hash", schema_hash);
    f("session", session);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("protocol_version", protocol_version);
    f("schema_hash", schema_hash);
    f("session", session);
    (void)f;
  }
};

/// Sent by the host after it has processed each telemetry frame (20 Hz). Keeps the device's failsafe from firing; not acknowledged. The twin's lockstep clock advances when it sees ack_seq of the frame it last sent.
struct Heartbeat {
  static constexpr uint8_t kType = 0x81;
  static constexpr const char* kName = "heartbeat";
  static constexpr size_t kSize = 2;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 2;
  uint8_t ack_seq = 0;
  uint8_t host_state = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, ack_seq);
    o += wire::put(out + o, host_state);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, ack_seq);
    o += wire::get(buf + o, host_state);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("ack_seq", ack_seq);
    f("host_state", host_state);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("ack_seq", ack_seq);
    f("host_state", host_state);
    (void)f;
  }
};

/// Telemetry rate. NACK BAD_VALUE outside 1-500 Hz.
struct SetRate {
  static constexpr uint8_t kType = 0x82;
  static constexpr const char* kName = "set_rate";
  static constexpr size_t kSize = 2;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 2;
  uint16_t rate_hz = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, rate_hz);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, rate_hz);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("rate_hz", rate_hz);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("rate_hz", rate_hz);
    (void)f;
  }
};

/// Sets the software offset so the selected cumulative counts read 0.
struct ZeroCounters {
  static constexpr uint8_t kType = 0x83;
  static constexpr const char* kName = "zero_counters";
  static constexpr size_t kSize = 1;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 1;
  uint8_t mask = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, mask);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, mask);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("mask", mask);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("mask", mask);
    (void)f;
  }
};

/// IMU calibration applied on the device: omega_base = R omega_sensor - gyro_bias, a_base = accel_scale R a_sensor. persist = 1 also stores it in NVS.
struct SetImuCalibration {
  static constexpr uint8_t kType = 0x84;
  static constexpr const char* kName = "set_imu_calibration";
  static constexpr size_t kSize = 53;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 53;
  std::array<float, 9> imu_rotation{};
  std::array<float, 3> gyro_bias{};
  float accel_scale = 0;
  uint8_t persist = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, imu_rotation);
    o += wire::put(out + o, gyro_bias);
    o += wire::put(out + o, accel_scale);
    o += wire::put(out + o, persist);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, imu_rotation);
    o += wire::get(buf + o, gyro_bias);
    o += wire::get(buf + o, accel_scale);
    o += wire::get(buf + o, persist);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("imu_rotation", imu_rotation);
    f("gyro_bias", gyro_bias);
    f("accel_scale", accel_scale);
    f("persist", persist);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("imu_rotation", imu_rotation);
    f("gyro_bias", gyro_bias);
    f("accel_scale", accel_scale);
    f("persist", persist);
    (void)f;
  }
};

/// Asks for INFO and STATUS.
struct RequestInfo {
  static constexpr uint8_t kType = 0x85;
  static constexpr const char* kName = "request_info";
  static constexpr size_t kSize = 0;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    (void)f;
  }
};

/// Signed duty per wheel for firmware that drives the motors (1e-4 units, clamped to +-10000). Expires after timeout_ms (0: the failsafe time), then the device brakes.
struct MotorPwm {
  static constexpr uint8_t kType = 0x86;
  static constexpr const char* kName = "motor_pwm";
  static constexpr size_t kSize = 6;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 6;
  int16_t left = 0;
  int16_t right = 0;
  uint16_t timeout_ms = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, left);
    o += wire::put(out + o, right);
    o += wire::put(out + o, timeout_ms);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, left);
    o += wire::get(buf + o, right);
    o += wire::get(buf + o, timeout_ms);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("left", left);
    f("right", right);
    f("timeout_ms", timeout_ms);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("left", left);
    f("right", right);
    f("timeout_ms", timeout_ms);
    (void)f;
  }
};

/// Device configuration. persist = 1 also stores it in NVS.
struct SetConfig {
  static constexpr uint8_t kType = 0x87;
  static constexpr const char* kName = "set_config";
  static constexpr size_t kSize = 6;  ///< fixed part, bytes
  static constexpr size_t kMaxSize = 6;
  uint8_t accel_fs = 0;
  uint8_t gyro_fs = 0;
  uint8_t direction_flags = 0;
  uint16_t failsafe_ms = 0;
  uint8_t persist = 0;

  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.
  size_t encode(uint8_t* out) const noexcept {
    size_t o = 0;
    o += wire::put(out + o, accel_fs);
    o += wire::put(out + o, gyro_fs);
    o += wire::put(out + o, direction_flags);
    o += wire::put(out + o, failsafe_ms);
    o += wire::put(out + o, persist);
    (void)out;
    return o;
  }

  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.
  void decode(const uint8_t* in, size_t n) noexcept {
    uint8_t buf[kSize + 1] = {};
    std::memcpy(buf, in, n < kSize ? n : kSize);
    size_t o = 0;
    o += wire::get(buf + o, accel_fs);
    o += wire::get(buf + o, gyro_fs);
    o += wire::get(buf + o, direction_flags);
    o += wire::get(buf + o, failsafe_ms);
    o += wire::get(buf + o, persist);
    (void)buf;
    (void)o;
  }

  template <class F>
  void for_each_field(F&& f) {
    f("accel_fs", accel_fs);
    f("gyro_fs", gyro_fs);
    f("direction_flags", direction_flags);
    f("failsafe_ms", failsafe_ms);
    f("persist", persist);
    (void)f;
  }
  template <class F>
  void for_each_field(F&& f) const {
    f("accel_fs", accel_fs);
    f("gyro_fs", gyro_fs);
    f("direction_flags", direction_flags);
    f("failsafe_ms", failsafe_ms);
    f("persist", persist);
    (void)f;
  }
};

/// True for every TYPE id the schema defines.
constexpr bool is_known_type(uint8_t type) noexcept {
  switch (type) {
    case Telemetry::kType:
    case Status::kType:
    case Info::kType:
    case Ack::kType:
    case Nack::kType:
    case Log::kType:
    case Hello::kType:
    case Heartbeat::kType:
    case SetRate::kType:
    case ZeroCounters::kType:
    case SetImuCalibration::kType:
    case RequestInfo::kType:
    case MotorPwm::kType:
    case SetConfig::kType:
      return true;
    default:
      return false;
  }
}

/// Schema name of a TYPE id, or nullptr.
constexpr const char* message_name(uint8_t type) noexcept {
  switch (type) {
    case Telemetry::kType: return Telemetry::kName;
    case Status::kType: return Status::kName;
    case Info::kType: return Info::kName;
    case Ack::kType: return Ack::kName;
    case Nack::kType: return Nack::kName;
    case Log::kType: return Log::kName;
    case Hello::kType: return Hello::kName;
    case Heartbeat::kType: return Heartbeat::kName;
    case SetRate::kType: return SetRate::kName;
    case ZeroCounters::kType: return ZeroCounters::kName;
    case SetImuCalibration::kType: return SetImuCalibration::kName;
    case RequestInfo::kType: return RequestInfo::kName;
    case MotorPwm::kType: return MotorPwm::kName;
    case SetConfig::kType: return SetConfig::kName;
    default: return nullptr;
  }
}

/// Decodes a payload of TYPE `type` into its struct and calls `v(msg)`.
/// Returns false (and calls nothing) for an unknown type.
template <class V>
bool visit_message(uint8_t type, const uint8_t* payload, size_t n, V&& v) {
  switch (type) {
    case Telemetry::kType: {
      Telemetry msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case Status::kType: {
      Status msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case Info::kType: {
      Info msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case Ack::kType: {
      Ack msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case Nack::kType: {
      Nack msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case Log::kType: {
      Log msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case Hello::kType: {
      Hello msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case Heartbeat::kType: {
      Heartbeat msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case SetRate::kType: {
      SetRate msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case ZeroCounters::kType: {
      ZeroCounters msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case SetImuCalibration::kType: {
      SetImuCalibration msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case RequestInfo::kType: {
      RequestInfo msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case MotorPwm::kType: {
      MotorPwm msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    case SetConfig::kType: {
      SetConfig msg;
      msg.decode(payload, n);
      v(msg);
      return true;
    }
    default:
      return false;
  }
}

}  // namespace jackson::protocol
