// Fakes of the HAL for unit tests only (end-to-end tests use the POSIX build over a real pty).
#pragma once

#include <array>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "firmware.hpp"
#include "jackson/protocol/frame.hpp"

namespace jackson::fw::test {

struct FakeClock : Clock {
  uint32_t t = 1000;
  uint32_t micros() override { return t; }
};

struct FakeEncoders : Encoders {
  int16_t lim = 30000;
  PcntSample l, r;
  int16_t limit() const override { return lim; }
  void read(PcntSample& left, PcntSample& right) override {
    left = l;
    right = r;
  }
  void set_total(int64_t left, int64_t right) {
    auto split = [this](int64_t total, PcntSample& s) {
      s.limit_events = static_cast<int32_t>(total / lim);
      s.count = static_cast<int16_t>(total - static_cast<int64_t>(s.limit_events) * lim);
    };
    split(left, l);
    split(right, r);
  }
};

/// MPU-6050 register file; `present = false` makes every transaction fail.
struct FakeI2c : I2cBus {
  std::array<uint8_t, 128> regs{};
  bool present = true;
  int transactions = 0;
  std::vector<std::pair<uint8_t, uint8_t>> writes;
  FakeI2c() { regs[0x75] = 0x68; }
  bool write_reg(uint8_t addr, uint8_t reg, uint8_t value) override {
    ++transactions;
    if (!present || addr != 0x68) return false;
    regs[reg] = value;
    writes.emplace_back(reg, value);
    return true;
  }
  bool read_regs(uint8_t addr, uint8_t reg, uint8_t* out, size_t n) override {
    ++transactions;
    if (!present || addr != 0x68) return false;
    std::memcpy(out, regs.data() + reg, n);
    return true;
  }
  void set_sample(std::array<int16_t, 3> accel, int16_t temp, std::array<int16_t, 3> gyro) {
    const int16_t v[7] = {accel[0], accel[1], accel[2], temp, gyro[0], gyro[1], gyro[2]};
    for (int i = 0; i < 7; ++i) {
      regs[0x3B + 2 * i] = static_cast<uint8_t>(static_cast<uint16_t>(v[i]) >> 8);
      regs[0x3B + 2 * i + 1] = static_cast<uint8_t>(static_cast<uint16_t>(v[i]) & 0xFF);
    }
  }
};

/// Captures what the firmware sends and decodes it; queues what the host would send.
struct FakeSerial : SerialPort {
  std::vector<uint8_t> rx;  // host -> device, not yet read
  std::vector<uint8_t> tx;  // device -> host
  bool full = false;
  bool write_all_or_nothing(const uint8_t* data, size_t n) override {
    if (full) return false;
    tx.insert(tx.end(), data, data + n);
    return true;
  }
  size_t read(uint8_t* out, size_t cap) override {
    const size_t n = rx.size() < cap ? rx.size() : cap;
    if (n == 0) return 0;
    std::memcpy(out, rx.data(), n);
    rx.erase(rx.begin(), rx.begin() + static_cast<long>(n));
    return n;
  }
  template <class Msg>
  void host_sends(const Msg& m, uint8_t seq) {
    uint8_t buf[protocol::kMaxFrame];
    const size_t n = protocol::encode_frame(m, seq, buf, sizeof buf);
    rx.insert(rx.end(), buf, buf + n);
  }
};

struct FakeStorage : Storage {
  std::map<std::string, std::vector<uint8_t>> blobs;
  bool fail = false;
  bool load(const char* key, void* out, size_t n) override {
    auto it = blobs.find(key);
    if (it == blobs.end() || it->second.size() != n) return false;
    std::memcpy(out, it->second.data(), n);
    return true;
  }
  bool save(const char* key, const void* data, size_t n) override {
    if (fail) return false;
    const auto* p = static_cast<const uint8_t*>(data);
    blobs[key] = std::vector<uint8_t>(p, p + n);
    return true;
  }
};

struct FakeMotors : MotorOutput {
  int16_t left = 0, right = 0;
  bool braked = true;
  int brakes = 0;
  void drive(int16_t l, int16_t r) override {
    left = l;
    right = r;
    braked = false;
  }
  void brake() override {
    left = right = 0;
    braked = true;
    ++brakes;
  }
};

/// The interlock line, recording each set() call with the clock's time.
struct FakeEnable : MotorEnable {
  explicit FakeEnable(const FakeClock& c) : clock(c) {}
  const FakeClock& clock;
  bool enabled = true;  // wrong on purpose until begin() sets it
  std::vector<bool> changes;
  std::vector<uint32_t> at_us;
  void set(bool e) override {
    enabled = e;
    changes.push_back(e);
    at_us.push_back(clock.t);
  }
};

/// A decoded frame the firmware sent.
struct Sent {
  uint8_t type;
  uint8_t seq;
  std::vector<uint8_t> payload;
  template <class Msg>
  Msg as() const {
    Msg m;
    m.decode(payload.data(), payload.size());
    return m;
  }
};

/// A complete board of fakes with the firmware on it.
struct Bench {
  FakeClock clock;
  FakeEncoders enc;
  FakeI2c i2c;
  FakeSerial serial;
  FakeStorage storage;
  FakeMotors motors;
  FakeEnable enable{clock};
  Hal hal;
  Firmware fw;
  protocol::FrameDecoder host_decoder;

  explicit Bench(bool with_motors = true)
      : hal{clock, enc, i2c, serial, storage, with_motors ? &motors : nullptr, 7, &enable},
        fw(hal) {
    i2c.set_sample({100, -200, 16384}, -1700, {10, -20, 30});
  }

  /// Runs the firmware for `us` microseconds in 1 ms ticks.
  void run_for(uint32_t us, uint32_t step = 1000) {
    for (uint32_t t = 0; t < us; t += step) {
      clock.t += step;
      fw.tick();
    }
  }

  /// Everything the firmware sent since the last call, decoded by the host-side decoder.
  std::vector<Sent> take_sent() {
    std::vector<Sent> out;
    host_decoder.feed(serial.tx.data(), serial.tx.size(), clock.t, [&](const protocol::Frame& f) {
      out.push_back(Sent{f.type, f.seq, std::vector<uint8_t>(f.payload, f.payload + f.len)});
    });
    serial.tx.clear();
    return out;
  }

  /// HELLO with this build's version and `session` (0: always a new session); returns what
  /// came back.
  std::vector<Sent> hello(uint8_t seq = 0, uint32_t session = 0) {
    protocol::Hello h;
    h.protocol_version = protocol::kProtocolVersion;
    h.schema_hash = protocol::kSchemaHash;
    h.session = session;
    serial.host_sends(h, seq);
    fw.tick();
    return take_sent();
  }
};

template <class Msg>
std::vector<Sent> only(const std::vector<Sent>& v) {
  std::vector<Sent> out;
  for (const auto& s : v) {
    if (s.type == Msg::kType) out.push_back(s);
  }
  return out;
}

}  // namespace jackson::fw::test
