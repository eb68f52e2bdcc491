#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "thrustcal/curve_builder.hpp"

namespace {

using tc::BuildReport;
using tc::BuildStatus;
using tc::CurveBuilder;
using tc::ForceCurve;
using tc::ThesisCurve;

// A clean motor: no thrust below 1080 us, 500 g at 1680 us, quadratic in between.
constexpr double kIdleUs = 1080.0;
constexpr double kDgPerUs2 = 5000.0 / (600.0 * 600.0);

double forceDg(double pwm_us) {
  return pwm_us <= kIdleUs ? 0.0 : kDgPerUs2 * (pwm_us - kIdleUs) * (pwm_us - kIdleUs);
}
double pwmForDg(double force_dg) { return force_dg <= 0 ? kIdleUs : kIdleUs + std::sqrt(force_dg / kDgPerUs2); }

// Lowest PWM a fitted force of `force_dg` can sit at: below zero force it is the sweep start.
double lowestPwmForDg(double force_dg) { return force_dg <= 0 ? 1000.0 : pwmForDg(force_dg); }

int16_t roundDg(double dg) { return static_cast<int16_t>(std::lround(dg)); }

template <uint16_t N>
void addQuadraticSweep(CurveBuilder<N>& builder, uint16_t from_us, uint16_t to_us, uint16_t step_us) {
  for (uint32_t pwm = from_us; pwm <= to_us; pwm += step_us)
    ASSERT_TRUE(builder.add(static_cast<uint16_t>(pwm), roundDg(forceDg(pwm))));
}

void expectMonotone(const tc::ForceCurveBase& curve) {
  for (uint16_t g = 2; g <= curve.maxGrams(); ++g)
    ASSERT_GE(curve.pwmForGrams(g), curve.pwmForGrams(g - 1)) << "curve goes backwards at " << g << " g";
}

TEST(CurveBuilder, CleanQuadraticSweepInvertsWithinOneMicrosecond) {
  // given a thesis-like sweep 1000..1700 us in 4 us steps
  CurveBuilder<256> builder;
  addQuadraticSweep(builder, 1000, 1700, 4);
  ThesisCurve curve;
  // when
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  // then
  ASSERT_EQ(report.status, BuildStatus::kOk);
  EXPECT_EQ(report.samples_used, 176);
  EXPECT_EQ(report.violations, 0);
  EXPECT_EQ(report.max_force_dg, roundDg(forceDg(1700)));
  EXPECT_EQ(report.max_grams, 500) << "the thesis curve holds 500 g even though the sweep reached 533 g";
  EXPECT_EQ(curve.maxGrams(), 500);
  for (uint16_t g = 1; g <= 500; ++g)
    ASSERT_NEAR(curve.pwmForGrams(g), pwmForDg(10.0 * g), 1.0) << g << " g";
}

TEST(CurveBuilder, StartVoltageIsLeftToTheCaller) {
  CurveBuilder<256> builder;
  addQuadraticSweep(builder, 1000, 1700, 4);
  ThesisCurve curve;
  curve.start_mv = 11800;
  ASSERT_EQ(builder.build(curve).status, BuildStatus::kOk);
  EXPECT_EQ(curve.start_mv, 11800);
  ThesisCurve fresh;
  ASSERT_EQ(builder.build(fresh).status, BuildStatus::kOk);
  EXPECT_EQ(fresh.start_mv, 0);
  EXPECT_EQ(fresh.maxGrams(), 0) << "absent until the caller sets the start voltage";
  fresh.start_mv = 11800;
  EXPECT_EQ(fresh.maxGrams(), 500);
}

TEST(CurveBuilder, NoisySweepGivesAMonotoneCurveInsideTheNoiseBand) {
  struct Row {
    uint32_t seed;
    int noise_dg;  // uniform +-noise on every sample
    uint16_t step_us;
  };
  const Row rows[] = {{1, 30, 2}, {2, 30, 5}, {3, 100, 2}, {4, 5, 1}};
  for (const auto& r : rows) {
    // given
    CurveBuilder<1024> builder;
    std::mt19937 rng(r.seed);
    std::uniform_int_distribution<int> noise(-r.noise_dg, r.noise_dg);
    for (uint32_t pwm = 1000; pwm <= 1700; pwm += r.step_us)
      ASSERT_TRUE(builder.add(static_cast<uint16_t>(pwm), static_cast<int16_t>(roundDg(forceDg(pwm)) + noise(rng))));
    ThesisCurve curve;
    // when
    const BuildReport report = builder.build(curve);
    curve.start_mv = 12000;
    // then
    ASSERT_EQ(report.status, BuildStatus::kOk) << r.seed;
    EXPECT_GT(report.violations, 0) << "noise makes raw data non-monotone";
    expectMonotone(curve);
    // The monotone fit of data within +-e of a monotone curve stays within +-e (plus 0.5 dg
    // rounding), so each gram's PWM lies between the inverses of F - e and F + e, +-1 us
    // rounding, minus one sweep step for the chord of the convex curve.
    for (uint16_t g = 1; g <= curve.maxGrams(); ++g) {
      const double lo = lowestPwmForDg(10.0 * g - r.noise_dg - 1.0) - 1.0 - r.step_us;
      const double hi = pwmForDg(10.0 * g + r.noise_dg + 1.0) + 1.0;
      ASSERT_GE(curve.pwmForGrams(g), lo) << "seed " << r.seed << " at " << g << " g";
      ASSERT_LE(curve.pwmForGrams(g), hi) << "seed " << r.seed << " at " << g << " g";
    }
  }
}

// The inversion carries its division from one gram to the next within a segment; every gram's
// PWM must be the one dividing at that gram gives: lo.pwm + round((target - lo.force) span_us /
// span_dg), halves up, on the fitted points the builder keeps. Sweeps with noise (pooled
// points), steps of 1..20 us, steep and flat segments, and a curve wider than int16 decigrams.
TEST(CurveBuilder, EachGramsPwmIsTheDivisionAtThatGramExactly) {
  int checked = 0;
  for (uint32_t seed = 1; seed <= 40; ++seed) {
    CurveBuilder<1024> builder;
    std::mt19937 rng(seed);
    const uint16_t step_us = static_cast<uint16_t>(1 + seed % 20);
    const int noise_dg = static_cast<int>(seed % 4) * 20;
    const double scale = seed % 5 == 0 ? 5.0 : 1.0;  // up to 2.5 kg: a span beyond int16 / 2
    std::uniform_int_distribution<int> noise(-noise_dg, noise_dg);
    for (uint32_t pwm = 1000; pwm <= 1800; pwm += step_us)
      ASSERT_TRUE(builder.add(static_cast<uint16_t>(pwm),
                              static_cast<int16_t>(std::min(32000.0, scale * forceDg(pwm)) + noise(rng))));
    ForceCurve<2000> curve;
    ASSERT_EQ(builder.build(curve).status, BuildStatus::kOk) << seed;
    curve.start_mv = 12000;
    uint16_t reach = 0;
    for (uint16_t g = 1; g <= curve.maxGrams(); ++g) {
      const int32_t target = 10 * g;
      while (builder.sample(reach).force_dg < target) ++reach;
      uint32_t want = builder.sample(reach).pwm_us;
      if (reach > 0) {
        const tc::SweepSample& lo = builder.sample(reach - 1);
        const tc::SweepSample& hi = builder.sample(reach);
        const uint32_t num = static_cast<uint32_t>(target - lo.force_dg) * (hi.pwm_us - lo.pwm_us);
        const uint32_t den = static_cast<uint32_t>(hi.force_dg - lo.force_dg);
        want = lo.pwm_us + num / den + (2 * (num % den) >= den ? 1 : 0);
      }
      ASSERT_EQ(curve.pwmForGrams(g), want) << "seed " << seed << " at " << g << " g";
      ++checked;
    }
  }
  EXPECT_GT(checked, 40 * 400);
}

TEST(CurveBuilder, NonMonotoneDataIsPooledToTheLeastSquaresMonotoneFit) {
  // given a dip at 1020 us: 0, 100, 50, 200 dg
  CurveBuilder<8> builder;
  builder.add(1000, 0);
  builder.add(1010, 100);
  builder.add(1020, 50);
  builder.add(1030, 200);
  ThesisCurve curve;
  // when
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  // then 100 and 50 are pooled to 75
  ASSERT_EQ(report.status, BuildStatus::kOk);
  EXPECT_EQ(report.violations, 2);
  EXPECT_EQ(builder.sample(1).force_dg, 75);
  EXPECT_EQ(builder.sample(2).force_dg, 75);
  struct Row {
    uint16_t grams, pwm_us;
  };
  const Row rows[] = {{1, 1001}, {7, 1009}, {8, 1020}, {20, 1030}};
  EXPECT_EQ(curve.maxGrams(), 20);
  for (const auto& r : rows) EXPECT_EQ(curve.pwmForGrams(r.grams), r.pwm_us) << r.grams;
}

TEST(CurveBuilder, ForceFallingAtTheTopOfTheSweepIsPooledNotReversed) {
  // given a motor whose thrust collapses after 1500 us (prop stall / supply current limit)
  CurveBuilder<512> builder;
  for (uint16_t pwm = 1000; pwm <= 1700; pwm += 2) {
    const double f = pwm <= 1500 ? forceDg(pwm) : forceDg(1500) - 3.0 * (pwm - 1500);
    builder.add(pwm, roundDg(f));
  }
  ThesisCurve curve;
  // when
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  // then
  ASSERT_EQ(report.status, BuildStatus::kOk);
  EXPECT_GT(report.violations, 90);
  expectMonotone(curve);
  EXPECT_LE(report.max_force_dg, roundDg(forceDg(1500)));
  EXPECT_LE(curve.pwmForGrams(curve.maxGrams()), 1700);
  EXPECT_NEAR(curve.pwmForGrams(100), pwmForDg(1000), 1.0) << "below the stall the curve is untouched";
}

TEST(CurveBuilder, UnsortedInputGivesTheSameCurveAsTheSortedSweep) {
  // given the same samples, ascending and shuffled
  CurveBuilder<256> sorted;
  CurveBuilder<256> shuffled;
  std::vector<uint16_t> pwms;
  for (uint16_t pwm = 1000; pwm <= 1700; pwm += 4) pwms.push_back(pwm);
  for (uint16_t pwm : pwms) sorted.add(pwm, roundDg(forceDg(pwm)));
  std::mt19937 rng(11);
  std::shuffle(pwms.begin(), pwms.end(), rng);
  for (uint16_t pwm : pwms) shuffled.add(pwm, roundDg(forceDg(pwm)));
  ThesisCurve a, b;
  // when
  ASSERT_EQ(sorted.build(a).status, BuildStatus::kOk);
  ASSERT_EQ(shuffled.build(b).status, BuildStatus::kOk);
  a.start_mv = b.start_mv = 12000;
  // then
  ASSERT_EQ(a.maxGrams(), b.maxGrams());
  for (uint16_t g = 1; g <= a.maxGrams(); ++g) ASSERT_EQ(a.pwmForGrams(g), b.pwmForGrams(g)) << g;
  for (uint16_t i = 1; i < shuffled.size(); ++i) EXPECT_LT(shuffled.sample(i - 1).pwm_us, shuffled.sample(i).pwm_us);
}

TEST(CurveBuilder, DuplicatePwmsAreMergedByAveraging) {
  // given two readings at 1010 us
  CurveBuilder<8> builder;
  builder.add(1000, 0);
  builder.add(1010, 100);
  builder.add(1020, 300);
  builder.add(1010, 200);
  ThesisCurve curve;
  // when
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  // then
  ASSERT_EQ(report.status, BuildStatus::kOk);
  EXPECT_EQ(report.samples_used, 3);
  EXPECT_EQ(builder.size(), 3);
  EXPECT_EQ(report.violations, 0);
  EXPECT_EQ(builder.sample(1).force_dg, 150);
  EXPECT_EQ(curve.pwmForGrams(15), 1010);
  EXPECT_EQ(curve.pwmForGrams(10), 1007);  // 1000 + 100 * 10 / 150 = 1006.7
}

TEST(CurveBuilder, MergedPwmsWeighTheFitByTheirSampleCount) {
  // given two readings of 300 dg at 1010 us, then one of 0 dg at 1020 us
  CurveBuilder<8> builder;
  builder.add(1000, 0);
  builder.add(1010, 300);
  builder.add(1010, 300);
  builder.add(1020, 0);
  ThesisCurve curve;
  // when
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  // then the pooled value is (300 + 300 + 0) / 3 = 200, not (300 + 0) / 2
  ASSERT_EQ(report.status, BuildStatus::kOk);
  EXPECT_EQ(report.max_force_dg, 200);
  EXPECT_EQ(report.violations, 2);
  EXPECT_EQ(curve.maxGrams(), 20);
  EXPECT_EQ(curve.pwmForGrams(20), 1010);
  EXPECT_EQ(curve.pwmForGrams(10), 1005);
}

TEST(CurveBuilder, FewerThanTwoDistinctPwmsIsTooFewSamples) {
  struct Row {
    std::vector<tc::SweepSample> samples;
    uint16_t used;
  };
  const Row rows[] = {{{}, 0}, {{{1500, 300}}, 1}, {{{1500, 300}, {1500, 310}, {1500, 290}}, 1}};
  for (const auto& r : rows) {
    // given a curve that was built before
    CurveBuilder<8> builder;
    for (const auto& s : r.samples) builder.add(s.pwm_us, s.force_dg);
    ThesisCurve curve;
    curve.start_mv = 12000;
    curve.pwm_at_1g_us = 1100;
    curve.finalize();
    // when
    const BuildReport report = builder.build(curve);
    // then it is absent
    EXPECT_EQ(report.status, BuildStatus::kTooFewSamples);
    EXPECT_EQ(report.samples_used, r.used);
    EXPECT_FALSE(curve.isPresent());
    EXPECT_EQ(curve.pwm_at_1g_us, 0);
  }
}

TEST(CurveBuilder, ForceThatNeverReachesOneGramIsNoForce) {
  // given a motor that never spins up (or an untared cell reading negative)
  for (int16_t top_dg : {0, 9, -50}) {
    CurveBuilder<8> builder;
    builder.add(1000, 0);
    builder.add(1500, top_dg);
    ThesisCurve curve;
    curve.start_mv = 12000;
    const BuildReport report = builder.build(curve);
    EXPECT_EQ(report.status, BuildStatus::kNoForce) << top_dg;
    EXPECT_FALSE(curve.isPresent());
  }
}

TEST(CurveBuilder, ExactlyOneGramIsACurveOfOneGram) {
  CurveBuilder<8> builder;
  builder.add(1000, 0);
  builder.add(1100, 10);
  ThesisCurve curve;
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  ASSERT_EQ(report.status, BuildStatus::kOk);
  EXPECT_EQ(curve.maxGrams(), 1);
  EXPECT_EQ(curve.pwmForGrams(1), 1100);
}

TEST(CurveBuilder, AGramStepOver254MicrosecondsIsTooSteep) {
  struct Row {
    uint16_t top_pwm_us;
    BuildStatus status;
  };
  // 0 g at 1000 us and 2 g at the top: 1 g at the middle, 2 g one half-span later
  const Row rows[] = {{1508, BuildStatus::kOk}, {1510, BuildStatus::kCurveTooSteep}};
  for (const auto& r : rows) {
    CurveBuilder<8> builder;
    builder.add(1000, 0);
    builder.add(r.top_pwm_us, 20);
    ThesisCurve curve;
    curve.start_mv = 12000;
    EXPECT_EQ(builder.build(curve).status, r.status) << r.top_pwm_us;
    EXPECT_EQ(curve.isPresent(), r.status == BuildStatus::kOk) << r.top_pwm_us;
  }
}

TEST(CurveBuilder, SmallCurveCapacityKeepsTheFirstGrams) {
  // given a full sweep into a 50 g curve
  CurveBuilder<256> builder;
  addQuadraticSweep(builder, 1000, 1700, 4);
  ForceCurve<50> curve;
  // when
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  // then
  ASSERT_EQ(report.status, BuildStatus::kOk);
  EXPECT_EQ(report.max_grams, 50);
  EXPECT_EQ(curve.maxGrams(), 50);
  for (uint16_t g = 1; g <= 50; ++g) ASSERT_NEAR(curve.pwmForGrams(g), pwmForDg(10.0 * g), 1.0) << g;
  EXPECT_EQ(curve.pwmForGrams(400), curve.pwmForGrams(50));
}

TEST(CurveBuilder, SampleBufferCapacityIsATemplateParameter) {
  // given
  CurveBuilder<4> builder;
  EXPECT_EQ(builder.capacity(), 4);
  for (uint16_t i = 0; i < 4; ++i) EXPECT_TRUE(builder.add(static_cast<uint16_t>(1000 + 100 * i), static_cast<int16_t>(100 * i)));
  // when the buffer is full
  const bool added = builder.add(1500, 500);
  // then the sample is dropped
  EXPECT_FALSE(added);
  EXPECT_EQ(builder.size(), 4);
  builder.reset();
  EXPECT_EQ(builder.size(), 0);
}

TEST(CurveBuilder, ForceAlreadyAboveOneGramAtTheFirstSampleStartsThere) {
  // given a sweep that starts with the motor already producing 5 g
  CurveBuilder<8> builder;
  builder.add(1200, 50);
  builder.add(1300, 150);
  ThesisCurve curve;
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  ASSERT_EQ(report.status, BuildStatus::kOk);
  for (uint16_t g = 1; g <= 5; ++g) EXPECT_EQ(curve.pwmForGrams(g), 1200) << g;
  EXPECT_EQ(curve.pwmForGrams(10), 1250);
  EXPECT_EQ(curve.pwmForGrams(15), 1300);
}

TEST(CurveBuilder, ForceSpanWiderThanInt16InterpolatesWithoutOverflow) {
  // given two samples 40000 dg apart (wider than a 16-bit int, which is AVR's int)
  CurveBuilder<4> builder;
  builder.add(1000, -20000);
  builder.add(1100, 20000);
  ForceCurve<2000> curve;
  // when
  const BuildReport report = builder.build(curve);
  curve.start_mv = 12000;
  // then 1 g is at 1000 + 20010 * 100 / 40000 = 1050.0 us and 2000 g at the top
  ASSERT_EQ(report.status, BuildStatus::kOk);
  EXPECT_EQ(curve.maxGrams(), 2000);
  EXPECT_EQ(curve.pwmForGrams(1), 1050);
  EXPECT_EQ(curve.pwmForGrams(1000), 1075);
  EXPECT_EQ(curve.pwmForGrams(2000), 1100);
}

}  // namespace
