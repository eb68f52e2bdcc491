// Force-curve builder: sort, merge equal PWMs, pool adjacent violators, invert per gram.
// int32 only (sums of decigrams, exact mean comparisons by quotient and remainder), no float,
// no recursion, no heap: the work space is the caller-sized arrays of CurveBuilder<N>.
#include "thrustcal/curve_builder.hpp"

#include "thrustcal/order_stats.hpp"

namespace tc {

namespace {

constexpr uint8_t kMaxStepUs = 254;  // kUnreachable (255) is the end marker
constexpr int32_t kDecigramsPerGram = 10;

// Floor division for den > 0: num = q * den + r with 0 <= r < den.
void floorDivMod(int32_t num, int32_t den, int32_t& q, int32_t& r) {
  q = num / den;
  r = num % den;
  if (r < 0) {
    r += den;
    --q;
  }
}

// Exact sum_a / weight_a > sum_b / weight_b without a 64-bit product. Sums under 2^20 (every
// block of a sweep's points: each a reading of at most 32767 dg, a block at most a few points)
// compare by cross products, which stay under 2^30 (weights are at most 1024): two
// multiplications. Larger sums take the quotients first: four 32-bit divisions, ~2,800 cycles
// on the AVR, which made the monotone fit of a 161-step sweep ~28 ms of gather_store's end of
// sweep between two watchdog kicks.
bool meanGreater(int32_t sum_a, uint16_t weight_a, int32_t sum_b, uint16_t weight_b) {
  constexpr int32_t kCrossMax = static_cast<int32_t>(1) << 20;
  if (sum_a > -kCrossMax && sum_a < kCrossMax && sum_b > -kCrossMax && sum_b < kCrossMax)
    return sum_a * static_cast<int32_t>(weight_b) > sum_b * static_cast<int32_t>(weight_a);
  int32_t qa, ra, qb, rb;
  floorDivMod(sum_a, weight_a, qa, ra);
  floorDivMod(sum_b, weight_b, qb, rb);
  if (qa != qb) return qa > qb;
  // ra < weight_a <= 1024 and rb < weight_b <= 1024: the products stay below 2^20.
  return ra * static_cast<int32_t>(weight_b) > rb * static_cast<int32_t>(weight_a);
}

// Mean rounded to the nearest decigram (halves up), saturated to int16.
int16_t roundedMean(int32_t sum, uint16_t weight) {
  int32_t q, r;
  floorDivMod(2 * sum + weight, 2 * static_cast<int32_t>(weight), q, r);
  if (q > 32767) return 32767;
  if (q < -32768) return -32768;
  return static_cast<int16_t>(q);
}

// The points of the monotone fit (order_stats.hpp's poolAdjacentViolators): a point's sum and
// weight (raw samples) in the block arrays; block k's sum and weight at index k of the same
// arrays, its point count parked in samples[k].force_dg, which the merge step no longer needs.
struct PavaPool {
  struct Block {
    int32_t sum;
    uint16_t weight;
    uint16_t points;
  };
  SweepSample* samples;
  int32_t* sum;
  uint16_t* weight;
  uint16_t pooled;  // points in blocks of more than one

  Block point(uint16_t i) const { return Block{sum[i], weight[i], 1}; }
  static bool above(const Block& lo, const Block& hi) {
    return meanGreater(lo.sum, lo.weight, hi.sum, hi.weight);
  }
  static Block merge(const Block& lo, const Block& hi) {
    return Block{lo.sum + hi.sum, static_cast<uint16_t>(lo.weight + hi.weight),
                 static_cast<uint16_t>(lo.points + hi.points)};
  }
  void keep(uint16_t k, const Block& b) {
    sum[k] = b.sum;
    weight[k] = b.weight;
    samples[k].force_dg = static_cast<int16_t>(b.points);
  }
  Block kept(uint16_t k) const {
    return Block{sum[k], weight[k], static_cast<uint16_t>(samples[k].force_dg)};
  }
  static uint16_t points(const Block& b) { return b.points; }
  void fill(uint16_t first, uint16_t end, const Block& b) {
    const int16_t fitted_dg = roundedMean(b.sum, b.weight);
    if (b.points > 1) pooled = static_cast<uint16_t>(pooled + b.points);
    for (uint16_t i = first; i < end; ++i) samples[i].force_dg = fitted_dg;
  }
};

// The PWM where the line from lo to hi reaches target_dg (lo.force_dg < target_dg <=
// hi.force_dg, so the span is never zero), rounded to the nearest microsecond.
// num = q * den + r, 0 <= r < den, for den > 0: by subtraction while the quotient is small (the
// inversion's usual case: a quotient of at most the sweep's step in microseconds, a few dozen
// cycles where the AVR's 32-bit division takes ~700), by division beyond 32.
void divModSmall(uint32_t num, uint32_t den, uint32_t& q, uint32_t& r) {
  uint32_t quotient = 0;
  for (uint8_t i = 0; i < 32 && num >= den; ++i) {
    num -= den;
    ++quotient;
  }
  if (num >= den) {
    quotient += num / den;
    num %= den;
  }
  q = quotient;
  r = num;
}

// The PWM where the line from lo to hi reaches each whole gram, rounded to the nearest
// microsecond (halves up): lo.pwm + round((target - lo.force) * span_us / span_dg). Grams that
// fall in one segment are consecutive targets 1 g apart, so the quotient and remainder of the
// division are carried from one gram to the next (two small divisions per segment, not one
// 32-bit division pair per gram: ~600 cycles each on the AVR). The same integers as dividing at
// every gram.
class SegmentInterpolator {
 public:
  uint16_t at(const SweepSample* samples, uint16_t reach, int32_t target_dg) {
    if (reach != segment_) {
      const SweepSample& lo = samples[reach - 1];
      const SweepSample& hi = samples[reach];
      const uint32_t above = static_cast<uint32_t>(target_dg - lo.force_dg);   // < 2^16
      const uint32_t span_us = static_cast<uint32_t>(hi.pwm_us) - lo.pwm_us;  // < 2^16
      // int32 before subtracting: on AVR int16 - int16 is a 16-bit int and could wrap.
      span_dg_ = static_cast<uint32_t>(static_cast<int32_t>(hi.force_dg) - lo.force_dg);
      divModSmall(above * span_us, span_dg_, add_, rem_);
      divModSmall(static_cast<uint32_t>(kDecigramsPerGram) * span_us, span_dg_, per_gram_add_, per_gram_rem_);
      lo_pwm_us_ = lo.pwm_us;
      segment_ = reach;
    } else {  // the next gram in the same segment: num grows by kDecigramsPerGram * span_us
      add_ += per_gram_add_;
      rem_ += per_gram_rem_;
      if (rem_ >= span_dg_) {
        rem_ -= span_dg_;
        ++add_;
      }
    }
    return static_cast<uint16_t>(lo_pwm_us_ + add_ + (2u * rem_ >= span_dg_ ? 1u : 0u));
  }

 private:
  uint16_t segment_ = 0;  // the upper point of the segment the state is for (0: none)
  uint16_t lo_pwm_us_ = 0;
  uint32_t span_dg_ = 1, add_ = 0, rem_ = 0, per_gram_add_ = 0, per_gram_rem_ = 0;
};

}  // namespace

bool CurveBuilderBase::add(uint16_t pwm_us, int16_t force_dg) {
  if (count_ >= capacity_) return false;
  samples_[count_].pwm_us = pwm_us;
  samples_[count_].force_dg = force_dg;
  ++count_;
  return true;
}

BuildReport CurveBuilderBase::build(ForceCurveBase& out) {
  BuildReport report;
  const uint16_t keep_start_mv = out.start_mv;
  out.clear();

  // 1. Sort by PWM: insertion sort, O(n) for the usual already-ascending sweep, stable.
  insertionSort(samples_, count_,
                [](const SweepSample& a, const SweepSample& b) { return a.pwm_us < b.pwm_us; });

  // 2. Merge equal PWMs: a point's sum and weight (raw samples) go to the PAVA arrays.
  uint16_t points = 0;
  for (uint16_t i = 0; i < count_; ++i) {
    if (points > 0 && samples_[points - 1].pwm_us == samples_[i].pwm_us) {
      block_sum_[points - 1] += samples_[i].force_dg;
      ++block_weight_[points - 1];
    } else {
      samples_[points].pwm_us = samples_[i].pwm_us;
      block_sum_[points] = samples_[i].force_dg;
      block_weight_[points] = 1;
      ++points;
    }
  }
  count_ = points;
  report.samples_used = points;
  if (points < 2) {
    report.status = BuildStatus::kTooFewSamples;
    return report;
  }

  // 3. Pool adjacent violators (weighted by raw samples: least squares on the raw data).
  PavaPool pool{samples_, block_sum_, block_weight_, 0};
  poolAdjacentViolators(pool, points);
  report.violations = pool.pooled;
  report.max_force_dg = samples_[points - 1].force_dg;

  // 4. Invert: for each whole gram the PWM where the fitted force first reaches it.
  if (report.max_force_dg < kDecigramsPerGram) {
    report.status = BuildStatus::kNoForce;
    return report;
  }
  uint16_t max_grams = static_cast<uint16_t>(report.max_force_dg / kDecigramsPerGram);
  if (max_grams > out.capacityGrams()) max_grams = out.capacityGrams();

  uint8_t* steps = out.steps();
  uint16_t reach = 0;  // first point whose fitted force >= target
  uint16_t previous_pwm = 0;
  SegmentInterpolator line;
  for (uint16_t grams = 1; grams <= max_grams; ++grams) {
    const int32_t target_dg = static_cast<int32_t>(grams) * kDecigramsPerGram;
    while (samples_[reach].force_dg < target_dg) ++reach;  // stops: last point >= max_grams
    uint16_t pwm = samples_[reach].pwm_us;
    if (reach > 0) pwm = line.at(samples_, reach, target_dg);
    if (grams == 1) {
      out.pwm_at_1g_us = pwm;
    } else {
      const uint16_t step = static_cast<uint16_t>(pwm - previous_pwm);
      if (step > kMaxStepUs) {
        out.clear();
        report.status = BuildStatus::kCurveTooSteep;
        return report;
      }
      steps[grams - 2] = static_cast<uint8_t>(step);
    }
    previous_pwm = pwm;
  }
  out.start_mv = keep_start_mv;
  out.finalize();
  report.max_grams = max_grams;
  report.status = BuildStatus::kOk;
  return report;
}

}  // namespace tc
