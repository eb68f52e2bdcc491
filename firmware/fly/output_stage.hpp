// The output stage: four forces in decigrams -> four ESC pulses, by the mode being compared
// (docs/fly.md, "Modes"):
//   force     each motor through its own record (the force API: v1 option 2.1 or model v2);
//   generic   every motor through one slot's record (the force API's model source): what an
//             aircraft flies with one motor measured, or a datasheet curve;
//   pwm       the thesis's Iqarus: the controller's output in microseconds around a hover pulse,
//             F -> 1000 us + F / slope (one straight line through the stop pulse and the hover
//             point: pulse_i = hover + (F_i - F_hover) / slope), no record, no battery;
//   ardupilot ArduPilot's thrust linearisation with the fitted parameters (ardupilot_curve.hpp):
//             one curve for all four, scaled with the battery voltage.
// Every mode takes the same decigrams (flight_types.hpp): the modes are compared at one
// resolution. Each mode also says which collective and force range the mixer works in
// (forceLimits), so saturation is handled where the motors (or the mode's model of them) end.
// A stage of fly's loop: Forces in, pulses out; it depends on no other stage.
#pragma once
#include <stdint.h>

#include "ardupilot_curve.hpp"
#include "flight_types.hpp"
#include "force_actuators.hpp"

namespace fly {

static_assert(kMotors == fw::ForceActuators::kMotors, "one flight motor per force-API motor");

constexpr uint16_t kIdleForceDg = 200;  // force and generic modes: armed motors never go below
constexpr float kIdleForceG = kIdleForceDg / 10.0f;  // the same in grams

struct PwmModeParams {
  uint16_t hover_us = 0;     // 0: not given (pwm mode refuses to arm)
  float slope_g_per_us = 0;  // the motors' force per microsecond around hover
};

// The output stage's settings, one plain struct (fly's parameters point at it).
struct OutputSettings {
  OutputMode mode = OutputMode::kForce;
  uint8_t generic_slot = 0;  // mode generic: the slot whose record every motor flies
  PwmModeParams pwm;
  ArduPilotParams ardupilot;
};

class OutputStage {
 public:
  // A start from a stop begins at the idle force: the force API keeps its thesis curves ready there.
  explicit OutputStage(fw::ForceActuators& motors) : motors_(motors) { motors_.setStartForceDg(kIdleForceDg); }

  // Only while stopped: generic mode points every motor at slot `generic_slot`'s model (the
  // others back at their own). False (nothing changed) when that slot holds no valid record.
  bool setMode(OutputMode mode, uint8_t generic_slot);
  OutputMode mode() const { return settings_.mode; }
  uint8_t genericSlot() const { return settings_.generic_slot; }
  void setPwmParams(const PwmModeParams& p);
  const PwmModeParams& pwmParams() const { return settings_.pwm; }
  // ArduPilot's parameters; its voltage filter starts from the present battery reading.
  void setArduPilotParams(const ArduPilotParams& p);
  const ArduPilotCurve& arduPilot() const { return ardupilot_; }
  const OutputSettings& settings() const { return settings_; }

  // Whether every motor in `mask` can fly in this mode, and whether the mode has its settings.
  bool motorsReady(uint8_t mask) const;
  bool settingsReady() const;
  // The mixer's limits for a total of `thrust_g` on the layout's motors (`mask`, `motors` of
  // them): the collective per motor at full spool (pwm: the hover pulse's force on its line; the
  // thrust setting does not apply) and the range of a motor's force the mixer may use.
  ForceLimits forceLimits(float thrust_g, uint8_t mask, uint8_t motors) const;
  // The motors in v1 (thesis) records among `mask` (the computation budget, fly_rules.hpp).
  uint8_t thesisMotors(uint8_t mask) const;

  // The four pulses for `force` (motors outside `mask` at the stop pulse): compute() works them
  // out, commit() writes the four at once (write() is both).
  void compute(const Forces& force, uint8_t mask);
  void commit();
  void write(const Forces& force, uint8_t mask) {
    compute(force, mask);
    commit();
  }
  // Every ESC to the stop pulse, now.
  void stop();
  // A battery reading came `dt_s` after the last one: the ardupilot mode's voltage filter.
  void batteryRead(float dt_s);
  uint16_t pulseUs(uint8_t motor) const { return pulse_us_[motor]; }

 private:
  uint16_t pwmModePulse(ForceDg force) const;

  fw::ForceActuators& motors_;
  OutputSettings settings_;
  // 1 / the slope in 1/65536 us per decigram, and the force of the whole throttle range: no
  // division per motor, and a force within that range times it stays within 26 bits.
  int32_t us_per_dg_q16_ = 0;
  ForceDg pwm_range_dg_ = 0;
  ArduPilotCurve ardupilot_;
  uint16_t pulse_us_[kMotors] = {tc::kStopPwmUs, tc::kStopPwmUs, tc::kStopPwmUs, tc::kStopPwmUs};
  uint8_t segment_[kMotors] = {0, 0, 0, 0};  // ardupilot: each motor's table segment (its hint)
};

}  // namespace fly
