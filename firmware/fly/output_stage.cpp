// The output stage (output_stage.hpp).
#include "output_stage.hpp"

#include "hal/hal.hpp"

namespace fly {

namespace {
uint16_t forceApiDg(ForceDg force) {
  return force <= 0 ? 0
                    : (force >= fw::ForceActuators::kMaxForceDg ? fw::ForceActuators::kMaxForceDg
                                                                : static_cast<uint16_t>(force));
}
constexpr int32_t kThrottleRangeUs = tc::kThrottleMaxUs - tc::kThrottleMinUs;
}  // namespace

bool OutputStage::setMode(OutputMode mode, uint8_t generic_slot) {
  if (mode == OutputMode::kGeneric && (generic_slot >= kMotors || !motors_.motor(generic_slot).isArmable())) {
    return false;
  }
  motors_.stopAll();
  for (uint8_t i = 0; i < kMotors; ++i)
    motors_.setModelSource(i, mode == OutputMode::kGeneric ? generic_slot : i);
  settings_.mode = mode;
  settings_.generic_slot = generic_slot;
  if (mode == OutputMode::kArduPilot) batteryRead(0);  // the filter from now, not from 1
  return true;
}

void OutputStage::setPwmParams(const PwmModeParams& p) {
  settings_.pwm = p;
  const bool valid = p.slope_g_per_us > 0;
  us_per_dg_q16_ = valid ? roundToInt32(65536.0f / (p.slope_g_per_us * kDgPerGram)) : 0;
  pwm_range_dg_ = valid ? forceDgOf(kThrottleRangeUs * p.slope_g_per_us) : 0;
}

void OutputStage::setArduPilotParams(const ArduPilotParams& p) {
  settings_.ardupilot = p;
  ardupilot_.setParams(p);
  batteryRead(0);
}

bool OutputStage::motorsReady(uint8_t mask) const {
  if (mode() == OutputMode::kPwm || mode() == OutputMode::kArduPilot) return true;  // no record flown
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (((mask >> i) & 1u) && !motors_.isArmable(i)) return false;
  }
  return true;
}

bool OutputStage::settingsReady() const {
  if (mode() == OutputMode::kPwm) return settings_.pwm.hover_us > tc::kThrottleMinUs && settings_.pwm.slope_g_per_us > 0;
  if (mode() == OutputMode::kArduPilot) return ardupilot_.ready();
  return true;
}

ForceLimits OutputStage::forceLimits(float thrust_g, uint8_t mask, uint8_t motors) const {
  ForceLimits l;
  switch (mode()) {
    case OutputMode::kPwm:
      l.collective =
          forceDgOf(static_cast<float>(settings_.pwm.hover_us - tc::kThrottleMinUs) * settings_.pwm.slope_g_per_us);
      l.min = 0;
      l.max = pwm_range_dg_;
      return l;
    case OutputMode::kArduPilot:
      l.min = 0;  // ArduPilot's zero thrust is MOT_SPIN_MIN: the motors keep turning
      l.max = forceDgOf(ardupilot_.maxForceG());
      break;
    default: {
      uint16_t lightest = fw::ForceActuators::kMaxForceDg;
      for (uint8_t i = 0; i < kMotors; ++i) {
        if (((mask >> i) & 1u) && motors_.maxForceDg(i) < lightest) lightest = motors_.maxForceDg(i);
      }
      l.min = forceDgOf(kIdleForceG);
      l.max = lightest;
      break;
    }
  }
  l.collective = motors == 0 ? 0 : forceDgOf(thrust_g / motors);
  return l;
}

uint8_t OutputStage::thesisMotors(uint8_t mask) const {
  if (mode() == OutputMode::kPwm || mode() == OutputMode::kArduPilot) return 0;
  uint8_t n = 0;
  for (uint8_t i = 0; i < kMotors; ++i) {
    const fw::Motor& m = motors_.motor(i);
    if (((mask >> i) & 1u) && motors_.isArmable(i) && !motors_.motor(m.source).fliesV2()) ++n;
  }
  return n;
}

// 1000 us + F / slope: (dg * Q16) >> 16 microseconds, rounded.
uint16_t OutputStage::pwmModePulse(ForceDg force) const {
  if (force <= 0) return tc::kThrottleMinUs;
  if (force >= pwm_range_dg_) return tc::kThrottleMaxUs;
  const int32_t above_us = (force * us_per_dg_q16_ + (1L << 15)) >> 16;
  return static_cast<uint16_t>(tc::kThrottleMinUs + (above_us >= kThrottleRangeUs ? kThrottleRangeUs : above_us));
}

void OutputStage::compute(const Forces& force, uint8_t mask) {
  if (mode() == OutputMode::kForce || mode() == OutputMode::kGeneric) {
    for (uint8_t i = 0; i < kMotors; ++i) motors_.setForceDg(i, ((mask >> i) & 1u) ? forceApiDg(force.dg[i]) : 0);
    motors_.computePulses();
    for (uint8_t i = 0; i < kMotors; ++i) pulse_us_[i] = motors_.motor(i).pwm_us;
    return;
  }
  for (uint8_t i = 0; i < kMotors; ++i) {
    if (!((mask >> i) & 1u)) {
      pulse_us_[i] = tc::kStopPwmUs;
    } else if (mode() == OutputMode::kPwm) {
      pulse_us_[i] = pwmModePulse(force.dg[i]);
    } else {
      pulse_us_[i] = ardupilot_.pulseUsDg(force.dg[i], segment_[i]);
    }
  }
}

// The pulses compute() worked out, all four at once (the force API's motors keep theirs, and
// their thesis motors' sag offsets for the next frame are looked up after the write).
void OutputStage::commit() {
  hal::Esc::writeAll(pulse_us_);
  if (mode() == OutputMode::kForce || mode() == OutputMode::kGeneric) motors_.prepareNextFrame();
}

void OutputStage::stop() {
  motors_.stopAll();
  for (uint16_t& p : pulse_us_) p = tc::kStopPwmUs;
}

void OutputStage::batteryRead(float dt_s) { ardupilot_.updateBattery(motors_.batteryMv(), dt_s); }

}  // namespace fly
