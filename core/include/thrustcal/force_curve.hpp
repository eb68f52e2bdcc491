// A force curve: the PWM (us) that produces each whole gram 1..Grams on one motor at one
// battery voltage (thesis sec. 6.4, "PWM per gram", 500 grams).
//
// Kept compact because read_run holds eight of them in 8 KB SRAM: the PWM at 1 g plus one
// byte per gram step (pwm(g+1) - pwm(g), the curve is monotone so steps are >= 0).
// kUnreachable in a step means: the motor never produced this many grams during the sweep;
// every heavier gram is unreachable too. Checkpoints every 32 g keep lookups short.
#pragma once
#include <stdint.h>

namespace tc {

constexpr uint16_t kCurveGrams = 500;      // thesis size
constexpr uint8_t kUnreachable = 0xFF;     // step marker; real steps are 0..254
constexpr uint8_t kCheckpointEvery = 32;   // grams between precomputed PWMs

// Size-independent part: all code lives here once.
class ForceCurveBase {
 public:
  bool isPresent() const { return start_mv != 0; }
  // Heaviest gram the curve reaches (0 when absent, i.e. start_mv == 0, or empty, i.e.
  // pwm_at_1g_us == 0).
  uint16_t maxGrams() const { return isPresent() ? max_grams_ : 0; }
  // PWM for `grams` (1..maxGrams()). grams == 0 -> 0. grams > maxGrams() -> PWM at maxGrams().
  // An absent or empty curve answers 0 for every gram. O(kCheckpointEvery) additions.
  uint16_t pwmForGrams(uint16_t grams) const;
  // Rebuilds maxGrams() and the checkpoints from pwm_at_1g_us and the steps. Call after
  // filling the public fields by hand or by decoding. Returns false if a step sequence
  // is inconsistent (a real step after kUnreachable, or a PWM above 65535 us); the curve is
  // then truncated there (every later step becomes kUnreachable).
  bool finalize();
  // Absent and empty: start_mv = 0, pwm_at_1g_us = 0, every step kUnreachable.
  void clear();
  uint16_t capacityGrams() const { return grams_; }
  uint8_t* steps() { return steps_; }
  const uint8_t* steps() const { return steps_; }
  uint16_t stepCount() const { return grams_ - 1; }

  uint16_t start_mv = 0;      // battery at the start of the sweep; 0 = no curve
  uint16_t pwm_at_1g_us = 0;  // PWM that produced 1 g

 protected:
  ForceCurveBase(uint8_t* steps, uint16_t* checkpoints, uint16_t grams)
      : steps_(steps), checkpoints_(checkpoints), grams_(grams) {}
  ForceCurveBase(const ForceCurveBase&) = default;
  ForceCurveBase& operator=(const ForceCurveBase&) = default;

 private:
  uint8_t* steps_;
  uint16_t* checkpoints_;  // pwm at 1 + k * kCheckpointEvery
  uint16_t grams_;
  uint16_t max_grams_ = 0;
};

template <uint16_t Grams>
class ForceCurve : public ForceCurveBase {
  static_assert(Grams >= 2 && Grams <= 2000, "force curve holds 2..2000 grams");

 public:
  ForceCurve() : ForceCurveBase(step_storage_, checkpoint_storage_, Grams) {
    for (uint16_t i = 0; i < Grams - 1; ++i) step_storage_[i] = kUnreachable;
  }
  ForceCurve(const ForceCurve& other) : ForceCurveBase(step_storage_, checkpoint_storage_, Grams) {
    *this = other;
  }
  ForceCurve& operator=(const ForceCurve& other) {
    start_mv = other.start_mv;
    pwm_at_1g_us = other.pwm_at_1g_us;
    for (uint16_t i = 0; i < Grams - 1; ++i) step_storage_[i] = other.step_storage_[i];
    finalize();
    return *this;
  }

 private:
  uint8_t step_storage_[Grams - 1u];
  uint16_t checkpoint_storage_[(Grams - 1u) / kCheckpointEvery + 1u];
};

using ThesisCurve = ForceCurve<kCurveGrams>;

}  // namespace tc
