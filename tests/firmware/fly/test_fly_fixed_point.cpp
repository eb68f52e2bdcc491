// fly's fixed point (fixed_point.hpp) against exact 64-bit arithmetic: the shifts, applyGain's
// rounding for every shift a gain can have, and gainOf's choice of mantissa and shift.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>

#include "fixed_point.hpp"

namespace {

using namespace fly;

// floor((v m + 2^(s-1)) / 2^s), exactly.
int64_t exactGain(int32_t v, int16_t m, uint8_t s) {
  const int64_t p = static_cast<int64_t>(v) * m;
  return s == 0 ? p : (p + (int64_t{1} << (s - 1))) >> s;
}

TEST(FixedPoint, ShiftsAreTheShiftsBitForBit) {
  std::mt19937 rng(3);
  for (int k = 0; k < 20000; ++k) {
    const int32_t v = static_cast<int32_t>(rng());
    const uint8_t n = static_cast<uint8_t>(rng() % 32);
    ASSERT_EQ(shiftRight(v, n), v >> n) << v << " >> " << int(n);
    ASSERT_EQ(shiftLeft(static_cast<uint32_t>(v), n), static_cast<uint32_t>(v) << n);
    if (n >= 1) {
      ASSERT_EQ(roundedShiftRight(v, n), (static_cast<int64_t>(v) + (int64_t{1} << (n - 1))) >> n);
    }
  }
}

TEST(FixedPoint, ApplyGainRoundsTheExactProductHalfUpForEveryShift) {
  std::mt19937 rng(5);
  int compared = 0;
  for (uint8_t s = 0; s <= kMaxGainShift; ++s) {
    for (int k = 0; k < 4000; ++k) {
      const int16_t m = static_cast<int16_t>(rng());
      const int32_t v = static_cast<int32_t>(rng()) >> (rng() % 31);  // every magnitude
      const int64_t want = exactGain(v, m, s);
      if (want > (int64_t{1} << 30) || want < -(int64_t{1} << 30)) continue;  // beyond fly's values
      ASSERT_EQ(applyGain(v, Gain{m, s}), want) << v << " * " << m << " / 2^" << int(s);
      ++compared;
    }
    // the halves: v m exactly (2j + 1) 2^(s-1) rounds up
    if (s >= 1 && s <= 30) {
      const int32_t v = static_cast<int32_t>(int64_t{3} << (s - 1));
      EXPECT_EQ(applyGain(v, Gain{1, s}), 2);
      EXPECT_EQ(applyGain(-v, Gain{1, s}), -1);
    }
  }
  EXPECT_GT(compared, 100000);
}

TEST(FixedPoint, GainOfKeepsSixteenSignificantBits) {
  for (float g : {1e-9f, 3.3e-7f, 0.0014f, 0.8f, 1.0f, 123.456f, 32767.0f, -0.146f, -5e-5f}) {
    const Gain q = gainOf(g);
    EXPECT_NEAR(gainValue(q), g, std::fabs(g) * (1.0 / 16384)) << g;
    EXPECT_GE(std::abs(q.m), 16384) << g;  // the mantissa is used: at least 15 bits
  }
  EXPECT_EQ(gainOf(0.0f).m, 0);
  EXPECT_EQ(gainOf(1e30f).m, 32767);
  EXPECT_EQ(gainOf(1e30f).s, 0);
}

}  // namespace
