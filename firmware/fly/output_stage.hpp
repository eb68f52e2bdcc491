// The output stage: four forces in grams -> four ESC pulses, by the mode being compared
// (docs/fly.md, "Modes"):
//   force     each motor through its own record (the force API: v1 option 2.1 or model v2);
//   generic   every motor through one slot's record (the force API's model source): what an
//             aircraft flies with one motor measured, or a datasheet curve;
//   pwm       the thesis's Iqarus: the controller's output in microseconds around a hover pulse,
//             F -> 1000 us + F / slope (one straight line through the stop pulse and the hover
//             point: pulse_i = hover + (F_i - F_hover) / slope), no record, no battery;
//   ardupilot ArduPilot's thrust linearisation with the fitted parameters (ardupilot_curve.hpp):
//             one curve for all four, scaled with the battery voltage.
// Each mode also says which collective and force range the mixer works in (forceRangeG), so
// saturation is handled where the motors (or the mode's model of them) really end.
#pragma once
#include <stdint.h>

#include "ardupilot_curve.hpp"
#include "fly_rules.hpp"
#include "force_actuators.hpp"
#include "mixer.hpp"

namespace fly {

constexpr float kIdleForceG = 20.0f;  // force and generic modes: armed motors never go below

struct PwmModeParams {
  uint16_t hover_us = 0;     // 0: not given (pwm mode refuses to arm)
  float slope_g_per_us = 0;  // the motors' force per microsecond around hover
};

class OutputStage {
 public:
  explicit OutputStage(fw::ForceActuators& motors) : motors_(motors) {}

  // Only while stopped: generic mode points every motor at slot `generic_slot`'s model (the
  // others back at their own). False (nothing changed) when that slot holds no valid record.
  bool setMode(OutputMode mode, uint8_t generic_slot);
  OutputMode mode() const { return mode_; }
  uint8_t genericSlot() const { return generic_slot_; }
  void setPwmParams(const PwmModeParams& p) {
    pwm_ = p;
    us_per_g_q12_ = p.slope_g_per_us > 0 ? static_cast<int32_t>(4096.0f / p.slope_g_per_us + 0.5f) : 0;
  }
  const PwmModeParams& pwmParams() const { return pwm_; }
  // ArduPilot's parameters; its voltage filter starts from the present battery reading.
  void setArduPilotParams(const ArduPilotParams& p);
  const ArduPilotCurve& arduPilot() const { return ardupilot_; }

  // Whether every motor in `mask` can fly in this mode, and whether the mode has its settings.
  bool motorsReady(uint8_t mask) const;
  bool settingsReady() const;
  // The collective per motor at full spool for a total of `thrust_g` on `motors` motors (pwm:
  // the hover pulse's force on its line; the thrust setting does not apply), and the range of a
  // motor's force the mixer may use.
  float collectivePerMotorG(float thrust_g, uint8_t motors) const;
  void forceRangeG(uint8_t mask, float& min_g, float& max_g) const;
  // The motors in v1 (thesis) records among `mask` (the computation budget, fly_rules.hpp).
  uint8_t thesisMotors(uint8_t mask) const;

  // The four pulses for `force` (motors outside `mask` at the stop pulse), written at once.
  void write(const ForceQ4 (&force)[4], uint8_t mask);
  // Every ESC to the stop pulse, now.
  void stop();
  // A battery reading came `dt_s` after the last one: the ardupilot mode's voltage filter.
  void batteryRead(float dt_s);
  uint16_t pulseUs(uint8_t motor) const { return pulse_us_[motor]; }

 private:
  uint16_t pwmModePulse(ForceQ4 force) const;

  fw::ForceActuators& motors_;
  OutputMode mode_ = OutputMode::kForce;
  uint8_t generic_slot_ = 0;
  PwmModeParams pwm_;
  // 1 / the slope in 1/4096 us per g: no division per motor, and F (Q4, at most 1000 us of
  // pulse) times it stays within 26 bits whatever the slope.
  int32_t us_per_g_q12_ = 0;
  ArduPilotCurve ardupilot_;
  uint16_t pulse_us_[4] = {tc::kStopPwmUs, tc::kStopPwmUs, tc::kStopPwmUs, tc::kStopPwmUs};
};

}  // namespace fly
