// MPU-6050: datasheet scaling, init sequence, burst read, failure handling and averaging.
#include <gtest/gtest.h>

#include "fakes.hpp"
#include "mpu6050.hpp"

using namespace jackson::fw;
using jackson::fw::test::FakeI2c;

TEST(Mpu6050Scaling, DatasheetSensitivities) {
  EXPECT_FLOAT_EQ(mpu6050::gyro_lsb_per_dps(0), 131.0f);
  EXPECT_FLOAT_EQ(mpu6050::gyro_lsb_per_dps(1), 65.5f);
  EXPECT_FLOAT_EQ(mpu6050::gyro_lsb_per_dps(2), 32.8f);
  EXPECT_FLOAT_EQ(mpu6050::gyro_lsb_per_dps(3), 16.4f);
  EXPECT_FLOAT_EQ(mpu6050::accel_lsb_per_g(0), 16384.0f);
  EXPECT_FLOAT_EQ(mpu6050::accel_lsb_per_g(3), 2048.0f);
  EXPECT_FLOAT_EQ(mpu6050::temperature_c(0), 36.53f);
  EXPECT_NEAR(mpu6050::temperature_c(-3400), 26.53f, 1e-4f);
  // 131 LSB = 1 deg/s; 16384 LSB = 1 g
  EXPECT_NEAR(1310 / mpu6050::gyro_lsb_per_dps(0), 10.0f, 1e-5f);
}

TEST(Mpu6050, InitWakesWithPllAnd21HzFilterAndRanges) {
  FakeI2c bus;
  Mpu6050 imu(bus);
  imu.configure(1, 2);
  ImuRaw s;
  ASSERT_TRUE(imu.poll(0, s));
  EXPECT_EQ(bus.regs[0x6B], 0x01);  // PWR_MGMT_1: awake, PLL X gyro
  EXPECT_EQ(bus.regs[0x1A], 4);     // DLPF_CFG 4: ~21 Hz
  EXPECT_EQ(bus.regs[0x19], 9);     // 100 Hz sample rate
  EXPECT_EQ(bus.regs[0x1B], 2 << 3);
  EXPECT_EQ(bus.regs[0x1C], 1 << 3);
  EXPECT_TRUE(imu.ok());
  EXPECT_TRUE(imu.present());
}

TEST(Mpu6050, BurstReadIsBigEndianInRegisterOrder) {
  FakeI2c bus;
  bus.set_sample({-2, 300, 16384}, -3400, {131, -131, 32767});
  Mpu6050 imu(bus);
  ImuRaw s;
  ASSERT_TRUE(imu.poll(0, s));
  EXPECT_EQ(s.accel, (std::array<int16_t, 3>{-2, 300, 16384}));
  EXPECT_EQ(s.temp, -3400);
  EXPECT_EQ(s.gyro, (std::array<int16_t, 3>{131, -131, 32767}));
}

TEST(Mpu6050, WrongWhoAmIIsAFailure) {
  FakeI2c bus;
  bus.regs[0x75] = 0x00;
  Mpu6050 imu(bus);
  ImuRaw s;
  EXPECT_FALSE(imu.poll(0, s));
  EXPECT_FALSE(imu.present());
  EXPECT_EQ(imu.errors(), 1u);
}

TEST(Mpu6050, MissingImuRetriesWithExponentialBackoff) {
  FakeI2c bus;
  bus.present = false;
  Mpu6050 imu(bus);
  ImuRaw s;
  std::vector<uint32_t> attempts;
  for (uint32_t t = 0; t <= 4'000'000; t += 1000) {
    const int before = bus.transactions;
    imu.poll(t, s);
    if (bus.transactions != before) attempts.push_back(t);
  }
  ASSERT_GE(attempts.size(), 6u);
  EXPECT_EQ(attempts[0], 0u);
  EXPECT_EQ(attempts[1], 50'000u);
  EXPECT_EQ(attempts[2], 150'000u);   // +100 ms
  EXPECT_EQ(attempts[3], 350'000u);   // +200 ms
  EXPECT_EQ(attempts[4], 750'000u);   // +400 ms
  for (size_t i = 1; i < attempts.size(); ++i) {
    EXPECT_LE(attempts[i] - attempts[i - 1], Mpu6050::kMaxBackoffUs);
  }
  EXPECT_FALSE(imu.ok());
  bus.present = true;  // plugged back in: recovers at the next retry
  bool recovered = false;
  for (uint32_t t = 4'001'000; t <= 7'000'000 && !recovered; t += 1000) recovered = imu.poll(t, s);
  EXPECT_TRUE(recovered);
  EXPECT_TRUE(imu.ok());
}

TEST(Mpu6050, ReadFailuresReinitAfterThreeInARow) {
  FakeI2c bus;
  Mpu6050 imu(bus);
  ImuRaw s;
  ASSERT_TRUE(imu.poll(0, s));
  bus.present = false;
  EXPECT_FALSE(imu.poll(10'000, s));
  EXPECT_FALSE(imu.ok());
  EXPECT_FALSE(imu.poll(20'000, s));
  EXPECT_FALSE(imu.poll(30'000, s));  // third: back to init with backoff
  bus.present = true;
  EXPECT_FALSE(imu.poll(40'000, s));  // still backing off
  EXPECT_TRUE(imu.poll(80'000, s));
  EXPECT_EQ(imu.errors(), 3u);
}

TEST(ImuAverager, MeanIsRoundedAndResets) {
  ImuAverager avg;
  ImuRaw a, b, out;
  a.gyro = {1, -1, 100};
  b.gyro = {2, -2, 101};
  a.accel = {0, 0, 16384};
  b.accel = {0, 0, 16385};
  avg.add(a);
  avg.add(b);
  ASSERT_TRUE(avg.take_mean(out));
  EXPECT_EQ(out.gyro, (std::array<int16_t, 3>{2, -2, 101}));  // 1.5 -> 2, -1.5 -> -2
  EXPECT_EQ(out.accel[2], 16385);
  EXPECT_FALSE(avg.take_mean(out));
}

TEST(ImuAverager, FiveSamplesPerFrameAverageOutAlternatingNoise) {
  ImuAverager avg;
  ImuRaw out;
  for (int i = 0; i < 5; ++i) {
    ImuRaw s;
    s.gyro[2] = static_cast<int16_t>(i % 2 == 0 ? 1000 : -1000);
    avg.add(s);
  }
  ASSERT_TRUE(avg.take_mean(out));
  EXPECT_EQ(out.gyro[2], 200);
}
