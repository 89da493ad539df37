#include "imu_calibration.hpp"

#include <Eigen/LU>
#include <cmath>

namespace jackson::fw {

namespace {
constexpr float kDegToRad = 3.14159265358979f / 180.0f;

int16_t saturate(float v) {
  const float r = std::nearbyint(v);
  if (r > 32767.0f) return 32767;
  if (r < -32768.0f) return -32768;
  return static_cast<int16_t>(r);
}
}  // namespace

bool ImuCalibration::valid(const Eigen::Matrix3f& r, const Eigen::Vector3f& bias,
                           float scale) noexcept {
  if (!r.allFinite() || !bias.allFinite() || !std::isfinite(scale)) return false;
  const float ortho = (r * r.transpose() - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff();
  return ortho < 1e-3f && std::fabs(r.determinant() - 1.0f) < 1e-3f &&
         bias.cwiseAbs().maxCoeff() < protocol::kGyroBiasRadSMax && scale >= protocol::kAccelScaleMin &&
         scale <= protocol::kAccelScaleMax;
}

void ImuCalibration::apply(uint8_t gyro_fs, ImuRaw& io) const noexcept {
  const float gyro_lsb_per_rad_s = mpu6050::gyro_lsb_per_dps(gyro_fs) / kDegToRad;
  const Eigen::Vector3f w(io.gyro[0], io.gyro[1], io.gyro[2]);
  const Eigen::Vector3f w_base = rotation * w - gyro_bias_rad_s * gyro_lsb_per_rad_s;
  const Eigen::Vector3f a(io.accel[0], io.accel[1], io.accel[2]);
  const Eigen::Vector3f a_base = accel_scale * (rotation * a);
  for (int i = 0; i < 3; ++i) {
    io.gyro[static_cast<size_t>(i)] = saturate(w_base[i]);
    io.accel[static_cast<size_t>(i)] = saturate(a_base[i]);
  }
}

Eigen::Matrix3f ImuCalibration::from_row_major(const std::array<float, 9>& m) noexcept {
  Eigen::Matrix3f r;
  r << m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8];
  return r;
}

std::array<float, 9> ImuCalibration::rotation_row_major() const noexcept {
  std::array<float, 9> m{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[static_cast<size_t>(3 * i + j)] = rotation(i, j);
  }
  return m;
}

}  // namespace jackson::fw
