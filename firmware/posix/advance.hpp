// Running the firmware core on a clock someone else sets (the twin's): every deadline on the
// way to an instant, each at its own time, as the board's loop would run them.
#pragma once

#include <cstdint>

#include "firmware.hpp"
#include "posix_hal.hpp"

namespace jackson::fw::posix {

/// Runs tick() at every deadline of the core strictly before `t`, then sets the clock to `t`
/// without ticking there (the caller hands over what arrived at `t`, then ticks).
inline void advance_before(Firmware& fw, FeedClock& clock, uint64_t t) {
  uint64_t cur = clock.now64();
  while (cur < t) {
    const uint32_t deadline = fw.next_deadline();
    const int32_t ahead = static_cast<int32_t>(deadline - static_cast<uint32_t>(cur));
    if (ahead <= 0 || cur + static_cast<uint64_t>(ahead) >= t) break;
    cur += static_cast<uint64_t>(ahead);
    clock.set(cur);
    fw.tick();
  }
  clock.set(t);
}

}  // namespace jackson::fw::posix
