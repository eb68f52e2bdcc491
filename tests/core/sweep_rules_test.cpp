// Settle auto (thrustcal/sweep_rules.hpp), table-driven: a step's force medians, one every
// 20 ms as gather_store takes them, and the median at which the step ends.
#include <gtest/gtest.h>

#include <vector>

#include "thrustcal/sweep_rules.hpp"

namespace {

struct SettleCase {
  const char* what;
  std::vector<uint16_t> medians;  // ADC counts, in order
  uint16_t cap_ms;
  uint32_t ms_per_median;        // time from one median to the next (probe + readings)
  int ends_after;                // medians read when the step ends; 0: not within the list
};

// Feeds the medians as the sweep runner does; returns how many were read when it stopped.
int mediansUntilSettled(const SettleCase& c) {
  tc::SettleAuto s;
  uint32_t elapsed_ms = 0;
  for (std::size_t i = 0; i < c.medians.size(); ++i) {
    elapsed_ms += c.ms_per_median;
    s = tc::settleAutoNext(s, c.medians[i]);
    if (tc::settleAutoDone(s, elapsed_ms, c.cap_ms)) return static_cast<int>(i + 1);
  }
  return 0;
}

class SettleAutoRule : public ::testing::TestWithParam<SettleCase> {};

TEST_P(SettleAutoRule, EndsTheStepAtTheRightMedian) {
  const SettleCase& c = GetParam();
  EXPECT_EQ(mediansUntilSettled(c), c.ends_after) << c.what;
}

INSTANTIATE_TEST_SUITE_P(
    Table, SettleAutoRule,
    ::testing::Values(
        SettleCase{"three equal medians end the step at the third", {500, 500, 500, 500}, 500, 41, 3},
        SettleCase{"one count apart is a change (kSettledCounts 0)", {500, 501, 500, 501, 500}, 500, 41, 0},
        SettleCase{"a change restarts the count", {400, 450, 450, 470, 470, 470}, 500, 41, 6},
        SettleCase{"two equal then a change then two equal: not yet", {300, 300, 301, 301}, 500, 41, 0},
        SettleCase{"rising force, down as well as up", {600, 590, 590, 590}, 500, 41, 4},
        SettleCase{"the cap ends a step that never settles (13 x 41 ms >= 500 ms)",
                   {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15}, 500, 41, 13},
        SettleCase{"the cap reached exactly ends the step", {1, 2, 3, 4, 5}, 123, 41, 3},
        SettleCase{"cap 0 (settle 0): the first median ends the step", {7, 8}, 0, 41, 1},
        SettleCase{"a single median never agrees with itself", {900}, 500, 41, 0},
        SettleCase{"the full ADC range does not wrap", {0, 1023, 0, 1023, 1023, 1023}, 5000, 41, 6}));

TEST(SettleAutoRule, StartsEveryStepFromNothing) {
  // given: a step that ended on three equal medians
  tc::SettleAuto s;
  for (int i = 0; i < 3; ++i) s = tc::settleAutoNext(s, 500);
  ASSERT_TRUE(tc::settleAutoDone(s, 60, 500));
  // when: the next step starts from a fresh state and reads the same force once
  tc::SettleAuto next;
  next = tc::settleAutoNext(next, 500);
  // then: one median is not settled
  EXPECT_FALSE(tc::settleAutoDone(next, 20, 500));
}

// The rule is constexpr: it costs the firmware nothing when its inputs are constants.
static_assert(tc::settleAutoDone(tc::settleAutoNext(tc::settleAutoNext(tc::settleAutoNext({}, 5), 5), 5), 0, 500),
              "three equal medians settle");
static_assert(!tc::settleAutoDone(tc::settleAutoNext(tc::settleAutoNext({}, 5), 5), 0, 500),
              "two equal medians do not");

}  // namespace
