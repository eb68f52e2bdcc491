// core's one sort, one median and one monotone fit (order_stats.hpp), on their own: the curve
// builder and the model v2 fitter are tested through them elsewhere.
#include "thrustcal/order_stats.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <numeric>
#include <vector>

namespace {

struct Keyed {
  uint16_t key;
  uint16_t tag;  // arrival order
};

TEST(OrderStatsSort, SortsAscendingAndKeepsEqualKeysInArrivalOrder) {
  std::vector<Keyed> a = {{5, 0}, {1, 1}, {5, 2}, {3, 3}, {1, 4}, {9, 5}, {3, 6}};
  tc::insertionSort(a.data(), static_cast<uint16_t>(a.size()),
                    [](const Keyed& x, const Keyed& y) { return x.key < y.key; });
  const std::vector<uint16_t> keys = {1, 1, 3, 3, 5, 5, 9};
  const std::vector<uint16_t> tags = {1, 4, 3, 6, 0, 2, 5};
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].key, keys[i]) << i;
    EXPECT_EQ(a[i].tag, tags[i]) << i;
  }
}

TEST(OrderStatsSort, MatchesStdSortOnEveryPermutationOfFiveValues) {
  std::vector<int16_t> base = {-3, 0, 7, 7, 12};
  do {
    std::vector<int16_t> a = base;
    tc::insertionSort(a.data(), static_cast<uint16_t>(a.size()));
    EXPECT_TRUE(std::is_sorted(a.begin(), a.end()));
    std::vector<int16_t> want = base;
    std::sort(want.begin(), want.end());
    EXPECT_EQ(a, want);
  } while (std::next_permutation(base.begin(), base.end()));
}

TEST(OrderStatsSort, EmptyAndSingleElementArraysStayAsTheyAre) {
  int16_t one[1] = {42};
  tc::insertionSort(one, 0);
  tc::insertionSort(one, 1);
  EXPECT_EQ(one[0], 42);
}

struct MedianCase {
  std::vector<int16_t> values;
  int32_t median;
};

TEST(OrderStatsMedian, MiddleValueForOddCountsMeanOfTheMiddleTwoRoundedUpForEven) {
  const MedianCase cases[] = {
      {{17}, 17},
      {{3, 1, 2}, 2},
      {{18000, 17600, 17700, 30000, 17650}, 17700},  // one outlier does not move it
      {{4, 1}, 3},                                   // (1 + 4) / 2 = 2.5 -> 3
      {{10, 20, 30, 40}, 25},
      {{17600, 17601, 17603, 17602}, 17602},         // 17601.5 -> 17602
  };
  for (const MedianCase& c : cases) {
    std::vector<int16_t> a = c.values;
    EXPECT_EQ(tc::medianInPlace(a.data(), static_cast<uint16_t>(a.size())), c.median)
        << "first value " << c.values[0];
    EXPECT_TRUE(std::is_sorted(a.begin(), a.end())) << "sorted in place";
  }
}

// An exact pool for the tests: blocks as (sum, count) of integers, means compared by cross
// multiplication, the fitted value as a double.
struct ExactPool {
  struct Block {
    int64_t sum;
    uint16_t count;
  };
  std::vector<int64_t> in;
  std::vector<Block> stack;
  std::vector<double> out;

  explicit ExactPool(std::vector<int64_t> v) : in(std::move(v)), stack(in.size()), out(in.size()) {}
  Block point(uint16_t i) const { return Block{in[i], 1}; }
  static bool above(const Block& lo, const Block& hi) { return lo.sum * hi.count > hi.sum * lo.count; }
  static Block merge(const Block& lo, const Block& hi) {
    return Block{lo.sum + hi.sum, static_cast<uint16_t>(lo.count + hi.count)};
  }
  void keep(uint16_t k, const Block& b) { stack[k] = b; }
  Block kept(uint16_t k) const { return stack[k]; }
  static uint16_t points(const Block& b) { return b.count; }
  void fill(uint16_t first, uint16_t end, const Block& b) {
    for (uint16_t i = first; i < end; ++i) out[i] = static_cast<double>(b.sum) / b.count;
  }
};

struct PavaCase {
  std::vector<int64_t> in;
  std::vector<double> fitted;
  uint16_t merges;
};

TEST(OrderStatsPava, PoolsEachViolationIntoTheMeanOfItsBlock) {
  const PavaCase cases[] = {
      {{1, 2, 3, 4}, {1, 2, 3, 4}, 0},             // monotone already: untouched
      {{1, 3, 2, 4}, {1, 2.5, 2.5, 4}, 1},
      {{5, 4, 3, 2, 1}, {3, 3, 3, 3, 3}, 4},       // falling: one block
      {{1, 5, 2, 2, 6}, {1, 3, 3, 3, 6}, 2},       // a spike pooled with what follows
      {{0, 10, 0, 10, 0}, {0, 5, 5, 5, 5}, 2},      // equal means stay apart
      {{7}, {7}, 0},
  };
  for (const PavaCase& c : cases) {
    ExactPool pool(c.in);
    EXPECT_EQ(tc::poolAdjacentViolators(pool, static_cast<uint16_t>(c.in.size())), c.merges)
        << "first value " << c.in[0];
    for (size_t i = 0; i < c.in.size(); ++i) EXPECT_DOUBLE_EQ(pool.out[i], c.fitted[i]) << i;
  }
}

// The fit is the least-squares non-decreasing sequence: no other non-decreasing sequence is
// closer. Checked against every non-decreasing sequence on a small grid.
TEST(OrderStatsPava, NoNonDecreasingSequenceOnAGridIsCloserThanTheFit) {
  const std::vector<int64_t> in = {3, 1, 4, 1, 5, 9, 2, 6};
  ExactPool pool(in);
  tc::poolAdjacentViolators(pool, static_cast<uint16_t>(in.size()));
  EXPECT_TRUE(std::is_sorted(pool.out.begin(), pool.out.end()));
  auto cost = [&](const std::vector<double>& y) {
    double c = 0;
    for (size_t i = 0; i < in.size(); ++i) c += (y[i] - in[i]) * (y[i] - in[i]);
    return c;
  };
  const double best = cost(pool.out);
  // Every non-decreasing sequence of 8 values from {1, 2, ..., 9} in half steps is no better.
  std::vector<double> y(in.size(), 1.0);
  std::function<void(size_t, double)> walk = [&](size_t i, double lo) {
    if (i == y.size()) {
      EXPECT_GE(cost(y) + 1e-9, best);
      return;
    }
    for (double v = lo; v <= 9.0; v += 0.5) {
      y[i] = v;
      walk(i + 1, v);
    }
  };
  walk(0, 1.0);
}

}  // namespace
