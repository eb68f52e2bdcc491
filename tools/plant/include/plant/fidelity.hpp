// Reference measurements the plant is checked against (thesis table 5.1, T-motor datasheet),
// and the model's answers to the same questions. Used by the fidelity tests and by
// `thrustcal plant table51`.
#pragma once
#include <array>
#include <string>
#include "plant/params.hpp"

namespace plant {

struct Table51Row {
  double supply_v;
  double measured_pwm_us;  // thesis: PWM giving 300 g on the bench supply
};
// Thesis table 5.1: KV1100 + APC 9x4.7, bench supply (6.32 A limit), 300 g.
extern const std::array<Table51Row, 8> kTable51;
constexpr double kTable51Thrust_g = 300.0;

struct Table51Result {
  double supply_v;
  double measured_pwm_us;
  double model_pwm_us;   // pulse for 300 g in steady state on the thesis bench at that voltage
  double diff_us;        // model - measured
};
// Runs the thesis bench (bench supply at each voltage, 6.32 A, cold motor at 20 C) for the
// given actuator and finds the pulse for 300 g at each row.
std::array<Table51Result, 8> runTable51(const ActuatorParams& params);

struct DatasheetCheck {
  DatasheetPoint datasheet;
  // The model's operating point at the datasheet's rpm and bus voltage: the throttle it needs,
  // the thrust and the bus current it gives there.
  double model_throttle = 0.0;
  double model_thrust_g = 0.0;
  double model_current_a = 0.0;
  double model_rpm = 0.0;
  // And at the datasheet's throttle taken literally as ESC duty.
  double at_throttle_thrust_g = 0.0;
  double at_throttle_current_a = 0.0;
  double at_throttle_rpm = 0.0;
};
// Datasheet bench: ideal supply at datasheet.bus_v (no wiring), cold motor, 20 C air.
DatasheetCheck checkDatasheet(const ActuatorParams& params, const DatasheetPoint& datasheet);

// Step response: holds pulse_from_us until steady, steps to pulse_to_us at a fixed bus voltage
// and returns the time (s) until the rpm has covered 63.2 % of its change (first-order tau).
double stepTimeConstant_s(const ActuatorParams& params, double bus_v, double pulse_from_us,
                          double pulse_to_us, double dt_s = 0.0005);

}  // namespace plant
