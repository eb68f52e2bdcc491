// Force curve lookups: checkpoint every 32 g, then at most 31 byte additions.
#include "thrustcal/force_curve.hpp"

namespace tc {

uint16_t ForceCurveBase::pwmForGrams(uint16_t grams) const {
  const uint16_t max_grams = maxGrams();
  if (grams == 0 || max_grams == 0) return 0;
  if (grams > max_grams) grams = max_grams;
  const uint16_t index = static_cast<uint16_t>(grams - 1);  // grams above 1 g
  const uint16_t k = static_cast<uint16_t>(index / kCheckpointEvery);
  uint16_t pwm = checkpoints_[k];
  // steps_[i] is pwm(i + 2) - pwm(i + 1); the checkpoint holds pwm(1 + k * 32). A pointer
  // loop: avr-gcc keeps it in registers, unlike an indexed one.
  const uint8_t* step = steps_ + k * kCheckpointEvery;
  const uint8_t* const end = steps_ + index;
  while (step < end) pwm = static_cast<uint16_t>(pwm + *step++);
  return pwm;
}

bool ForceCurveBase::finalize() {
  const uint16_t checkpoint_count = static_cast<uint16_t>((grams_ - 1u) / kCheckpointEvery + 1u);
  bool consistent = true;
  uint16_t max_grams = 0;
  uint32_t pwm = pwm_at_1g_us;
  if (pwm_at_1g_us != 0) {
    max_grams = 1;
    checkpoints_[0] = pwm_at_1g_us;
    bool ended = false;
    for (uint16_t i = 0; i < stepCount(); ++i) {
      if (!ended) {
        if (steps_[i] == kUnreachable || pwm + steps_[i] > 0xFFFFul) {
          if (steps_[i] != kUnreachable) consistent = false;
          ended = true;
        } else {
          pwm += steps_[i];
          ++max_grams;  // gram i + 2 reached
          if (((i + 1u) % kCheckpointEvery) == 0)
            checkpoints_[(i + 1u) / kCheckpointEvery] = static_cast<uint16_t>(pwm);
          continue;
        }
      }
      if (steps_[i] != kUnreachable) consistent = false;
      steps_[i] = kUnreachable;
    }
  } else {
    for (uint16_t i = 0; i < stepCount(); ++i) {
      if (steps_[i] != kUnreachable) consistent = false;
      steps_[i] = kUnreachable;
    }
  }
  // Checkpoints past the heaviest gram are never read; keep them defined anyway.
  const uint16_t first_unused = max_grams ? static_cast<uint16_t>((max_grams - 1u) / kCheckpointEvery + 1u) : 0;
  for (uint16_t k = first_unused; k < checkpoint_count; ++k) checkpoints_[k] = static_cast<uint16_t>(pwm);
  max_grams_ = max_grams;
  return consistent;
}

void ForceCurveBase::clear() {
  start_mv = 0;
  pwm_at_1g_us = 0;
  for (uint16_t i = 0; i < stepCount(); ++i) steps_[i] = kUnreachable;
  finalize();
}

}  // namespace tc
