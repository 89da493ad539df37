// Cumulative wheel counts from the PCNT's 16-bit counter and its limit events.
#pragma once

#include <cstdint>

#include "hal.hpp"

namespace jackson::fw {

/// One wheel: PCNT (count, limit events) -> cumulative int32 count with a direction flag and a
/// software zero offset. Counts wrap modulo 2^32, as the host's differencing expects.
class EncoderAccumulator {
 public:
  /// Updates from a PCNT sample and returns the cumulative count.
  int32_t update(const PcntSample& s, int16_t limit) noexcept {
    if (s.limit_events != last_events_) {
      overflow_flag_ = true;
      overflows_ += static_cast<uint32_t>(s.limit_events - last_events_ >= 0
                                              ? s.limit_events - last_events_
                                              : last_events_ - s.limit_events);
      last_events_ = s.limit_events;
    }
    // unsigned arithmetic: well-defined wrap modulo 2^32
    raw_ = static_cast<uint32_t>(s.limit_events) * static_cast<uint32_t>(static_cast<int32_t>(limit)) +
           static_cast<uint32_t>(static_cast<int32_t>(s.count));
    return value();
  }

  /// The count with direction and offset applied (as of the last update).
  int32_t value() const noexcept {
    const uint32_t signed_raw = inverted_ ? 0u - raw_ : raw_;
    return static_cast<int32_t>(signed_raw - offset_);
  }

  /// Makes the current position read 0 (ZERO_COUNTERS).
  void zero() noexcept { offset_ = inverted_ ? 0u - raw_ : raw_; }

  /// Inverting a wheel re-zeroes it, so the count never jumps by twice its value.
  void set_inverted(bool inverted) noexcept {
    if (inverted != inverted_) {
      inverted_ = inverted;
      zero();
    }
  }
  bool inverted() const noexcept { return inverted_; }

  /// True once after any limit event since the previous call.
  bool take_overflow_flag() noexcept {
    const bool f = overflow_flag_;
    overflow_flag_ = false;
    return f;
  }
  uint32_t overflows() const noexcept { return overflows_; }

 private:
  uint32_t raw_ = 0;
  uint32_t offset_ = 0;
  int32_t last_events_ = 0;
  uint32_t overflows_ = 0;
  bool inverted_ = false;
  bool overflow_flag_ = false;
};

}  // namespace jackson::fw
