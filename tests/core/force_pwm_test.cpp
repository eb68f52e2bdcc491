#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <cstdint>

#include "thrustcal/force_pwm.hpp"

namespace {

using tc::ForcePwmLimits;
using tc::MotorCalibration;

// pwm(g) = base + g - 1 up to max_grams.
void fill(tc::ForceCurveBase& curve, uint16_t start_mv, uint16_t pwm_at_1g_us, uint16_t max_grams) {
  curve.start_mv = start_mv;
  curve.pwm_at_1g_us = pwm_at_1g_us;
  for (uint16_t i = 0; i < curve.stepCount(); ++i) curve.steps()[i] = (i + 1u < max_grams) ? 1 : tc::kUnreachable;
  ASSERT_TRUE(curve.finalize());
}

// First curve at 12.0 V: pwm = 1099 + F. Second curve at 11.0 V: 100 us more for every force.
MotorCalibration twoCurves(uint16_t second_start_mv = 11000, uint16_t second_max_grams = 300) {
  MotorCalibration cal;
  fill(cal.first, 12000, 1100, 300);
  fill(cal.second, second_start_mv, 1200, second_max_grams);
  return cal;
}

struct Row {
  uint16_t force_g;
  uint16_t vbat_mv;
  uint16_t pwm_us;
  uint8_t flags;
  const char* what;
};

void expectRows(const MotorCalibration& cal, const Row* rows, size_t n, const ForcePwmLimits& limits = ForcePwmLimits()) {
  for (size_t i = 0; i < n; ++i) {
    const auto& r = rows[i];
    const tc::ForcePwmResult result = tc::forceToPwm(cal, r.force_g, r.vbat_mv, limits);
    EXPECT_EQ(result.pwm_us, r.pwm_us) << r.what;
    EXPECT_EQ(result.flags, r.flags) << r.what;
  }
}

TEST(ForcePwm, InterpolatesLinearlyInVoltageBetweenTheTwoCurvesOption21) {
  // PWM = c1(F) + (V - V1) * (c2(F) - c1(F)) / (V2 - V1), V1 = 12000, V2 = 11000, c2 - c1 = 100
  const Row rows[] = {
      {100, 12000, 1199, 0, "at V1: first curve"},
      {100, 11000, 1299, 0, "at V2: second curve"},
      {100, 11500, 1249, 0, "half way"},
      {100, 13000, 1099, 0, "above V1: extrapolated down"},
      {100, 10000, 1399, 0, "below V2: extrapolated up"},
      {100, 11999, 1199, 0, "0.1 us rounds to 0"},
      {100, 11995, 1200, 0, "0.5 us rounds away from zero"},
      {100, 12005, 1198, 0, "-0.5 us rounds away from zero"},
      {1, 11750, 1125, 0, "lightest gram"},
      {300, 11250, 1474, 0, "heaviest gram"},
  };
  expectRows(twoCurves(), rows, sizeof rows / sizeof rows[0]);
}

// Decigrams (the force API's unit): between two grams each curve's straight line, then option 2.1
// rounded once; at whole grams the rows above.
TEST(ForcePwm, DecigramsFollowEachCurvesStraightLineBetweenGramsRoundedOnce) {
  const MotorCalibration cal = twoCurves();
  struct DgRow {
    uint16_t force_dg, vbat_mv, pwm_us;
    uint8_t flags;
    const char* what;
  };
  const DgRow rows[] = {
      {1000, 11500, 1249, 0, "a whole gram: as forceToPwm"},
      {1005, 12000, 1200, 0, "c1 1199.5 at V1 rounds away from zero"},
      {1004, 12000, 1199, 0, "c1 1199.4"},
      {1004, 11500, 1249, 0, "1249.4"},
      {1006, 11500, 1250, 0, "1249.6"},
      {1005, 11000, 1300, 0, "c2 1299.5"},
      {5, 12000, 1100, 0, "below the first gram: the first gram's pulse"},
      {3005, 12000, 1399, tc::kSaturated, "beyond the heaviest gram"},
      {0, 12000, 1000, tc::kStopped, "0 dg stops"},
  };
  for (const DgRow& r : rows) {
    const tc::ForcePwmResult result = tc::forceToPwmDg(cal, r.force_dg, r.vbat_mv);
    EXPECT_EQ(result.pwm_us, r.pwm_us) << r.what;
    EXPECT_EQ(result.flags, r.flags) << r.what;
  }
}

// Against option 2.1 in double precision on the curves' straight lines, every decigram of a
// curved record at voltages around and between the curves', where the exact value is not within
// 1e-6 us of a half (there the two roundings may differ only by the double's own error).
TEST(ForcePwm, DecigramsAreOption21OnTheStraightLinesInDoublePrecision) {
  MotorCalibration cal;
  for (tc::ForceCurveBase* c : {static_cast<tc::ForceCurveBase*>(&cal.first), static_cast<tc::ForceCurveBase*>(&cal.second)}) {
    const bool first = c == &cal.first;
    c->start_mv = first ? 12400 : 10900;
    c->pwm_at_1g_us = first ? 1110 : 1125;
    for (uint16_t i = 0; i < c->stepCount(); ++i)  // steps 3, 2, ..., down to 0 and 1: a curve
      c->steps()[i] = i + 1u < 400 ? static_cast<uint8_t>((first ? 3 : 4) * 60 / (i + 60)) : tc::kUnreachable;
    ASSERT_TRUE(c->finalize());
  }
  long compared = 0;
  for (uint16_t mv : {9000, 10900, 11337, 12400, 13100}) {
    for (uint16_t dg = 10; dg <= 3990; ++dg) {
      const double g = dg / 10.0;
      const auto line = [&](const tc::ForceCurveBase& c) {
        const uint16_t lo = static_cast<uint16_t>(g);
        const double frac = g - lo;
        return c.pwmForGrams(lo) + frac * (c.pwmForGrams(static_cast<uint16_t>(lo + 1)) - c.pwmForGrams(lo));
      };
      const double c1 = line(cal.first), c2 = line(cal.second);
      const double exact = c1 + (mv - 12400.0) * (c2 - c1) / (10900.0 - 12400.0);
      if (std::fabs(exact - std::floor(exact) - 0.5) < 1e-6) continue;
      const long want = std::lround(exact);
      ASSERT_EQ(tc::forceToPwmDg(cal, dg, mv).pwm_us, want) << dg << " dg at " << mv << " mV";
      ++compared;
    }
  }
  EXPECT_GT(compared, 19000);
}

TEST(ForcePwm, ZeroForceStopsTheMotor) {
  const Row rows[] = {{0, 11500, 1000, tc::kStopped, "F = 0"}};
  expectRows(twoCurves(), rows, 1);
}

TEST(ForcePwm, UncalibratedMotorStaysAtMinimumPwm) {
  const MotorCalibration none;
  const Row rows[] = {{100, 11500, 1000, tc::kNotCalibrated, "no first curve"},
                      {0, 11500, 1000, tc::kNotCalibrated | tc::kStopped, "no curve and F = 0"}};
  expectRows(none, rows, 2);
  MotorCalibration empty;
  empty.first.start_mv = 12000;  // a start voltage but not a single gram
  const Row empty_rows[] = {{100, 11500, 1000, tc::kNotCalibrated, "first curve without grams"}};
  expectRows(empty, empty_rows, 1);
}

TEST(ForcePwm, ForceBeyondTheCurveSaturatesAtItsHeaviestGram) {
  const Row rows[] = {
      {400, 11500, 1449, tc::kSaturated, "beyond both curves: both at 300 g"},
      {65535, 12000, 1399, tc::kSaturated, "largest command"},
  };
  expectRows(twoCurves(), rows, 2);
  // second curve shorter than the first: 250 g is on the first, beyond the second (max 200)
  const Row short_rows[] = {{250, 11000, 1399, tc::kSaturated, "second curve saturated at 200 g"}};
  expectRows(twoCurves(11000, 200), short_rows, 1);
}

TEST(ForcePwm, VoltageOutsideTheSaneRangeUsesTheFirstCurveAlone) {
  const Row rows[] = {
      {100, 5999, 1199, tc::kVoltageInvalid, "below 6 V: sensor fault"},
      {100, 0, 1199, tc::kVoltageInvalid, "0 V: divider unplugged"},
      {100, 17501, 1199, tc::kVoltageInvalid, "above 17.5 V"},
      {100, 6000, 1799, 0, "6 V is sane: 1199 + (6000 - 12000) * 100 / -1000"},
      {100, 17500, 1000, tc::kClamped, "17.5 V is sane: 1199 - 550 = 649, clamped"},
  };
  expectRows(twoCurves(), rows, sizeof rows / sizeof rows[0]);
}

TEST(ForcePwm, MissingSecondCurveUsesTheFirstCurveAlone) {
  MotorCalibration cal = twoCurves();
  cal.second.clear();
  const Row rows[] = {{100, 11000, 1199, tc::kSingleCurve, "no second curve"},
                      {400, 11000, 1399, tc::kSingleCurve | tc::kSaturated, "and beyond the curve"}};
  expectRows(cal, rows, 2);
  MotorCalibration empty_second = twoCurves();
  empty_second.second.pwm_at_1g_us = 0;
  empty_second.second.finalize();
  expectRows(empty_second, rows, 1);
}

TEST(ForcePwm, StartVoltagesCloserThanTheMinimumSpanUseTheFirstCurveAlone) {
  const Row close_rows[] = {{100, 11000, 1199, tc::kEqualVoltages, "99 mV apart"}};
  expectRows(twoCurves(12099), close_rows, 1);
  expectRows(twoCurves(11901), close_rows, 1);
  const Row equal_rows[] = {{100, 11000, 1199, tc::kEqualVoltages, "equal: no division by zero"}};
  expectRows(twoCurves(12000), equal_rows, 1);
  // exactly the minimum span interpolates: 1199 + 50 * 100 / 100
  const Row span_rows[] = {{100, 12050, 1249, 0, "100 mV apart"}};
  expectRows(twoCurves(12100), span_rows, 1);
}

TEST(ForcePwm, ResultIsClampedToTheEscRange) {
  const Row rows[] = {
      {100, 9000, 1499, 0, "inside"},
      {100, 6500, 1749, 0, "still inside"},
  };
  expectRows(twoCurves(), rows, 2);
  ForcePwmLimits narrow;
  narrow.pwm_min_us = 1150;
  narrow.pwm_max_us = 1300;
  const Row narrow_rows[] = {
      {10, 12000, 1150, tc::kClamped, "below the minimum"},
      {200, 11000, 1300, tc::kClamped, "above the maximum"},
      {10, 5000, 1150, tc::kClamped | tc::kVoltageInvalid, "single-curve path is clamped too"},
      {100, 12000, 1199, 0, "inside"},
  };
  expectRows(twoCurves(), narrow_rows, 4, narrow);
  // a first curve running past 2000 us
  MotorCalibration high;
  fill(high.first, 12000, 1900, 300);
  const Row high_rows[] = {{200, 12000, 2000, tc::kClamped | tc::kSingleCurve, "2099 us clamped"}};
  expectRows(high, high_rows, 1);
}

TEST(ForcePwm, ExtremeVoltagesAndCurvesDoNotOverflow) {
  // given sane-looking limits opened to the whole uint16 range and curves 1000 us apart
  ForcePwmLimits open;
  open.v_min_mv = 0;
  open.v_max_mv = 65535;
  open.pwm_min_us = 0;
  open.pwm_max_us = 65535;
  MotorCalibration cal;
  fill(cal.first, 65535, 500, 10);
  fill(cal.second, 65435, 1500, 10);
  // when V is 65535 mV below V1: 500 + (-65535) * 1000 / -100 = 655850 -> clamped
  const tc::ForcePwmResult r = tc::forceToPwm(cal, 1, 0, open);
  // then
  EXPECT_EQ(r.pwm_us, 65535);
  EXPECT_EQ(r.flags, tc::kClamped);
}

}  // namespace

// Option 2.1's rounded division (the short long division for small quotients, the library's
// beyond) against the definition: the truncated quotient, one more in magnitude when twice the
// remainder reaches the divisor.
TEST(ForcePwm, RoundedDivisionIsTheNearestQuotientHalvesAwayFromZero) {
  const auto want = [](int64_t num, int64_t den) {
    int64_t q = num / den;
    const int64_t r = num % den;
    if (2 * (r < 0 ? -r : r) >= (den < 0 ? -den : den)) q += (num < 0) != (den < 0) ? -1 : 1;
    return q;
  };
  uint32_t x = 7;
  long compared = 0;
  for (int i = 0; i < 400000; ++i) {
    x = x * 1664525u + 1013904223u;
    const int shift = static_cast<int>(x >> 27);                         // every magnitude
    int32_t num = static_cast<int32_t>(x * 2654435761u) >> (shift & 31);
    if (num == INT32_MIN) num = INT32_MAX;
    int32_t den = static_cast<int32_t>((x >> 5) & 0x1FFFF) >> ((x >> 3) & 15);  // up to 2^17
    if (den == 0) den = 1;
    if (x & 1u) den = -den;
    ASSERT_EQ(tc::force_pwm_detail::divRound(num, den), want(num, den)) << num << " / " << den;
    ++compared;
  }
  for (int32_t den : {1, 2, 3, 1900, -1900, 65535, 65536, -65535})
    for (int32_t num = -600 * 256; num <= 600 * 256; num += 7)
      ASSERT_EQ(tc::force_pwm_detail::divRound(num, den), want(num, den)) << num << " / " << den;
  EXPECT_EQ(compared, 400000);
}
