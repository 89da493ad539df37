#include "mpu6050.hpp"

namespace jackson::fw {

namespace {
bool reached(uint32_t now, uint32_t t) { return static_cast<int32_t>(now - t) >= 0; }
int16_t be16(const uint8_t* p) {
  return static_cast<int16_t>(static_cast<uint16_t>((static_cast<uint16_t>(p[0]) << 8) | p[1]));
}
}  // namespace

void Mpu6050::configure(uint8_t accel_fs, uint8_t gyro_fs) noexcept {
  accel_fs_ = accel_fs & 3u;
  gyro_fs_ = gyro_fs & 3u;
  initialised_ = false;
  waiting_ = false;
}

bool Mpu6050::init() noexcept {
  using namespace mpu6050;
  uint8_t who = 0;
  if (!bus_.read_regs(kAddress, kWhoAmI, &who, 1) || who != kWhoAmIValue) return false;
  present_ = true;
  return bus_.write_reg(kAddress, kPwrMgmt1, kClockPllXGyro) &&
         bus_.write_reg(kAddress, kSmplrtDiv, kDiv100Hz) &&
         bus_.write_reg(kAddress, kConfig, kDlpf21Hz) &&
         bus_.write_reg(kAddress, kGyroConfig, static_cast<uint8_t>(gyro_fs_ << 3)) &&
         bus_.write_reg(kAddress, kAccelConfig, static_cast<uint8_t>(accel_fs_ << 3));
}

void Mpu6050::fail(uint32_t now_us) noexcept {
  ++errors_;
  ok_ = false;
  if (!initialised_ || ++consecutive_failures_ >= kFailuresBeforeReinit) {
    initialised_ = false;
    waiting_ = true;
    retry_at_us_ = now_us + backoff_us_;
    backoff_us_ = backoff_us_ >= kMaxBackoffUs / 2 ? kMaxBackoffUs : backoff_us_ * 2;
  }
}

bool Mpu6050::poll(uint32_t now_us, ImuRaw& out) noexcept {
  if (waiting_ && !reached(now_us, retry_at_us_)) return false;
  waiting_ = false;
  if (!initialised_) {
    if (!init()) {
      fail(now_us);
      return false;
    }
    initialised_ = true;
    consecutive_failures_ = 0;
  }
  uint8_t b[mpu6050::kBurstBytes];
  if (!bus_.read_regs(mpu6050::kAddress, mpu6050::kAccelXoutH, b, sizeof b)) {
    fail(now_us);
    return false;
  }
  for (size_t i = 0; i < 3; ++i) {
    out.accel[i] = be16(b + 2 * i);
    out.gyro[i] = be16(b + 8 + 2 * i);
  }
  out.temp = be16(b + 6);
  ok_ = true;
  consecutive_failures_ = 0;
  backoff_us_ = kFirstBackoffUs;
  return true;
}

void ImuAverager::add(const ImuRaw& s) noexcept {
  for (size_t i = 0; i < 3; ++i) {
    sum_[i] += s.accel[i];
    sum_[4 + i] += s.gyro[i];
  }
  sum_[3] += s.temp;
  ++n_;
}

bool ImuAverager::take_mean(ImuRaw& out) noexcept {
  if (n_ == 0) return false;
  const int32_t n = static_cast<int32_t>(n_);
  auto mean = [n](int32_t sum) {
    // round half away from zero
    return static_cast<int16_t>(sum >= 0 ? (sum + n / 2) / n : -((-sum + n / 2) / n));
  };
  for (size_t i = 0; i < 3; ++i) {
    out.accel[i] = mean(sum_[i]);
    out.gyro[i] = mean(sum_[4 + i]);
  }
  out.temp = mean(sum_[3]);
  sum_ = {};
  n_ = 0;
  return true;
}

}  // namespace jackson::fw
