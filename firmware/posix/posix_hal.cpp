#include "posix_hal.hpp"

#include <fcntl.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace jackson::fw::posix {

uint64_t FeedClock::now64() {
  if (monotonic_) {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    t_us_ = static_cast<uint64_t>(ts.tv_sec) * 1000000u + static_cast<uint64_t>(ts.tv_nsec) / 1000u;
  }
  return t_us_;
}

uint32_t FeedClock::micros() { return static_cast<uint32_t>(now64()); }

void FeedEncoders::read(PcntSample& left, PcntSample& right) {
  auto split = [](int64_t total, PcntSample& s) {
    const int64_t events = total / kLimit;  // truncates toward zero, as the counter resets at +-limit
    s.limit_events = static_cast<int32_t>(events);
    s.count = static_cast<int16_t>(total - events * kLimit);
  };
  split(left_, left);
  split(right_, right);
}

FeedI2c::FeedI2c() {
  regs_[0x75] = 0x68;      // WHO_AM_I
  regs_[0x6B] = 0x40;      // PWR_MGMT_1 reset value: asleep
  regs_[0x3B + 4] = 0x40;  // ACCEL_ZOUT = 16384: at rest, level
}

bool FeedI2c::write_reg(uint8_t addr, uint8_t reg, uint8_t value) {
  if (!present_ || addr != 0x68 || reg >= regs_.size()) return false;
  regs_[reg] = value;
  return true;
}

bool FeedI2c::read_regs(uint8_t addr, uint8_t reg, uint8_t* out, size_t n) {
  if (!present_ || addr != 0x68 || reg + n > regs_.size()) return false;
  std::memcpy(out, regs_.data() + reg, n);
  return true;
}

void FeedI2c::set(bool present, const std::array<uint8_t, 14>& burst) {
  present_ = present;
  std::memcpy(regs_.data() + 0x3B, burst.data(), burst.size());
}

bool PtySerial::open_pty(std::string& slave_path, std::string& error) {
  master_ = posix_openpt(O_RDWR | O_NOCTTY);
  if (master_ < 0 || grantpt(master_) != 0 || unlockpt(master_) != 0) {
    error = std::string("cannot create a pseudo-terminal: ") + std::strerror(errno);
    return false;
  }
  const char* name = ptsname(master_);
  if (name == nullptr) {
    error = "ptsname failed";
    return false;
  }
  slave_path = name;
  slave_ = ::open(name, O_RDWR | O_NOCTTY);  // kept open: clients may close and reopen
  if (slave_ < 0) {
    error = std::string("cannot open ") + name + ": " + std::strerror(errno);
    return false;
  }
  termios tio{};
  tcgetattr(slave_, &tio);
  cfmakeraw(&tio);
  tcsetattr(slave_, TCSANOW, &tio);
  fcntl(master_, F_SETFL, fcntl(master_, F_GETFL) | O_NONBLOCK);
  return true;
}

void PtySerial::flush() {
  while (!queue_.empty()) {
    const ssize_t w = ::write(master_, queue_.data(), queue_.size());
    if (w <= 0) return;  // EAGAIN: nobody is reading; keep what fits
    queue_.erase(queue_.begin(), queue_.begin() + w);
  }
}

bool PtySerial::write_all_or_nothing(const uint8_t* data, size_t n) {
  flush();
  if (queue_.size() + n > kQueueBytes) return false;
  queue_.insert(queue_.end(), data, data + n);
  flush();
  return true;
}

size_t PtySerial::read(uint8_t* out, size_t cap) {
  flush();
  const ssize_t r = ::read(master_, out, cap);
  return r > 0 ? static_cast<size_t>(r) : 0;
}

bool FileStorage::load(const char* key, void* out, size_t n) {
  auto it = mem_.find(key);
  if (it == mem_.end() && !dir_.empty()) {
    FILE* f = std::fopen((dir_ + "/" + key + ".bin").c_str(), "rb");
    if (f != nullptr) {
      std::vector<uint8_t> data(n + 1);
      const size_t got = std::fread(data.data(), 1, data.size(), f);
      std::fclose(f);
      data.resize(got);
      it = mem_.emplace(key, std::move(data)).first;
    }
  }
  if (it == mem_.end() || it->second.size() != n) return false;
  std::memcpy(out, it->second.data(), n);
  return true;
}

bool FileStorage::save(const char* key, const void* data, size_t n) {
  const auto* p = static_cast<const uint8_t*>(data);
  mem_[key] = std::vector<uint8_t>(p, p + n);
  if (dir_.empty()) return true;
  const std::string path = dir_ + "/" + key + ".bin";
  FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return false;
  const bool ok = std::fwrite(data, 1, n, f) == n;
  return std::fclose(f) == 0 && ok;
}

}  // namespace jackson::fw::posix
