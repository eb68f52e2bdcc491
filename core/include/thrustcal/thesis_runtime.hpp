// The thesis model (record layout v1, option 2.1) as read_run flies it, in a fraction of the
// SRAM of the decoded record (tc::MotorCalibration): the curves' 499 PWM steps per curve stay
// in the EEPROM and are read on demand; SRAM keeps each curve's PWM every 16 grams
// (checkpoints), its start voltage and heaviest gram, and the sag table.
//
// A lookup walks at most kThesisCheckpointEvery - 1 steps read from the EEPROM from a
// checkpoint: the same sum the decoded curve makes from its own checkpoints every 32 g, so the
// PWM is the same to the bit for every gram and every battery reading (tests/core/
// thesis_runtime_test.cpp sweeps them all against tc::forceToPwm on the decoded record). The
// EEPROM does not change while read_run or fly flies (neither writes it), and load() checks
// every checkpoint it computes from the EEPROM against the decoded, CRC-checked record.
//
// Each curve remembers the gram it walked to last, its PWM and its step to the next gram (5
// bytes): a motor holding its force reads nothing, one changing it by 1-3 g reads those step
// bytes one by one (walkNear); a longer jump walks from the nearest checkpoint, at most 8 steps
// away but near the heaviest gram, in one EEPROM block read (walkTo). placeCursor walks ahead of
// a start from a stop (fw::ForceActuators' start force: 1 g, fly's idle force). The voltage
// term is 16-bit arithmetic with the record's span's reciprocal (forceToPwmDg below): on the
// ATmega2560 this took four motors' option 2.1 in fly (with their sag offsets) from about
// 12,000 cycles a frame to about 5,800, walkNear and the sag offsets looked up after the write
// (fw::ForceActuators::prepareNextFrame) to about 4,500 between the IMU read and the write
// (thrustcal bench fly's breakdown; docs/fly.md, "Budgets").
//
// Storage: static uint8_t readByte(uint16_t addr); static void readBlock(uint16_t addr,
// void* dst, uint16_t length) (hal::Eeprom on the board, RAM arrays in tests).
#pragma once
#include <stdint.h>

#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace tc {

constexpr uint8_t kThesisCheckpointEvery = 16;  // grams between the PWMs kept in SRAM
constexpr uint8_t kThesisCheckpoints = (kCurveGrams - 1) / kThesisCheckpointEvery + 1;
constexpr uint8_t kThesisNearGrams = 3;  // a cursor move walkNear makes byte by byte

struct ThesisCurveRun {
  uint16_t start_mv = 0;    // 0: no curve
  uint16_t max_grams = 0;   // heaviest gram the curve reaches
  uint16_t steps_addr = 0;  // EEPROM address of the step pwm(2 g) - pwm(1 g)
  uint16_t checkpoint_us[kThesisCheckpoints] = {};  // PWM at 1 + 16 k grams

  bool isPresent() const { return start_mv != 0; }
  uint16_t maxGrams() const { return isPresent() ? max_grams : 0; }

  // As ForceCurveBase::pwmForGrams: 0 for gram 0 or an absent/empty curve, the heaviest
  // gram's PWM above it. At most kThesisCheckpointEvery - 1 EEPROM bytes (walkTo).
  template <class Storage>
  uint16_t pwmForGrams(uint16_t grams) const {
    const uint16_t max = maxGrams();
    if (grams == 0 || max == 0) return 0;
    if (grams > max) grams = max;
    return walkTo<Storage>(grams);
  }

  // The PWM at `grams` + `tenths` / 10 in 0.1 us: tc::pwmTenthsAt's value (the first gram's
  // PWM below it, the heaviest's at and beyond it, the straight line between two grams), from
  // the cursor's PWM and its step to the next gram. Fits 16 bits for a curve whose PWMs are at
  // most 6553 us. Inlined into forceToPwmDg: the gram walked to last again (a motor holding its
  // force) costs a comparison, a few grams from it below the heaviest (a motor changing its
  // force) a walk of those few EEPROM bytes (walkNear), anything else the walk from the nearest
  // known PWM (walkTo).
  template <class Storage>
  __attribute__((always_inline)) uint16_t pwmTenths(uint16_t grams, uint8_t tenths) const {
    if (grams != cursor_g_ || grams == 0) {
      if (static_cast<uint16_t>(grams - cursor_g_ + kThesisNearGrams) > 2 * kThesisNearGrams || cursor_g_ == 0 ||
          grams == 0 || grams >= max_grams)
        return pwmTenthsWalked<Storage>(grams, tenths);
      walkNear<Storage>(grams);
    }
    return static_cast<uint16_t>(10u * cursor_us_ + static_cast<uint16_t>(tenths * cursor_step_));
  }

  // The gram the cursor is on (0: none yet): a force near it splits into grams and tenths
  // without a division (forceToPwmDg).
  uint16_t cursorGrams() const { return cursor_g_; }

  // The cursor on `grams` (1 at the least, the heaviest gram at the most), walked now: a motor
  // that starts from a stop near there (a few grams first, or a flight loop's idle force) then
  // walks walkNear's few bytes in its first frame, not walkTo's block.
  template <class Storage>
  void placeCursor(uint16_t grams) const {
    if (maxGrams() == 0) return;
    walkTo<Storage>(grams == 0 ? 1 : (grams > maxGrams() ? maxGrams() : grams));
  }

  // From a decoded curve whose steps lie at `steps_addr` in Storage: checkpoints summed from
  // the EEPROM bytes, each checked against the decoded curve. False (cleared) on a mismatch.
  template <class Storage>
  bool load(const ForceCurveBase& curve, uint16_t steps_address) {
    *this = ThesisCurveRun();
    if (!curve.isPresent()) return true;
    start_mv = curve.start_mv;
    max_grams = curve.maxGrams();
    steps_addr = steps_address;
    uint16_t pwm = curve.pwm_at_1g_us;
    for (uint16_t g = 1; g <= max_grams; ++g) {
      if ((g - 1) % kThesisCheckpointEvery == 0) {
        if (pwm != curve.pwmForGrams(g)) {
          *this = ThesisCurveRun();
          return false;
        }
        checkpoint_us[(g - 1) / kThesisCheckpointEvery] = pwm;
      }
      if (g < max_grams)
        pwm = static_cast<uint16_t>(pwm + Storage::readByte(static_cast<uint16_t>(steps_address + g - 1)));
    }
    if (max_grams != 0 && pwm != curve.pwmForGrams(max_grams)) {
      *this = ThesisCurveRun();
      return false;
    }
    return true;
  }

 private:
  static_assert((kThesisCheckpointEvery & (kThesisCheckpointEvery - 1)) == 0, "a power of two: the walk shifts");

  template <class Storage>
  __attribute__((noinline)) uint16_t pwmTenthsWalked(uint16_t grams, uint8_t tenths) const {
    const uint16_t max = maxGrams();
    if (grams >= max) return static_cast<uint16_t>(10u * pwmForGrams<Storage>(max));
    if (grams == 0) return static_cast<uint16_t>(10u * walkTo<Storage>(1));
    const uint16_t lo = walkTo<Storage>(grams);
    return static_cast<uint16_t>(10u * lo + static_cast<uint16_t>(tenths * cursor_step_));
  }

  // The cursor moved to `grams` (1..max_grams - 1, 1..kThesisNearGrams from the cursor) one
  // EEPROM byte a step, without walkTo's block: forward the PWM adds the cursor's step and the
  // bytes between, backward it takes off the bytes from `grams` up; the last byte read is the
  // new gram's step (the byte at steps_addr + g - 1 is pwm(g + 1) - pwm(g)). The same bytes
  // walkTo adds, so the same PWM and step.
  template <class Storage>
  __attribute__((noinline)) void walkNear(uint16_t grams) const {
    uint16_t pwm = cursor_us_;
    uint8_t step;
    if (grams > cursor_g_) {
      step = cursor_step_;
      for (uint16_t g = cursor_g_; g != grams; ++g) {
        pwm = static_cast<uint16_t>(pwm + step);
        step = Storage::readByte(static_cast<uint16_t>(steps_addr + g));
      }
    } else {
      step = 0;
      for (uint16_t g = static_cast<uint16_t>(cursor_g_ - 1); g >= grams; --g) {
        step = Storage::readByte(static_cast<uint16_t>(steps_addr + g - 1));
        pwm = static_cast<uint16_t>(pwm - step);
        if (g == grams) break;
      }
    }
    cursor_g_ = grams;
    cursor_us_ = pwm;
    cursor_step_ = step;
  }

  // The PWM at `grams` (1..max_grams), walked from the nearest known PWM: a checkpoint (at most
  // half their spacing away but near the heaviest gram) or the gram this curve walked to last
  // (pwmTenths takes moves of up to kThesisNearGrams to walkNear). The steps walked over
  // and the step to the next gram are one EEPROM block, at most kThesisCheckpointEvery bytes;
  // forward the PWM adds them, backward it takes them off. Every PWM it starts from was summed
  // from the same bytes, so the result is exact. The gram, its PWM and its step to the next gram
  // (0 at the heaviest) become the cursor.
  template <class Storage>
  uint16_t walkTo(uint16_t grams) const {
    const uint16_t index = static_cast<uint16_t>(grams - 1);
    const uint8_t k = static_cast<uint8_t>(index / kThesisCheckpointEvery);
    uint16_t from_g = static_cast<uint16_t>(k * kThesisCheckpointEvery + 1);
    uint16_t from_us = checkpoint_us[k];
    const uint16_t next_g = static_cast<uint16_t>(from_g + kThesisCheckpointEvery);
    if (grams - from_g > kThesisCheckpointEvery / 2 && next_g <= max_grams) {
      from_g = next_g;
      from_us = checkpoint_us[k + 1];
    }
    const uint16_t to_anchor = grams > from_g ? grams - from_g : from_g - grams;
    const uint16_t to_cursor = grams > cursor_g_ ? grams - cursor_g_ : cursor_g_ - grams;
    if (cursor_g_ != 0 && to_cursor < to_anchor) {
      from_g = cursor_g_;
      from_us = cursor_us_;
    }
    const bool with_step = grams < max_grams;
    uint8_t steps[kThesisCheckpointEvery];
    uint16_t pwm = from_us;
    uint8_t step = 0;
    if (grams >= from_g) {
      const uint8_t walk = static_cast<uint8_t>(grams - from_g);
      const uint8_t length = static_cast<uint8_t>(walk + (with_step ? 1 : 0));
      if (length != 0) Storage::readBlock(static_cast<uint16_t>(steps_addr + from_g - 1), steps, length);
      for (uint8_t j = 0; j < walk; ++j) pwm = static_cast<uint16_t>(pwm + steps[j]);
      if (with_step) step = steps[walk];
    } else {
      const uint8_t walk = static_cast<uint8_t>(from_g - grams);
      Storage::readBlock(static_cast<uint16_t>(steps_addr + grams - 1), steps, walk);
      for (uint8_t j = 0; j < walk; ++j) pwm = static_cast<uint16_t>(pwm - steps[j]);
      step = steps[0];
    }
    cursor_g_ = grams;
    cursor_us_ = pwm;
    cursor_step_ = step;
    return pwm;
  }

  mutable uint16_t cursor_g_ = 0;     // the gram walked to last (0: none yet)
  mutable uint16_t cursor_us_ = 0;    // its PWM
  mutable uint8_t cursor_step_ = 0;   // its step to the next gram (0 at the heaviest gram)
};

namespace thesis_detail {
// Widening 16 x 16 -> 32 bit products (the AVR's MUL four times, not a 32 x 32 library call).
inline uint32_t umul16(uint16_t a, uint16_t b) { return static_cast<uint32_t>(a) * static_cast<uint32_t>(b); }
inline int32_t smul16(int16_t a, int16_t b) { return static_cast<int32_t>(a) * static_cast<int32_t>(b); }
// The high half of a product, taken whole (an AVR shifts a 32-bit value one bit at a time).
inline uint16_t high16(uint32_t x) { return static_cast<uint16_t>(x >> 16); }
// floor(x / 10) for every uint16_t, by a product: x * 52429 / 2^19.
inline uint16_t div10(uint16_t x) { return static_cast<uint16_t>(high16(umul16(x, 52429u)) >> 3); }
}  // namespace thesis_detail

struct ThesisRun {
  ThesisCurveRun first;   // first.start_mv == 0: not calibrated
  ThesisCurveRun second;  // second.start_mv == 0: no second curve
  SagTable sag;

  bool isCalibrated() const { return first.isPresent(); }
  // Both curves' cursors on `grams` (ThesisCurveRun::placeCursor): for a start from a stop.
  template <class Storage>
  void placeCursors(uint16_t grams) const {
    first.placeCursor<Storage>(grams);
    second.placeCursor<Storage>(grams);
  }
  bool hasSecondCurve() const { return second.isPresent(); }
  void clear() { *this = ThesisRun(); }

  // From the record of `slot` decoded into `cal` (readRecord returned kOk). False (cleared)
  // when the EEPROM no longer holds what was decoded.
  template <class Storage>
  bool load(const MotorCalibration& cal, uint8_t slot) {
    clear();
    const uint16_t base = slotAddress(slot);
    if (!first.load<Storage>(cal.first, static_cast<uint16_t>(base + kRecordFirstStepsOffset)) ||
        !second.load<Storage>(cal.second, static_cast<uint16_t>(base + kRecordSecondStepsOffset))) {
      clear();
      return false;
    }
    sag = cal.sag;
    prepareFastPath(cal);
    return true;
  }

  // The 16-bit path (forceToPwmDg below) applies: every PWM of both curves at most
  // kFastMaxPwmUs (0.1 us in an int16), and a voltage span of kFastMinSpanMv..kFastMaxSpanMv
  // (ten times it in a uint16, its reciprocal exact enough). Any record the codec passes (PWMs
  // within the ESC range, curves 0.1 V apart or more) is on it.
  static constexpr uint16_t kFastMaxPwmUs = 3276;
  static constexpr uint16_t kFastMinSpanMv = 26;
  static constexpr uint16_t kFastMaxSpanMv = 6553;
  bool isFast() const { return fast_; }
  int16_t spanMv() const { return static_cast<int16_t>(second.start_mv - first.start_mv); }

  // floor(m / (10 |span|)) for m < 2^24: the reciprocal's estimate (at most 3 below: it drops
  // m's low byte and the reciprocal's fraction) corrected by the remainder. Exact.
  uint16_t spanQuotient(uint32_t m) const {
    uint16_t q = thesis_detail::high16(thesis_detail::umul16(static_cast<uint16_t>(m >> 8), span_recip_));
#ifdef __AVR__
    // q as a plain 16-bit value: avr-gcc otherwise keeps it as the 32-bit product's shift and
    // multiplies it by the span 32 x 32 (a library call twice as long as the widening one).
    __asm__("" : "+r"(q));
#endif
    uint32_t r = m - thesis_detail::umul16(q, span_x10_);
    while (r >= span_x10_) {
      r -= span_x10_;
      ++q;
    }
    return q;
  }
  uint16_t spanX10() const { return span_x10_; }

 private:
  void prepareFastPath(const MotorCalibration& cal) {
    fast_ = false;
    if (cal.first.pwmForGrams(first.maxGrams()) > kFastMaxPwmUs) return;
    if (hasSecondCurve()) {
      if (cal.second.pwmForGrams(second.maxGrams()) > kFastMaxPwmUs) return;
      const int32_t span = static_cast<int32_t>(second.start_mv) - first.start_mv;
      const uint32_t magnitude = static_cast<uint32_t>(span < 0 ? -span : span);
      if (magnitude < kFastMinSpanMv || magnitude > kFastMaxSpanMv) return;
      span_x10_ = static_cast<uint16_t>(10u * magnitude);
      span_recip_ = static_cast<uint16_t>((1ul << 24) / span_x10_);
    }
    fast_ = true;
  }

  bool fast_ = false;
  uint16_t span_x10_ = 0;    // 10 |V2 - V1|
  uint16_t span_recip_ = 0;  // floor(2^24 / span_x10_)
};

// forceToPwmWithDg itself on a ThesisRun (its 32-bit arithmetic): the reference forceToPwmDg
// below equals, and its way for what the 16-bit path does not cover. Not inlined: the frame's
// path keeps its registers.
template <class Storage>
__attribute__((noinline)) ForcePwmResult forceToPwmDgGeneral(const ThesisRun& run, uint16_t force_dg, uint16_t vbat_mv,
                                                            const ForcePwmLimits& limits) {
  return forceToPwmWithDg(run, force_dg, vbat_mv, limits, [](const ThesisCurveRun& curve, uint16_t grams) {
    return curve.pwmForGrams<Storage>(grams);
  });
}

// Option 2.1 on a ThesisRun (what read_run and fly fly): tc::forceToPwm's arithmetic
// (forceToPwmWithDg) for a force in decigrams, the same to the bit for every force, voltage and
// record (tests/core/thesis_runtime_test.cpp, tests/bench/thesis_fast_test.cpp on the bench's
// gathered records), in 16-bit operands: both curves' PWMs at the decigram (one EEPROM walk
// each: ThesisCurveRun::pwmTenths), the voltage term's two products as widening 16 x 16
// multiplications, and its rounded division by the record's fixed 10 (V2 - V1) through a
// reciprocal computed at load (ThesisRun::spanQuotient). A record off the 16-bit path
// (isFast()), a reading more than 32.767 V from V1 or a voltage term of 2^22 or more (a
// quotient of 16,000 us) takes forceToPwmWithDg itself.
template <class Storage>
ForcePwmResult forceToPwmDg(const ThesisRun& run, uint16_t force_dg, uint16_t vbat_mv,
                            const ForcePwmLimits& limits = ForcePwmLimits()) {
  using namespace thesis_detail;
  if (!run.isFast()) return forceToPwmDgGeneral<Storage>(run, force_dg, vbat_mv, limits);
  uint8_t flags = 0;
  if (!run.isCalibrated() || run.first.maxGrams() == 0) flags |= kNotCalibrated;
  if (force_dg == 0) flags |= kStopped;
  if (flags) return ForcePwmResult{limits.pwm_min_us, flags};

  static_assert(10u * kCurveGrams < 65536u, "a curve's heaviest force in decigrams fits 16 bits");
  // The force's grams and tenths: near the first curve's cursor (a motor holding or slowly
  // changing its force) by at most three subtractions, else a division.
  uint16_t grams = run.first.cursorGrams();
  int16_t below = static_cast<int16_t>(force_dg - static_cast<uint16_t>(10u * grams));
  if (below >= 10 * (kThesisNearGrams + 1) || below < -10 * kThesisNearGrams) {
    grams = div10(force_dg);
    below = static_cast<int16_t>(force_dg - static_cast<uint16_t>(10u * grams));
  } else {
    for (; below >= 10; below = static_cast<int16_t>(below - 10)) ++grams;
    for (; below < 0; below = static_cast<int16_t>(below + 10)) --grams;
  }
  const uint8_t tenths = static_cast<uint8_t>(below);
  if (force_dg > static_cast<uint16_t>(10u * run.first.maxGrams())) flags |= kSaturated;
  const uint16_t c1_x10 = run.first.pwmTenths<Storage>(grams, tenths);
  const uint16_t c1_us = div10(c1_x10);
  const uint8_t c1_tenths = static_cast<uint8_t>(c1_x10 - static_cast<uint16_t>(10u * c1_us));
  int16_t pwm_us = static_cast<int16_t>(c1_us + (c1_tenths >= 5 ? 1 : 0));  // the first curve alone
  if (vbat_mv < limits.v_min_mv || vbat_mv > limits.v_max_mv) {
    flags |= kVoltageInvalid;
  } else if (!run.hasSecondCurve() || run.second.maxGrams() == 0) {
    flags |= kSingleCurve;
  } else {
    const int16_t span_mv = run.spanMv();
    const int16_t min_span_mv = static_cast<int16_t>(limits.min_voltage_span_mv > 32767 ? 32767 : limits.min_voltage_span_mv);
    if (span_mv < min_span_mv && -span_mv < min_span_mv) {
      flags |= kEqualVoltages;
    } else {
      const int32_t dv_mv = static_cast<int32_t>(vbat_mv) - run.first.start_mv;
      if (dv_mv > 32767 || dv_mv < -32767) return forceToPwmDgGeneral<Storage>(run, force_dg, vbat_mv, limits);
      if (force_dg > static_cast<uint16_t>(10u * run.second.maxGrams())) flags |= kSaturated;
      const uint16_t c2_x10 = run.second.pwmTenths<Storage>(grams, tenths);
      const int16_t dc_x10 = static_cast<int16_t>(static_cast<int16_t>(c2_x10) - static_cast<int16_t>(c1_x10));
      // c1 + (c1_tenths span + dv dc) / (10 span), rounded to nearest, halves away from zero
      // (force_pwm_detail::divRound): |numerator| + 5 |span| over 10 |span|, then the sign.
      // A term of 2^22 or more (a quotient of 16,000 us or more) goes the 32-bit way, so c1 + q
      // stays inside int16 (q < 2^22 / 260).
      // c1_tenths |span| < 10 * 6554 fits 16 bits: an 8 x 16 product, no library call.
      const uint16_t tenths_span = static_cast<uint16_t>(c1_tenths * static_cast<uint16_t>(span_mv < 0 ? -span_mv : span_mv));
      const int32_t num = (span_mv < 0 ? -static_cast<int32_t>(tenths_span) : static_cast<int32_t>(tenths_span)) +
                          smul16(static_cast<int16_t>(dv_mv), dc_x10);
      const bool negative = (num < 0) != (span_mv < 0);
      const uint32_t m = (num < 0 ? 0u - static_cast<uint32_t>(num) : static_cast<uint32_t>(num)) + (run.spanX10() >> 1);
      if (m >= (1ul << 22)) return forceToPwmDgGeneral<Storage>(run, force_dg, vbat_mv, limits);
      const int16_t q = static_cast<int16_t>(run.spanQuotient(m));
      pwm_us = static_cast<int16_t>(c1_us + (negative ? -q : q));
    }
  }
  if (pwm_us < static_cast<int32_t>(limits.pwm_min_us)) return ForcePwmResult{limits.pwm_min_us, static_cast<uint8_t>(flags | kClamped)};
  if (pwm_us > static_cast<int32_t>(limits.pwm_max_us)) return ForcePwmResult{limits.pwm_max_us, static_cast<uint8_t>(flags | kClamped)};
  return ForcePwmResult{static_cast<uint16_t>(pwm_us), flags};
}

// The same for a force in whole grams (the thesis's own commands).
template <class Storage>
ForcePwmResult forceToPwm(const ThesisRun& run, uint16_t force_g, uint16_t vbat_mv,
                          const ForcePwmLimits& limits = ForcePwmLimits()) {
  const uint16_t force_dg = force_g > 6553 ? 65530 : static_cast<uint16_t>(10u * force_g);
  return forceToPwmDg<Storage>(run, force_dg, vbat_mv, limits);
}

}  // namespace tc
