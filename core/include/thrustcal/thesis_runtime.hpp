// The thesis model (record layout v1, option 2.1) as read_run flies it, in a fraction of the
// SRAM of the decoded record (tc::MotorCalibration): the curves' 499 PWM steps per curve stay
// in the EEPROM and are read on demand; SRAM keeps each curve's PWM every 16 grams
// (checkpoints), its start voltage and heaviest gram, and the sag table.
//
// A lookup adds at most 15 steps read from the EEPROM to a checkpoint: the same sum the decoded
// curve makes from its own checkpoints every 32 g, so the PWM is the same to the bit for every
// gram and every battery reading (tests/core/thesis_runtime_test.cpp sweeps them all against
// tc::forceToPwm on the decoded record). The EEPROM does not change while read_run or fly flies
// (neither writes it), and load() checks every checkpoint it computes from the EEPROM against
// the decoded, CRC-checked record.
//
// Each curve keeps the running sums of the last 16-gram block it looked up (30 bytes): a motor
// holding a force looks up the same block frame after frame, and then a lookup is a checkpoint
// plus one sum from SRAM instead of up to 15 EEPROM reads and additions (on the ATmega2560 at
// 400 Hz that is about 6 % of the CPU for four motors: thrustcal bench fly). Another block is
// read whole (the steps the curve has) and summed once.
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

struct ThesisCurveRun {
  uint16_t start_mv = 0;    // 0: no curve
  uint16_t max_grams = 0;   // heaviest gram the curve reaches
  uint16_t steps_addr = 0;  // EEPROM address of the step pwm(2 g) - pwm(1 g)
  uint16_t checkpoint_us[kThesisCheckpoints] = {};  // PWM at 1 + 16 k grams

  bool isPresent() const { return start_mv != 0; }
  uint16_t maxGrams() const { return isPresent() ? max_grams : 0; }

  // As ForceCurveBase::pwmForGrams: 0 for gram 0 or an absent/empty curve, the heaviest
  // gram's PWM above it. At most kThesisCheckpointEvery - 1 EEPROM bytes.
  template <class Storage>
  uint16_t pwmForGrams(uint16_t grams) const {
    const uint16_t max = maxGrams();
    if (grams == 0 || max == 0) return 0;
    if (grams > max) grams = max;
    const uint16_t index = static_cast<uint16_t>(grams - 1);
    const uint8_t k = static_cast<uint8_t>(index / kThesisCheckpointEvery);
    const uint8_t n = static_cast<uint8_t>(index % kThesisCheckpointEvery);
    if (n == 0) return checkpoint_us[k];
    if (cached_block_ != k) cacheBlock<Storage>(k);
    return static_cast<uint16_t>(checkpoint_us[k] + cached_sums_[n - 1]);
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
  static constexpr uint8_t kNoBlock = 0xFF;

  // The running sums of block k's steps: cached_sums_[j] = steps k*16 .. k*16 + j, for the
  // steps the curve has (grams up to max_grams). Not inlined: its buffer and registers would
  // make every lookup save and restore them, the hits too.
  template <class Storage>
  __attribute__((noinline)) void cacheBlock(uint8_t k) const {
    const uint16_t first = static_cast<uint16_t>(k * kThesisCheckpointEvery);
    const uint16_t left = static_cast<uint16_t>(max_grams - 1 - first);  // steps from `first` on
    const uint8_t length = left < kThesisCheckpointEvery - 1 ? static_cast<uint8_t>(left) : kThesisCheckpointEvery - 1;
    uint8_t steps[kThesisCheckpointEvery - 1];
    Storage::readBlock(static_cast<uint16_t>(steps_addr + first), steps, length);
    uint16_t sum = 0;
    for (uint8_t j = 0; j < length; ++j) {
      sum = static_cast<uint16_t>(sum + steps[j]);
      cached_sums_[j] = sum;
    }
    cached_block_ = k;
  }

  mutable uint8_t cached_block_ = kNoBlock;
  mutable uint16_t cached_sums_[kThesisCheckpointEvery - 1] = {};
};

struct ThesisRun {
  ThesisCurveRun first;   // first.start_mv == 0: not calibrated
  ThesisCurveRun second;  // second.start_mv == 0: no second curve
  SagTable sag;

  bool isCalibrated() const { return first.isPresent(); }
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
    return true;
  }
};

// Option 2.1 on a ThesisRun: tc::forceToPwm's arithmetic (forceToPwmWithDg) with the curves'
// steps read from Storage, for a force in decigrams (what the force API flies) or whole grams.
template <class Storage>
ForcePwmResult forceToPwmDg(const ThesisRun& run, uint16_t force_dg, uint16_t vbat_mv,
                            const ForcePwmLimits& limits = ForcePwmLimits()) {
  return forceToPwmWithDg(run, force_dg, vbat_mv, limits, [](const ThesisCurveRun& curve, uint16_t grams) {
    return curve.pwmForGrams<Storage>(grams);
  });
}
template <class Storage>
ForcePwmResult forceToPwm(const ThesisRun& run, uint16_t force_g, uint16_t vbat_mv,
                          const ForcePwmLimits& limits = ForcePwmLimits()) {
  return forceToPwmWith(run, force_g, vbat_mv, limits, [](const ThesisCurveRun& curve, uint16_t grams) {
    return curve.pwmForGrams<Storage>(grams);
  });
}

}  // namespace tc
