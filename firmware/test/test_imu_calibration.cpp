// IMU calibration maths against hand-computed values.
#include <gtest/gtest.h>

#include <cmath>

#include "imu_calibration.hpp"

using namespace jackson::fw;

namespace {
Eigen::Matrix3f rot_z_90() {
  Eigen::Matrix3f r;
  r << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // sensor x -> base y
  return r;
}
}  // namespace

TEST(ImuCalibration, IdentityLeavesCountsUnchanged) {
  ImuCalibration cal;
  ImuRaw s;
  s.accel = {10, -20, 16384};
  s.gyro = {1, 2, 3};
  ImuRaw out = s;
  cal.apply(0, out);
  EXPECT_EQ(out.accel, s.accel);
  EXPECT_EQ(out.gyro, s.gyro);
}

TEST(ImuCalibration, MountingRotationMapsSensorAxesIntoTheBaseFrame) {
  ImuCalibration cal;
  cal.rotation = rot_z_90();
  ImuRaw s;
  s.accel = {1000, 0, 16384};
  s.gyro = {0, 131, 0};
  cal.apply(0, s);
  EXPECT_EQ(s.accel, (std::array<int16_t, 3>{0, 1000, 16384}));
  EXPECT_EQ(s.gyro, (std::array<int16_t, 3>{-131, 0, 0}));
}

TEST(ImuCalibration, GyroBiasIsSubtractedInRadPerSecond) {
  ImuCalibration cal;
  cal.gyro_bias_rad_s = Eigen::Vector3f(0, 0, 0.01f);  // 0.01 rad/s = 0.5730 deg/s = 75.06 LSB
  ImuRaw s;
  s.gyro = {0, 0, 175};
  cal.apply(0, s);
  EXPECT_EQ(s.gyro[2], 100);  // 175 - 75.06 = 99.94 -> 100
  ImuRaw t;
  t.gyro = {0, 0, 175};
  cal.apply(3, t);  // +-2000 deg/s: 16.4 LSB per deg/s, bias = 9.40 LSB
  EXPECT_EQ(t.gyro[2], 166);
}

TEST(ImuCalibration, AccelScaleCorrectsTheMeasuredGravity) {
  // the paper measured 9.299 m/s^2 at rest: 9.299/9.81 g = 15531 LSB at +-2 g
  ImuCalibration cal;
  cal.accel_scale = 9.81f / 9.299f;
  ImuRaw s;
  s.accel = {0, 0, 15531};
  cal.apply(0, s);
  EXPECT_NEAR(s.accel[2], 16384, 1);
}

TEST(ImuCalibration, OutputSaturatesInsteadOfWrapping) {
  ImuCalibration cal;
  cal.accel_scale = 2.0f;
  ImuRaw s;
  s.accel = {30000, -30000, 0};
  cal.apply(0, s);
  EXPECT_EQ(s.accel[0], 32767);
  EXPECT_EQ(s.accel[1], -32768);
}

TEST(ImuCalibration, ValidityChecks) {
  const Eigen::Vector3f zero = Eigen::Vector3f::Zero();
  EXPECT_TRUE(ImuCalibration::valid(Eigen::Matrix3f::Identity(), zero, 1.054f));
  EXPECT_TRUE(ImuCalibration::valid(rot_z_90(), zero, 1.0f));
  Eigen::Matrix3f mirror = Eigen::Matrix3f::Identity();
  mirror(2, 2) = -1;  // det -1: a reflection, not a mounting
  EXPECT_FALSE(ImuCalibration::valid(mirror, zero, 1.0f));
  EXPECT_FALSE(ImuCalibration::valid(2 * Eigen::Matrix3f::Identity(), zero, 1.0f));
  EXPECT_FALSE(ImuCalibration::valid(Eigen::Matrix3f::Identity(), zero, 0.1f));
  EXPECT_FALSE(ImuCalibration::valid(Eigen::Matrix3f::Identity(), Eigen::Vector3f(1, 0, 0), 1.0f));
  EXPECT_FALSE(
      ImuCalibration::valid(Eigen::Matrix3f::Identity(), Eigen::Vector3f(NAN, 0, 0), 1.0f));
}

TEST(ImuCalibration, RowMajorRoundTrip) {
  const std::array<float, 9> m = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  ImuCalibration cal;
  cal.rotation = ImuCalibration::from_row_major(m);
  EXPECT_EQ(cal.rotation_row_major(), m);
  EXPECT_EQ(cal.rotation(0, 1), -1.0f);
}
