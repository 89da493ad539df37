// Frame layer of the jackson wire protocol (protocol/spec.md): CRC-32C, encoder, streaming decoder.
// Header-only C++17: no heap, no exceptions, no RTTI; runs on the ESP32-S3 and on Linux.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "jackson/protocol/messages.hpp"

namespace jackson::protocol {

constexpr uint8_t kSync0 = 0xA5;
constexpr uint8_t kSync1 = 0x5A;
constexpr size_t kHeaderSize = 6;  ///< SYNC0 SYNC1 VER TYPE SEQ LEN
constexpr size_t kCrcSize = 4;
constexpr size_t kMaxFrame = kHeaderSize + kMaxPayload + kCrcSize;

namespace detail {
constexpr uint32_t kCrc32cPoly = 0x82F63B78u;  // Castagnoli, reflected

constexpr std::array<uint32_t, 256> make_crc32c_table() {
  std::array<uint32_t, 256> t{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ kCrc32cPoly : c >> 1;
    t[i] = c;
  }
  return t;
}
inline constexpr std::array<uint32_t, 256> kCrc32cTable = make_crc32c_table();
}  // namespace detail

/// CRC-32C (Castagnoli; init and final XOR 0xFFFFFFFF, reflected), as crcmod's 'crc-32c'.
/// check("123456789") = 0xE3069283. Table-driven, 1 KiB of constant data in flash.
inline uint32_t crc32c(const uint8_t* data, size_t n) noexcept {
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) c = detail::kCrc32cTable[(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

/// Writes one frame carrying `msg` into `out`; returns its length, or 0 when `cap` is too small.
template <class Msg>
size_t encode_frame(const Msg& msg, uint8_t seq, uint8_t* out, size_t cap) noexcept {
  static_assert(Msg::kMaxSize <= kMaxPayload, "message larger than the frame allows");
  uint8_t payload[Msg::kMaxSize + 1];
  const size_t len = msg.encode(payload);
  const size_t total = kHeaderSize + len + kCrcSize;
  if (cap < total) return 0;
  out[0] = kSync0;
  out[1] = kSync1;
  out[2] = kProtocolVersion;
  out[3] = Msg::kType;
  out[4] = seq;
  out[5] = static_cast<uint8_t>(len);
  std::memcpy(out + kHeaderSize, payload, len);
  wire::put(out + kHeaderSize + len, crc32c(out + 2, 4 + len));
  return total;
}

/// A frame that passed every check. `payload` is valid only inside the sink call.
struct Frame {
  uint8_t type;
  uint8_t seq;
  uint8_t len;
  const uint8_t* payload;
  uint32_t crc = 0;  ///< the frame's CRC-32C (ACK and NACK echo it as acked_crc)

  /// Decodes the payload into `msg` (zero-filling missing trailing fields); false on type mismatch.
  template <class Msg>
  bool as(Msg& msg) const noexcept {
    if (type != Msg::kType) return false;
    msg.decode(payload, len);
    return true;
  }
};

/// What the decoder saw. Every byte fed ends up in a delivered frame, in bytes_skipped,
/// or still pending.
struct DecoderCounters {
  uint32_t frames_ok = 0;        ///< frames delivered
  uint32_t crc_errors = 0;       ///< complete candidates whose CRC failed
  uint32_t bytes_skipped = 0;    ///< bytes not part of a delivered frame
  uint32_t oversize = 0;         ///< LEN above kMaxPayload
  uint32_t unknown_version = 0;  ///< VER other than kProtocolVersion
  uint32_t unknown_type = 0;     ///< CRC-valid frames of a TYPE the schema lacks (skipped whole)
  uint32_t seq_gaps = 0;         ///< discontinuities in SEQ
  uint32_t seq_lost = 0;         ///< frames missing according to SEQ
  uint32_t timeouts = 0;         ///< partial frames dropped after kPartialTimeoutUs of silence
};

/// Streaming decoder: feed bytes as they arrive, frames come out through a sink `void(const Frame&)`.
///
/// On any failure it discards one byte and rescans from the next SYNC0, so a real frame
/// that starts inside a corrupt one is still found. Uses kMaxFrame bytes of state, no heap.
class FrameDecoder {
 public:
  FrameDecoder() = default;
  /// With `deliver_unknown`, CRC-valid frames of an unknown TYPE also reach the sink (they are
  /// still counted in unknown_type and bytes_skipped), so a device can NACK them.
  explicit FrameDecoder(bool deliver_unknown) : deliver_unknown_(deliver_unknown) {}

  /// Feeds one byte received at `now_us` (a free-running microsecond clock that may wrap).
  template <class Sink>
  void feed(uint8_t byte, uint32_t now_us, Sink&& sink) {
    poll(now_us, sink);
    last_us_ = now_us;
    buf_[n_++] = byte;
    scan(false, sink);
  }

  template <class Sink>
  void feed(const uint8_t* data, size_t n, uint32_t now_us, Sink&& sink) {
    for (size_t i = 0; i < n; ++i) feed(data[i], now_us, sink);
  }

  /// Drops a partial frame after kPartialTimeoutUs of silence, delivering any complete frame
  /// that was waiting behind it.
  template <class Sink>
  void poll(uint32_t now_us, Sink&& sink) {
    if (n_ == 0 || static_cast<uint32_t>(now_us - last_us_) < kPartialTimeoutUs) return;
    ++counters_.timeouts;
    scan(true, sink);
  }

  const DecoderCounters& counters() const noexcept { return counters_; }
  size_t pending() const noexcept { return n_; }

 private:
  void drop(size_t k) noexcept {
    std::memmove(buf_.data(), buf_.data() + k, n_ - k);
    n_ -= k;
  }
  void skip(size_t k) noexcept {
    counters_.bytes_skipped += static_cast<uint32_t>(k);
    drop(k);
  }

  // One pass over the buffer; `final` treats an incomplete candidate as failed.
  template <class Sink>
  void scan(bool final, Sink& sink) {
    while (n_ > 0) {
      if (buf_[0] != kSync0) {
        size_t k = 1;
        while (k < n_ && buf_[k] != kSync0) ++k;
        skip(k);
        continue;
      }
      if (n_ < 2) break;
      if (buf_[1] != kSync1) {
        skip(1);
        continue;
      }
      if (n_ < 3) break;
      if (buf_[2] != kProtocolVersion) {
        ++counters_.unknown_version;
        skip(1);
        continue;
      }
      if (n_ < kHeaderSize) break;
      const size_t len = buf_[5];
      if (len > kMaxPayload) {
        ++counters_.oversize;
        skip(1);
        continue;
      }
      const size_t total = kHeaderSize + len + kCrcSize;
      if (n_ < total) break;
      uint32_t crc = 0;
      wire::get(buf_.data() + kHeaderSize + len, crc);
      if (crc32c(buf_.data() + 2, 4 + len) != crc) {
        ++counters_.crc_errors;
        skip(1);
        continue;
      }
      const uint8_t type = buf_[3];
      const uint8_t seq = buf_[4];
      if (have_seq_ && seq != static_cast<uint8_t>(last_seq_ + 1)) {
        ++counters_.seq_gaps;
        counters_.seq_lost += static_cast<uint8_t>(seq - static_cast<uint8_t>(last_seq_ + 1));
      }
      have_seq_ = true;
      last_seq_ = seq;
      if (!is_known_type(type)) {
        ++counters_.unknown_type;
        if (deliver_unknown_) {
          sink(Frame{type, seq, static_cast<uint8_t>(len), buf_.data() + kHeaderSize, crc});
        }
        skip(total);
        continue;
      }
      ++counters_.frames_ok;
      sink(Frame{type, seq, static_cast<uint8_t>(len), buf_.data() + kHeaderSize, crc});
      drop(total);
    }
    if (final) {
      while (n_ > 0) {  // everything left is an incomplete candidate: fail it and rescan
        skip(1);
        scan(false, sink);
      }
    }
  }

  std::array<uint8_t, kMaxFrame> buf_{};
  size_t n_ = 0;
  uint32_t last_us_ = 0;
  bool have_seq_ = false;
  uint8_t last_seq_ = 0;
  bool deliver_unknown_ = false;
  DecoderCounters counters_{};
};

}  // namespace jackson::protocol
