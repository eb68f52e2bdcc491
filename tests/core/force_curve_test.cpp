#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "thrustcal/force_curve.hpp"

namespace {

using tc::ForceCurve;
using tc::kUnreachable;
using tc::ThesisCurve;

// pwm(g) = 1099 + g for g = 1..max_grams.
template <uint16_t Grams>
void fillLinear(ForceCurve<Grams>& curve, uint16_t max_grams) {
  curve.start_mv = 12000;
  curve.pwm_at_1g_us = 1100;
  for (uint16_t i = 0; i < curve.stepCount(); ++i) curve.steps()[i] = (i + 1u < max_grams) ? 1 : kUnreachable;
  ASSERT_TRUE(curve.finalize());
}

TEST(ForceCurve, NewCurveIsAbsentAndAnswersZero) {
  const ThesisCurve curve;
  EXPECT_FALSE(curve.isPresent());
  EXPECT_EQ(curve.maxGrams(), 0);
  EXPECT_EQ(curve.pwmForGrams(1), 0);
  EXPECT_EQ(curve.capacityGrams(), 500);
  EXPECT_EQ(curve.stepCount(), 499);
}

TEST(ForceCurve, LookupTableOnAHandMadeCurve) {
  // given
  ThesisCurve curve;
  fillLinear(curve, 100);
  struct Row {
    uint16_t grams, pwm_us;
  };
  const Row rows[] = {{0, 0}, {1, 1100}, {2, 1101}, {32, 1131}, {33, 1132}, {34, 1133},
                      {65, 1164}, {100, 1199}, {101, 1199}, {500, 1199}, {65535, 1199}};
  // then
  EXPECT_EQ(curve.maxGrams(), 100);
  for (const auto& r : rows) EXPECT_EQ(curve.pwmForGrams(r.grams), r.pwm_us) << r.grams;
}

TEST(ForceCurve, LookupEqualsPrefixSumOfRandomStepsAtEveryGram) {
  // given random steps 0..254 that keep the PWM inside uint16 for the whole curve
  ThesisCurve curve;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> step(0, 120);
  curve.start_mv = 11000;
  curve.pwm_at_1g_us = 1050;
  std::vector<uint32_t> expected{0, 1050};
  for (uint16_t i = 0; i < curve.stepCount(); ++i) {
    curve.steps()[i] = static_cast<uint8_t>(step(rng));
    expected.push_back(expected.back() + curve.steps()[i]);
  }
  // when
  ASSERT_TRUE(curve.finalize());
  // then every gram, on and between the 32 g checkpoints, matches
  ASSERT_EQ(curve.maxGrams(), 500);
  for (uint16_t g = 1; g <= 500; ++g) ASSERT_EQ(curve.pwmForGrams(g), expected[g]) << g;
}

TEST(ForceCurve, StartVoltageZeroMeansAbsentEvenWithSteps) {
  ThesisCurve curve;
  fillLinear(curve, 100);
  curve.start_mv = 0;
  EXPECT_EQ(curve.maxGrams(), 0);
  EXPECT_EQ(curve.pwmForGrams(50), 0);
}

TEST(ForceCurve, EmptyCurveWithoutPwmAtOneGramHasNoGrams) {
  ThesisCurve curve;
  curve.start_mv = 12000;
  EXPECT_TRUE(curve.finalize());
  EXPECT_EQ(curve.maxGrams(), 0);
  EXPECT_EQ(curve.pwmForGrams(1), 0);
}

TEST(ForceCurve, FinalizeTruncatesARealStepAfterTheEndMarker) {
  // given steps 1, 1, end, 1
  ThesisCurve curve;
  fillLinear(curve, 3);
  curve.steps()[3] = 1;
  // when
  const bool consistent = curve.finalize();
  // then
  EXPECT_FALSE(consistent);
  EXPECT_EQ(curve.maxGrams(), 3);
  EXPECT_EQ(curve.steps()[3], kUnreachable);
  EXPECT_TRUE(curve.finalize()) << "once truncated the curve is consistent";
}

TEST(ForceCurve, FinalizeRejectsStepsWithoutAPwmAtOneGram) {
  ThesisCurve curve;
  curve.start_mv = 12000;
  curve.steps()[10] = 3;
  EXPECT_FALSE(curve.finalize());
  EXPECT_EQ(curve.steps()[10], kUnreachable);
}

TEST(ForceCurve, FinalizeTruncatesWhereThePwmWouldOverflow) {
  ThesisCurve curve;
  curve.start_mv = 12000;
  curve.pwm_at_1g_us = 65000;
  for (uint16_t i = 0; i < curve.stepCount(); ++i) curve.steps()[i] = 254;
  EXPECT_FALSE(curve.finalize());
  EXPECT_EQ(curve.maxGrams(), 3);  // 65000, 65254, 65508
  EXPECT_EQ(curve.pwmForGrams(500), 65508);
}

TEST(ForceCurve, CopyAndAssignmentKeepTheCurve) {
  ThesisCurve original;
  fillLinear(original, 300);
  const ThesisCurve copy(original);
  ThesisCurve assigned;
  assigned = original;
  const ThesisCurve* const copies[] = {&copy, &assigned};
  for (const ThesisCurve* c : copies) {
    EXPECT_EQ(c->start_mv, 12000);
    EXPECT_EQ(c->maxGrams(), 300);
    EXPECT_EQ(c->pwmForGrams(250), 1349);
  }
}

TEST(ForceCurve, ClearMakesTheCurveAbsentAndEmpty) {
  ThesisCurve curve;
  fillLinear(curve, 300);
  curve.clear();
  EXPECT_FALSE(curve.isPresent());
  EXPECT_EQ(curve.pwm_at_1g_us, 0);
  EXPECT_EQ(curve.steps()[0], kUnreachable);
  curve.start_mv = 12000;
  EXPECT_EQ(curve.maxGrams(), 0);
}

TEST(ForceCurve, CapacityIsATemplateParameter) {
  ForceCurve<2> tiny;
  fillLinear(tiny, 2);
  EXPECT_EQ(tiny.maxGrams(), 2);
  EXPECT_EQ(tiny.pwmForGrams(5), 1101);
  ForceCurve<2000> big;
  fillLinear(big, 2000);
  EXPECT_EQ(big.maxGrams(), 2000);
  EXPECT_EQ(big.pwmForGrams(1999), 3098);
}

}  // namespace
