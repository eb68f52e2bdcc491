// The output stage (output_stage.hpp).
#include "output_stage.hpp"

#include "hal/hal.hpp"

namespace fly {

namespace {
constexpr uint8_t kMotors = fw::ForceActuators::kMotors;
uint16_t grams(ForceQ4 force) {
  const int32_t g = roundedGrams(force);
  return g <= 0 ? 0 : (g >= tc::kRecordMaxForceG ? tc::kRecordMaxForceG : static_cast<uint16_t>(g));
}
}  // namespace

bool OutputStage::setMode(OutputMode mode, uint8_t generic_slot) {
  if (mode == OutputMode::kGeneric && (generic_slot >= kMotors || !motors_.motor(generic_slot).isArmable())) {
    return false;
  }
  motors_.stopAll();
  for (uint8_t i = 0; i < kMotors; ++i)
    motors_.setModelSource(i, mode == OutputMode::kGeneric ? generic_slot : i);
  mode_ = mode;
  generic_slot_ = generic_slot;
  if (mode == OutputMode::kArduPilot) batteryRead(0);  // the filter from now, not from 1
  return true;
}

void OutputStage::setArduPilotParams(const ArduPilotParams& p) {
  ardupilot_.setParams(p);
  batteryRead(0);
}

bool OutputStage::motorsReady(uint8_t mask) const {
  if (mode_ == OutputMode::kPwm || mode_ == OutputMode::kArduPilot) return true;  // no record flown
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (((mask >> i) & 1u) && !motors_.isArmable(i)) return false;
  }
  return true;
}

bool OutputStage::settingsReady() const {
  if (mode_ == OutputMode::kPwm) return pwm_.hover_us > tc::kThrottleMinUs && pwm_.slope_g_per_us > 0;
  if (mode_ == OutputMode::kArduPilot) return ardupilot_.ready();
  return true;
}

float OutputStage::collectivePerMotorG(float thrust_g, uint8_t motors) const {
  if (mode_ == OutputMode::kPwm) {
    return static_cast<float>(pwm_.hover_us - tc::kThrottleMinUs) * pwm_.slope_g_per_us;
  }
  return motors == 0 ? 0.0f : thrust_g / motors;
}

void OutputStage::forceRangeG(uint8_t mask, float& min_g, float& max_g) const {
  switch (mode_) {
    case OutputMode::kPwm:
      min_g = 0;
      max_g = static_cast<float>(tc::kThrottleMaxUs - tc::kThrottleMinUs) * pwm_.slope_g_per_us;
      return;
    case OutputMode::kArduPilot:
      min_g = 0;  // ArduPilot's zero thrust is MOT_SPIN_MIN: the motors keep turning
      max_g = ardupilot_.maxForceG();
      return;
    default: {
      uint16_t lightest = tc::kRecordMaxForceG;
      for (uint8_t i = 0; i < kMotors; ++i) {
        if (((mask >> i) & 1u) && motors_.maxForceG(i) < lightest) lightest = motors_.maxForceG(i);
      }
      min_g = kIdleForceG;
      max_g = lightest;
      return;
    }
  }
}

uint8_t OutputStage::thesisMotors(uint8_t mask) const {
  if (mode_ == OutputMode::kPwm || mode_ == OutputMode::kArduPilot) return 0;
  uint8_t n = 0;
  for (uint8_t i = 0; i < kMotors; ++i) {
    const fw::Motor& m = motors_.motor(i);
    if (((mask >> i) & 1u) && motors_.isArmable(i) && !motors_.motor(m.source).fliesV2()) ++n;
  }
  return n;
}

// 1000 us + F / slope: (Q4 * Q12) >> 16 microseconds, rounded.
uint16_t OutputStage::pwmModePulse(ForceQ4 force) const {
  const int32_t above_us = (force * us_per_g_q12_ + (1L << 15)) >> 16;
  const int32_t range_us = tc::kThrottleMaxUs - tc::kThrottleMinUs;
  return static_cast<uint16_t>(tc::kThrottleMinUs +
                               (above_us <= 0 ? 0 : (above_us >= range_us ? range_us : above_us)));
}

void OutputStage::write(const ForceQ4 (&force)[4], uint8_t mask) {
  if (mode_ == OutputMode::kForce || mode_ == OutputMode::kGeneric) {
    for (uint8_t i = 0; i < kMotors; ++i) motors_.setForce(i, ((mask >> i) & 1u) ? grams(force[i]) : 0);
    motors_.output();
    for (uint8_t i = 0; i < kMotors; ++i) pulse_us_[i] = motors_.motor(i).pwm_us;
    return;
  }
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (!((mask >> i) & 1u)) {
      pulse_us_[i] = tc::kStopPwmUs;
    } else if (mode_ == OutputMode::kPwm) {
      pulse_us_[i] = pwmModePulse(force[i]);
    } else {
      pulse_us_[i] = ardupilot_.pulseUsQ4(force[i]);
    }
  }
  hal::Esc::writeAll(pulse_us_);
}

void OutputStage::stop() {
  motors_.stopAll();
  for (uint16_t& p : pulse_us_) p = tc::kStopPwmUs;
}

void OutputStage::batteryRead(float dt_s) { ardupilot_.updateBattery(motors_.batteryMv(), dt_s); }

}  // namespace fly
