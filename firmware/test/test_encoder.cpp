// Encoder accumulation: PCNT limits, direction flags, zero offsets, int32 wrap.
#include <gtest/gtest.h>

#include "encoder.hpp"
#include "fakes.hpp"

using jackson::fw::EncoderAccumulator;
using jackson::fw::PcntSample;
using jackson::fw::test::FakeEncoders;

namespace {
int32_t feed(EncoderAccumulator& acc, FakeEncoders& enc, int64_t total) {
  enc.set_total(total, 0);
  return acc.update(enc.l, enc.lim);
}
}  // namespace

TEST(Encoder, CountsBelowTheLimitPassThrough) {
  EncoderAccumulator acc;
  FakeEncoders enc;
  EXPECT_EQ(feed(acc, enc, 1234), 1234);
  EXPECT_EQ(feed(acc, enc, -29999), -29999);
  EXPECT_FALSE(acc.take_overflow_flag());
}

TEST(Encoder, LimitEventsAccumulateIntoInt32) {
  EncoderAccumulator acc;
  FakeEncoders enc;
  for (int64_t total : {29999LL, 30000LL, 30001LL, 95000LL, 1000000LL, -1000000LL, -30000LL}) {
    EXPECT_EQ(feed(acc, enc, total), total);
  }
  EXPECT_TRUE(acc.take_overflow_flag());
  EXPECT_FALSE(acc.take_overflow_flag());
}

TEST(Encoder, ThePcntResetIsNotACountJump) {
  // hardware view: count runs up to 29999, the unit resets to 0 and the ISR counts one event
  EncoderAccumulator acc;
  EXPECT_EQ(acc.update(PcntSample{29999, 0}, 30000), 29999);
  EXPECT_EQ(acc.update(PcntSample{0, 1}, 30000), 30000);
  EXPECT_EQ(acc.update(PcntSample{5, 1}, 30000), 30005);
  EXPECT_EQ(acc.overflows(), 1u);
}

TEST(Encoder, CumulativeCountWrapsModulo2To32) {
  EncoderAccumulator acc;
  const int32_t events = 2147483647 / 30000 + 1;  // just past INT32_MAX
  const int32_t v = acc.update(PcntSample{0, events}, 30000);
  EXPECT_LT(v, 0);  // wrapped, as the host's wrap-safe differencing expects
  EXPECT_EQ(static_cast<uint32_t>(v), static_cast<uint32_t>(events) * 30000u);
}

TEST(Encoder, DirectionFlagInvertsTheCount) {
  EncoderAccumulator acc;
  FakeEncoders enc;
  acc.set_inverted(true);
  EXPECT_EQ(feed(acc, enc, 500), -500);
  EXPECT_EQ(feed(acc, enc, 700), -700);
}

TEST(Encoder, InvertingReZeroesSoTheCountDoesNotJump) {
  EncoderAccumulator acc;
  FakeEncoders enc;
  EXPECT_EQ(feed(acc, enc, 500), 500);
  acc.set_inverted(true);
  EXPECT_EQ(acc.value(), 0);
  EXPECT_EQ(feed(acc, enc, 510), -10);
}

TEST(Encoder, ZeroIsASoftwareOffset) {
  EncoderAccumulator acc;
  FakeEncoders enc;
  feed(acc, enc, 123456);
  acc.zero();
  EXPECT_EQ(acc.value(), 0);
  EXPECT_EQ(feed(acc, enc, 123466), 10);
  EXPECT_EQ(feed(acc, enc, 123400), -56);
}
