// On-board IMU calibration (Eigen fixed-size types only: no heap).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "mpu6050.hpp"

namespace jackson::fw {

/// Mounting rotation into the base frame (REP-103: x forward, y left, z up), gyro bias and
/// accelerometer gravity scale:
///   omega_base = R * omega_sensor - gyro_bias      [rad/s]
///   a_base     = accel_scale * R * a_sensor
/// Applied to averaged counts; the result stays in the LSB scale of the configured range, so
/// telemetry keeps its layout and the IMU_CALIBRATED flag tells the host not to apply it again.
struct ImuCalibration {
  Eigen::Matrix3f rotation = Eigen::Matrix3f::Identity();
  Eigen::Vector3f gyro_bias_rad_s = Eigen::Vector3f::Zero();
  float accel_scale = 1.0f;

  /// False unless R is a proper rotation (orthonormal within 1e-3, det +1), the bias is finite
  /// and under 0.5 rad/s, and the scale is in [0.5, 2].
  static bool valid(const Eigen::Matrix3f& r, const Eigen::Vector3f& bias, float scale) noexcept;

  /// Calibrates one sample in place (counts in, counts out, rounded and saturated to int16).
  /// The accelerometer scale is dimensionless, so only the gyro range matters.
  void apply(uint8_t gyro_fs, ImuRaw& io) const noexcept;

  /// Row-major float[9] <-> matrix, as carried by SET_IMU_CALIBRATION and INFO.
  static Eigen::Matrix3f from_row_major(const std::array<float, 9>& m) noexcept;
  std::array<float, 9> rotation_row_major() const noexcept;
};

}  // namespace jackson::fw
