// The firmware HAL on Linux: a pseudo-terminal for the host link, sensors from a feed.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "hal.hpp"

namespace jackson::fw::posix {

/// Clock set by the feed (lockstep) or following CLOCK_MONOTONIC (real time).
class FeedClock : public Clock {
 public:
  uint32_t micros() override;
  void set(uint64_t t_us) { t_us_ = t_us; }
  void follow_monotonic(bool on) { monotonic_ = on; }
  uint64_t now64();

 private:
  uint64_t t_us_ = 0;
  bool monotonic_ = false;
};

/// Emulates the ESP32 PCNT: the feed gives true cumulative counts, this presents them as a
/// 16-bit count that resets at +-limit plus limit events, exactly as the hardware does.
class FeedEncoders : public Encoders {
 public:
  static constexpr int16_t kLimit = 30000;  // as firmware/esp32/board_config.hpp
  int16_t limit() const override { return kLimit; }
  void read(PcntSample& left, PcntSample& right) override;
  void set(int64_t left, int64_t right) {
    left_ = left;
    right_ = right;
  }

 private:
  int64_t left_ = 0;
  int64_t right_ = 0;
};

/// MPU-6050 register file behind an I2C bus: WHO_AM_I answers 0x68, 0x3B..0x48 come from the
/// feed, writes are kept; every transaction fails while the feed says the IMU is absent.
class FeedI2c : public I2cBus {
 public:
  FeedI2c();
  bool write_reg(uint8_t addr, uint8_t reg, uint8_t value) override;
  bool read_regs(uint8_t addr, uint8_t reg, uint8_t* out, size_t n) override;
  void set(bool present, const std::array<uint8_t, 14>& burst);
  void set_present(bool present) { present_ = present; }
  uint8_t reg(uint8_t r) const { return regs_[r]; }

 private:
  std::array<uint8_t, 128> regs_{};
  bool present_ = true;
};

/// The host link: a pseudo-terminal in raw mode. The slave stays open here so a client may close
/// and reopen it; frames go through a bounded queue and are dropped whole when it is full.
class PtySerial : public SerialPort {
 public:
  static constexpr size_t kQueueBytes = 8192;
  bool open_pty(std::string& slave_path, std::string& error);
  bool write_all_or_nothing(const uint8_t* data, size_t n) override;
  size_t read(uint8_t* out, size_t cap) override;
  int fd() const { return master_; }
  void flush();

 private:
  int master_ = -1;
  int slave_ = -1;
  std::vector<uint8_t> queue_;
};

/// Blobs in memory, and in DIR/<key>.bin when a directory is given.
class FileStorage : public Storage {
 public:
  explicit FileStorage(std::string dir) : dir_(std::move(dir)) {}
  bool load(const char* key, void* out, size_t n) override;
  bool save(const char* key, const void* data, size_t n) override;

 private:
  std::string dir_;
  std::map<std::string, std::vector<uint8_t>> mem_;
};

/// Records the core's motor output for the feed's status line.
class RecordedMotors : public MotorOutput {
 public:
  void drive(int16_t left, int16_t right) override {
    left_ = left;
    right_ = right;
    braked_ = false;
  }
  void brake() override {
    left_ = right_ = 0;
    braked_ = true;
  }
  int16_t left_ = 0;
  int16_t right_ = 0;
  bool braked_ = true;
};

/// Records the core's motor interlock line (PCA9685 OE / TB6612 STBY) for the feed's status
/// line. Starts released, as the pull resistor holds it before the core sets it.
class RecordedMotorEnable : public MotorEnable {
 public:
  void set(bool enabled) override {
    enabled_ = enabled;
    ++changes_;
  }
  bool enabled_ = false;
  uint32_t changes_ = 0;
};

}  // namespace jackson::fw::posix
