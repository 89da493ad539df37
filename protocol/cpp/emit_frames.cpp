// Writes a stream of frames to stdout, encoded by the C++ codec: 200 telemetry frames of a
// robot driving a gentle arc (20 Hz of MCU time), one frame of every other device message,
// and a few corruptions (noise, a flipped bit, a truncated frame). `make demo` pipes it
// into `jackson decode -`, the Python decoder.
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include "jackson/protocol/frame.hpp"

namespace jp = jackson::protocol;

namespace {

std::vector<uint8_t> out;
uint8_t seq = 0;

template <class Msg>
size_t emit(const Msg& m) {
  uint8_t buf[jp::kMaxFrame];
  const size_t n = jp::encode_frame(m, seq++, buf, sizeof buf);
  out.insert(out.end(), buf, buf + n);
  return n;
}

}  // namespace

int main() {
  jp::Info info;
  info.protocol_version = jp::kProtocolVersion;
  info.schema_hash = jp::kSchemaHash;
  info.firmware_version = {0, 1, 0};
  info.telemetry_rate_hz = 20;
  info.failsafe_ms = 600;
  info.capabilities = jp::capabilities::kImuPresent;
  info.imu_rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.accel_scale = 1.0f;
  emit(info);

  for (int k = 0; k < 200; ++k) {
    jp::Telemetry t;
    t.t_us = 50000u * static_cast<uint32_t>(k);
    t.enc_left = 15 * k;   // the right wheel turns faster: a left arc
    t.enc_right = 17 * k;
    t.flags = jp::telemetry_flags::kImuOk;
    t.accel = {12, -8, 16384};
    t.temp = -1200;
    t.gyro = {2, -1, 33};
    const size_t start = out.size();
    const size_t n = emit(t);
    if (k == 50) out[start + 10] ^= 0x04;                      // flipped bit: CRC error
    if (k == 100) out.resize(start + n / 2);                     // truncated frame
    if (k == 150) {                                              // line noise between frames
      const uint8_t noise[] = {0x00, 0xFF, 0xA5, 0x13, 0xA5, 0x5A, 0x07, 0x42};
      out.insert(out.end(), noise, noise + sizeof noise);
    }
  }
  jp::Ack ack;
  ack.acked_type = jp::SetRate::kType;
  ack.acked_seq = 3;
  emit(ack);
  jp::Log log;
  log.level = static_cast<uint8_t>(jp::LogLevel::kInfo);
  log.text.assign("telemetry at 20 Hz");
  emit(log);
  jp::Status st;
  st.t_us = 10000000;
  st.rx_frames_ok = 12;
  st.telemetry_rate_hz = 20;
  emit(st);
  return std::fwrite(out.data(), 1, out.size(), stdout) == out.size() ? 0 : 1;
}
