#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <random>
#include <vector>

#include "thrustcal/median_filter.hpp"

namespace {

// Lower median of what a window of `window` samples holds: std::nth_element reference.
uint16_t referenceMedian(const std::deque<uint16_t>& held) {
  std::vector<uint16_t> v(held.begin(), held.end());
  const size_t mid = (v.size() - 1) / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(mid), v.end());
  return v[mid];
}

template <uint16_t Window>
void expectMatchesReference(uint32_t seed, uint16_t max_value, size_t length) {
  tc::MedianFilter<Window> filter;
  std::deque<uint16_t> held;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<uint32_t> dist(0, max_value);
  for (size_t i = 0; i < length; ++i) {
    const uint16_t sample = static_cast<uint16_t>(dist(rng));
    filter.push(sample);
    held.push_back(sample);
    if (held.size() > Window) held.pop_front();
    ASSERT_EQ(filter.count(), held.size());
    ASSERT_EQ(filter.median(), referenceMedian(held))
        << "window " << Window << " seed " << seed << " after " << (i + 1) << " samples";
  }
}

struct StreamCase {
  uint32_t seed;
  uint16_t max_value;  // small ranges give many duplicates
};

const StreamCase kStreams[] = {{1, 65535}, {2, 1023}, {3, 20}, {4, 1}, {5, 0}};

// Each stream is 3 windows + 7 samples long: the ring wraps around several times.
// The sorted array is kept up to date while queries come every few pushes and given up after
// kEagerPushes pushes without one (the next query sorts): every pattern of queries gives the
// reference's median and central mean, including the switches between the two ways, a window
// filled without a query (gather_store), four pushes a query (read_run and fly), and a reset in
// between.
TEST(MedianFilter, AnyPatternOfQueriesGivesTheReferenceMedian) {
  const uint16_t kEvery[] = {1, 2, 4, 7, 8, 9, 13, 50, 101, 201, 500};
  int queries = 0;
  for (const auto& s : kStreams) {
    tc::MedianFilter<101> filter;
    std::deque<uint16_t> held;
    std::mt19937 rng(s.seed);
    std::uniform_int_distribution<uint32_t> dist(0, s.max_value);
    std::uniform_int_distribution<size_t> pick(0, sizeof kEvery / sizeof kEvery[0] - 1);
    for (int round = 0; round < 60; ++round) {
      if (round == 30) {
        filter.reset();
        held.clear();
      }
      const uint16_t every = kEvery[pick(rng)];
      for (uint16_t i = 0; i < every; ++i) {
        const uint16_t sample = static_cast<uint16_t>(dist(rng));
        filter.push(sample);
        held.push_back(sample);
        if (held.size() > 101) held.pop_front();
      }
      ASSERT_EQ(filter.median(), referenceMedian(held)) << "seed " << s.seed << " round " << round;
      if (held.size() % 2 == 1 && held.size() >= 65 && s.max_value <= 1023) {  // ADC counts: Q4 fits 16 bits
        std::vector<uint16_t> v(held.begin(), held.end());
        std::sort(v.begin(), v.end());
        uint32_t sum = 0;
        for (size_t k = (v.size() - 65) / 2; k < (v.size() - 65) / 2 + 65; ++k) sum += v[k];
        ASSERT_EQ(filter.centralMeanQ4(65), (sum * 16 + 32) / 65) << "seed " << s.seed << " round " << round;
      }
      ++queries;
    }
  }
  EXPECT_EQ(queries, 5 * 60);
}

TEST(MedianFilter, WindowOfOneFollowsTheLastSample) {
  for (const auto& s : kStreams) expectMatchesReference<1>(s.seed, s.max_value, 3 * 1 + 7);
}

TEST(MedianFilter, WindowOfThreeMatchesNthElementReference) {
  for (const auto& s : kStreams) expectMatchesReference<3>(s.seed, s.max_value, 3 * 3 + 7);
}

TEST(MedianFilter, WindowOf101MatchesNthElementReferenceAcrossRingWrapAround) {
  for (const auto& s : kStreams) expectMatchesReference<101>(s.seed, s.max_value, 3 * 101 + 7);
}

TEST(MedianFilter, WindowOf201MatchesNthElementReferenceAcrossRingWrapAround) {
  for (const auto& s : kStreams) expectMatchesReference<201>(s.seed, s.max_value, 3 * 201 + 7);
}

TEST(MedianFilter, EmptyFilterReportsZeroAndNoSamples) {
  tc::MedianFilter<5> filter;
  EXPECT_EQ(filter.count(), 0);
  EXPECT_EQ(filter.median(), 0);
  EXPECT_EQ(filter.window(), 5);
  EXPECT_FALSE(filter.full());
}

TEST(MedianFilter, EvenCountWhileFillingGivesLowerMedian) {
  // given
  tc::MedianFilter<5> filter;
  // when
  filter.push(40);
  filter.push(10);
  // then
  EXPECT_EQ(filter.median(), 10);
  filter.push(30);
  filter.push(20);
  EXPECT_EQ(filter.median(), 20);
}

TEST(MedianFilter, RejectsASingleSpikeInTheWindow) {
  // given a steady load cell reading with one electrical spike
  tc::MedianFilter<5> filter;
  const uint16_t readings[] = {500, 501, 1023, 499, 500};
  // when
  for (uint16_t r : readings) filter.push(r);
  // then
  EXPECT_TRUE(filter.full());
  EXPECT_EQ(filter.median(), 500);
}

TEST(MedianFilter, OldestSampleLeavesOnceFull) {
  // given
  tc::MedianFilter<3> filter;
  for (uint16_t v : {100, 100, 100}) filter.push(v);
  // when two new samples push out two old ones
  filter.push(7);
  filter.push(9);
  // then the window holds {100, 7, 9}
  EXPECT_EQ(filter.median(), 9);
  filter.push(8);  // {7, 9, 8}
  EXPECT_EQ(filter.median(), 8);
}

TEST(MedianFilter, ResetForgetsEverySample) {
  // given
  tc::MedianFilter<3> filter;
  for (uint16_t v : {5, 6, 7, 8}) filter.push(v);
  // when
  filter.reset();
  filter.push(42);
  // then
  EXPECT_EQ(filter.count(), 1);
  EXPECT_EQ(filter.median(), 42);
}

TEST(MedianFilter, CentralMeanIsTheMedianOfAConstantAndResolvesDitheredReadings) {
  // given: a constant reading, then readings dithered between 300 and 301 (a quarter 301)
  tc::MedianFilter<201> filter;
  for (int i = 0; i < 201; ++i) filter.push(300);
  EXPECT_EQ(filter.centralMeanQ4(65), 300 * 16);
  EXPECT_EQ(filter.centralMeanQ4(1), filter.median() * 16u);
  filter.reset();
  for (int i = 0; i < 201; ++i) filter.push(static_cast<uint16_t>(i % 4 == 0 ? 301 : 300));
  // then: the median is stuck at 300; the central mean sees the 301s that reach the middle
  EXPECT_EQ(filter.median(), 300);
  const uint16_t q4 = filter.centralMeanQ4(201);
  EXPECT_EQ(q4, (300 * 16 * 150 + 301 * 16 * 51 + 100) / 201);
  // and: 65 around the median of 101 x 300 and 100 x 301: ranks 68..132, 33 of them 300
  filter.reset();
  for (int i = 0; i < 201; ++i) filter.push(static_cast<uint16_t>(i < 101 ? 300 : 301));
  EXPECT_EQ(filter.centralMeanQ4(65), (33 * 300 * 16 + 32 * 301 * 16 + 32) / 65);
}

TEST(MedianFilter, CentralMeanIgnoresSpikesOutsideTheMiddleRanks) {
  // given: 201 readings of 500 with 60 spikes to 0 and 1023
  tc::MedianFilter<201> filter;
  for (int i = 0; i < 201; ++i) filter.push(static_cast<uint16_t>(i % 7 == 0 ? 0 : (i % 7 == 1 ? 1023 : 500)));
  // then: the middle 65 are all 500
  EXPECT_EQ(filter.centralMeanQ4(65), 500 * 16);
  // and: more than asked is clamped to the samples held; empty reads 0
  tc::MedianFilter<5> few;
  EXPECT_EQ(few.centralMeanQ4(3), 0);
  for (uint16_t v : {10, 20, 30}) few.push(v);
  EXPECT_EQ(few.centralMeanQ4(5), 20 * 16);
}

}  // namespace
