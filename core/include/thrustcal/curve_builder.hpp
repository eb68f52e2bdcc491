// Builds a force curve from sweep samples (thesis sec. 6.4, "filter function").
//
// 1. samples sorted by PWM (a sweep is already ascending; any order is accepted), equal
//    PWMs merged by averaging;
// 2. force made monotone non-decreasing in PWM by isotonic regression (pool adjacent
//    violators): noise and a non-monotone raw sweep give the least-squares monotone fit,
//    never a curve that goes backwards;
// 3. each whole gram 1..Grams gets the PWM where the fitted force first reaches it, linearly
//    interpolated between the two nearest samples (the thesis averaged the two nearest);
//    grams above the largest fitted force are marked unreachable.
#pragma once
#include <stdint.h>

#include "thrustcal/force_curve.hpp"

namespace tc {

struct SweepSample {
  uint16_t pwm_us;
  int16_t force_dg;  // decigrams (0.1 g), thrust positive
};

enum class BuildStatus : uint8_t {
  kOk = 0,
  kTooFewSamples,  // fewer than 2 distinct PWMs
  kNoForce,        // the fitted force never reaches 1 g: motor not spinning or cell not tared
  kCurveTooSteep,  // a 1 g step needs more than 254 us: sweep too coarse to be a curve
};

struct BuildReport {
  BuildStatus status = BuildStatus::kTooFewSamples;
  uint16_t samples_used = 0;   // after merging equal PWMs
  uint16_t violations = 0;     // points (after merging) the monotone fit pooled with a
                               // neighbour: 0 for a monotone sweep
  int16_t max_force_dg = 0;    // largest fitted force
  uint16_t max_grams = 0;      // heaviest gram in the curve
};

class CurveBuilderBase {
 public:
  void reset() { count_ = 0; }
  // Adds a sample; false when the buffer is full (the sample is dropped).
  bool add(uint16_t pwm_us, int16_t force_dg);
  uint16_t size() const { return count_; }
  uint16_t capacity() const { return capacity_; }
  const SweepSample& sample(uint16_t i) const { return samples_[i]; }
  // Fills `out`'s PWM at 1 g and steps and finalizes it; on kOk out.start_mv keeps the value
  // it had (setting it is the caller's job, maxGrams() is 0 until then). Grams beyond
  // out.capacityGrams() are dropped. On any status but kOk `out` is cleared (absent,
  // start_mv = 0). Afterwards the buffer holds the merged points, ascending in PWM, with
  // their fitted (monotone) force: size() may shrink; reset() before the next sweep.
  // int32 arithmetic only, O(n) for an ascending sweep (insertion sort), O(n + grams).
  // Status kTooFewSamples: under 2 distinct PWMs; kNoForce: fitted force never reaches 1 g;
  // kCurveTooSteep: two neighbouring grams more than 254 us apart.
  BuildReport build(ForceCurveBase& out);

 protected:
  CurveBuilderBase(SweepSample* samples, int32_t* block_sum, uint16_t* block_weight,
                   uint16_t capacity)
      : samples_(samples), block_sum_(block_sum), block_weight_(block_weight),
        capacity_(capacity) {}

 private:
  SweepSample* samples_;
  int32_t* block_sum_;      // PAVA work space
  uint16_t* block_weight_;  // PAVA work space
  uint16_t capacity_;
  uint16_t count_ = 0;
};

template <uint16_t MaxSamples>
class CurveBuilder : public CurveBuilderBase {
  static_assert(MaxSamples >= 2 && MaxSamples <= 1024, "2..1024 samples");

 public:
  CurveBuilder() : CurveBuilderBase(samples_storage_, sum_storage_, weight_storage_, MaxSamples) {}
  CurveBuilder(const CurveBuilder&) = delete;
  CurveBuilder& operator=(const CurveBuilder&) = delete;

 private:
  SweepSample samples_storage_[MaxSamples];
  int32_t sum_storage_[MaxSamples];
  uint16_t weight_storage_[MaxSamples];
};

}  // namespace tc
