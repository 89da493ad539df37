// MPU-6050 driver over the I2C HAL: bounded, never blocking the encoder path.
#pragma once

#include <array>
#include <cstdint>

#include "hal.hpp"
#include "jackson/protocol/messages.hpp"

namespace jackson::fw {

/// MPU-6050 register map (InvenSense RM-MPU-6000A-00).
namespace mpu6050 {
constexpr uint8_t kAddress = 0x68;  // AD0 low
constexpr uint8_t kSmplrtDiv = 0x19;
constexpr uint8_t kConfig = 0x1A;
constexpr uint8_t kGyroConfig = 0x1B;
constexpr uint8_t kAccelConfig = 0x1C;
constexpr uint8_t kAccelXoutH = 0x3B;  // 14 bytes: accel xyz, temp, gyro xyz, big-endian
constexpr uint8_t kPwrMgmt1 = 0x6B;
constexpr uint8_t kWhoAmI = 0x75;
constexpr uint8_t kWhoAmIValue = 0x68;
constexpr uint8_t kClockPllXGyro = 0x01;  // PWR_MGMT_1: awake, PLL with X-gyro reference
constexpr uint8_t kDlpf21Hz = 4;          // CONFIG.DLPF_CFG: accel 21 Hz, gyro 20 Hz, 1 kHz rate
constexpr uint8_t kDiv100Hz = 9;          // SMPLRT_DIV: 1 kHz / (1 + 9) = 100 Hz
constexpr size_t kBurstBytes = 14;

/// LSB per g for ACCEL_CONFIG.AFS_SEL 0-3 (+-2, 4, 8, 16 g): protocol/schema.yaml's scales.
constexpr float accel_lsb_per_g(uint8_t fs) { return protocol::kAccelLsbPerG[fs & 3u]; }
/// LSB per deg/s for GYRO_CONFIG.FS_SEL 0-3 (+-250, 500, 1000, 2000 deg/s).
constexpr float gyro_lsb_per_dps(uint8_t fs) { return protocol::kGyroLsbPerDps[fs & 3u]; }
/// Die temperature in deg C from TEMP_OUT.
constexpr float temperature_c(int16_t raw) {
  return static_cast<float>(raw) / protocol::kTempLsbPerC + protocol::kTempOffsetC;
}
}  // namespace mpu6050

/// One sample in sensor counts, sensor axes.
struct ImuRaw {
  std::array<int16_t, 3> accel{};
  int16_t temp = 0;
  std::array<int16_t, 3> gyro{};
};

/// Init, burst reads, health and retry with exponential backoff. Each poll() does at most one
/// init sequence (6 short transactions) or one 14-byte burst read.
class Mpu6050 {
 public:
  static constexpr uint32_t kFirstBackoffUs = 50'000;
  static constexpr uint32_t kMaxBackoffUs = 2'000'000;
  static constexpr uint8_t kFailuresBeforeReinit = 3;

  explicit Mpu6050(I2cBus& bus) : bus_(bus) {}

  /// Sets the full-scale ranges (0-3 each) and re-initialises on the next poll.
  void configure(uint8_t accel_fs, uint8_t gyro_fs) noexcept;

  /// Takes a sample if the device is up; returns true and fills `out` on success.
  bool poll(uint32_t now_us, ImuRaw& out) noexcept;

  bool ok() const noexcept { return ok_; }
  bool present() const noexcept { return present_; }
  uint32_t errors() const noexcept { return errors_; }
  uint8_t accel_fs() const noexcept { return accel_fs_; }
  uint8_t gyro_fs() const noexcept { return gyro_fs_; }

 private:
  bool init() noexcept;
  void fail(uint32_t now_us) noexcept;

  I2cBus& bus_;
  uint8_t accel_fs_ = 0;
  uint8_t gyro_fs_ = 0;
  bool initialised_ = false;
  bool ok_ = false;
  bool present_ = false;
  uint8_t consecutive_failures_ = 0;
  uint32_t errors_ = 0;
  uint32_t retry_at_us_ = 0;
  bool waiting_ = false;
  uint32_t backoff_us_ = kFirstBackoffUs;
};

/// Sums samples between telemetry frames, so a 20 Hz stream of 100 Hz samples does not alias.
class ImuAverager {
 public:
  void add(const ImuRaw& s) noexcept;
  /// The rounded mean since the last call; false (and `out` untouched) when no sample arrived.
  bool take_mean(ImuRaw& out) noexcept;
  uint32_t count() const noexcept { return n_; }

 private:
  std::array<int32_t, 7> sum_{};
  uint32_t n_ = 0;
};

}  // namespace jackson::fw
