// Randomised decoder test, run under ASan and UBSan by `make test` (bounded: about a second).
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "jackson/protocol/frame.hpp"

namespace jp = jackson::protocol;

namespace {

std::vector<uint8_t> random_bytes(std::mt19937& rng, size_t n, bool sync_rich) {
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> pick(0, 9);
  std::vector<uint8_t> out(n);
  for (auto& b : out) {
    const int p = pick(rng);
    // Bias towards the bytes that steer the decoder: SYNC0, SYNC1, VER and big lengths.
    b = static_cast<uint8_t>(sync_rich && p < 2   ? 0xA5
                             : sync_rich && p < 3 ? 0x5A
                             : sync_rich && p < 4 ? 0x01
                                                  : byte(rng));
  }
  return out;
}

std::vector<uint8_t> telemetry_frame(uint8_t seq, int32_t left) {
  jp::Telemetry t;
  t.t_us = 1000u * seq;
  t.enc_left = left;
  t.enc_right = -left;
  std::vector<uint8_t> out(jp::kMaxFrame);
  out.resize(jp::encode_frame(t, seq, out.data(), out.size()));
  return out;
}

}  // namespace

TEST(Fuzz, RandomBytesNeverBreakTheInvariants) {
  std::mt19937 rng(12345);
  std::uniform_int_distribution<size_t> len(0, 600);
  std::uniform_int_distribution<int> chunk(1, 64);
  for (int iter = 0; iter < 3000; ++iter) {
    const auto data = random_bytes(rng, len(rng), iter % 2 == 0);
    jp::FrameDecoder dec;
    size_t delivered_bytes = 0;
    auto sink = [&](const jp::Frame& f) {
      ASSERT_LE(f.len, jp::kMaxPayload);
      ASSERT_TRUE(jp::is_known_type(f.type));
      delivered_bytes += jp::kHeaderSize + f.len + jp::kCrcSize;
    };
    size_t i = 0;
    uint32_t now = 0;
    while (i < data.size()) {
      const size_t k = std::min(data.size() - i, static_cast<size_t>(chunk(rng)));
      dec.feed(data.data() + i, k, now, sink);
      i += k;
      now += 100;
    }
    const auto& c = dec.counters();
    ASSERT_EQ(c.bytes_skipped + delivered_bytes + dec.pending(), data.size());
    dec.poll(now + jp::kPartialTimeoutUs, sink);
    ASSERT_EQ(dec.pending(), 0u);
    ASSERT_EQ(dec.counters().bytes_skipped + delivered_bytes, data.size());
  }
}

TEST(Fuzz, AFrameEmbeddedInNoiseIsFound) {
  std::mt19937 rng(777);
  std::uniform_int_distribution<size_t> len(0, 300);
  int found_all = 0;
  const int iterations = 3000;
  for (int iter = 0; iter < iterations; ++iter) {
    const auto before = random_bytes(rng, len(rng), true);
    const auto after = random_bytes(rng, len(rng), true);
    const auto frame = telemetry_frame(static_cast<uint8_t>(iter), iter * 7);
    std::vector<uint8_t> data = before;
    data.insert(data.end(), frame.begin(), frame.end());
    data.insert(data.end(), after.begin(), after.end());
    jp::FrameDecoder dec;
    bool found = false;
    auto sink = [&](const jp::Frame& f) {
      jp::Telemetry t;
      if (f.as(t) && t.enc_left == iter * 7 && t.enc_right == -iter * 7 &&
          t.t_us == 1000u * static_cast<uint8_t>(iter)) {
        found = true;
      }
    };
    dec.feed(data.data(), data.size(), 0, sink);
    dec.poll(jp::kPartialTimeoutUs, sink);
    found_all += found ? 1 : 0;
  }
  EXPECT_EQ(found_all, iterations);
}

TEST(Fuzz, CorruptedStreamsLoseOnlyTheCorruptedFrames) {
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int iter = 0; iter < 200; ++iter) {
    std::vector<uint8_t> data;
    for (int k = 0; k < 50; ++k) {
      const auto f = telemetry_frame(static_cast<uint8_t>(k), k);
      data.insert(data.end(), f.begin(), f.end());
    }
    // corrupt one byte in each of frames 10, 20, 30, 40
    for (int k : {10, 20, 30, 40}) {
      const size_t at = static_cast<size_t>(k) * 38 + 6 + static_cast<size_t>(byte(rng) % 28);
      data[at] = static_cast<uint8_t>(data[at] ^ (1 + byte(rng) % 255));
    }
    jp::FrameDecoder dec;
    int frames = 0;
    dec.feed(data.data(), data.size(), 0, [&](const jp::Frame&) { ++frames; });
    EXPECT_EQ(frames, 46);
    EXPECT_EQ(dec.counters().crc_errors, 4u);
    EXPECT_EQ(dec.counters().seq_gaps, 4u);
    EXPECT_EQ(dec.counters().seq_lost, 4u);
  }
}
