// CPU time of the firmware core on Linux: runs the core as the ESP32 loop does (tick every
// 1 ms, IMU at 100 Hz) with telemetry set to its top rate of 200 Hz (SET_RATE), a heartbeat
// and a motor command from the host each period, and prints one JSON object with the mean and
// p99 CPU time per 5 ms telemetry period.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "firmware.hpp"
#include "posix/posix_hal.hpp"

using namespace jackson::fw;
namespace proto = jackson::protocol;

namespace {

struct NullSerial : SerialPort {
  std::vector<uint8_t> rx;
  size_t bytes_out = 0;
  bool write_all_or_nothing(const uint8_t*, size_t n) override {
    bytes_out += n;
    return true;
  }
  size_t read(uint8_t* out, size_t cap) override {
    const size_t n = std::min(cap, rx.size());
    std::copy(rx.begin(), rx.begin() + static_cast<long>(n), out);
    rx.erase(rx.begin(), rx.begin() + static_cast<long>(n));
    return n;
  }
  template <class Msg>
  void host_sends(const Msg& m, uint8_t seq) {
    uint8_t buf[proto::kMaxFrame];
    const size_t n = proto::encode_frame(m, seq, buf, sizeof buf);
    rx.insert(rx.end(), buf, buf + n);
  }
};

struct NullMotors : MotorOutput {
  void drive(int16_t, int16_t) override {}
  void brake() override {}
};

}  // namespace

int main() {
  posix::FeedClock clock;
  posix::FeedEncoders enc;
  posix::FeedI2c i2c;
  NullSerial serial;
  posix::FileStorage storage("");
  NullMotors motors;
  posix::RecordedMotorEnable line;
  Hal hal{clock, enc, i2c, serial, storage, &motors, 1, &line};
  static Firmware fw(hal);
  clock.set(1000);
  fw.begin();
  proto::Hello h;
  h.protocol_version = proto::kProtocolVersion;
  h.schema_hash = proto::kSchemaHash;
  serial.host_sends(h, 0);
  proto::SetRate rate;
  rate.rate_hz = 200;
  serial.host_sends(rate, 1);
  uint64_t t = 1000;
  clock.set(t);
  fw.tick();  // HELLO and SET_RATE taken: 200 Hz from here
  const unsigned frames_before = fw.frames_sent();
  uint8_t last_seq = 0;
  fw.last_telemetry_seq(last_seq);
  int telemetry_periods = 0;  // periods that sent a telemetry frame (a new telemetry SEQ)
  const int periods = 20000;  // 100 s of MCU time at 200 Hz
  std::vector<double> per_period_us;
  per_period_us.reserve(periods);
  uint8_t seq = 2;
  for (int p = 0; p < periods; ++p) {
    proto::Heartbeat hb;
    hb.ack_seq = static_cast<uint8_t>(p);
    serial.host_sends(hb, seq++);
    proto::MotorPwm m;
    m.left = 4000;
    m.right = 4100;
    serial.host_sends(m, seq++);
    enc.set(31 * p, 30 * p);
    const auto c0 = std::chrono::steady_clock::now();
    for (int k = 0; k < 5; ++k) {  // 5 loop iterations of 1 ms per 200 Hz telemetry period
      t += 1000;
      clock.set(t);
      fw.tick();
    }
    const auto c1 = std::chrono::steady_clock::now();
    per_period_us.push_back(std::chrono::duration<double, std::micro>(c1 - c0).count());
    uint8_t seq_now = 0;
    if (fw.last_telemetry_seq(seq_now) && seq_now != last_seq) ++telemetry_periods;
    last_seq = seq_now;
  }
  std::vector<double> sorted = per_period_us;
  std::sort(sorted.begin(), sorted.end());
  double sum = 0;
  for (double v : per_period_us) sum += v;
  std::printf(
      "{\"periods\": %d, \"mean_us\": %.3f, \"median_us\": %.3f, \"p99_us\": %.3f, "
      "\"frames_sent\": %u, \"telemetry_periods\": %d, \"bytes_out\": %zu}\n",
      periods, sum / periods, sorted[sorted.size() / 2], sorted[sorted.size() * 99 / 100],
      fw.frames_sent() - frames_before, telemetry_periods, serial.bytes_out);
  return telemetry_periods == periods ? 0 : 1;  // a frame every 5 ms: the rate was taken
}
