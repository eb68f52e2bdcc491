#include "plant/fidelity.hpp"

#include <algorithm>

#include "plant/actuator.hpp"
#include "plant/bench.hpp"

namespace plant {

const std::array<Table51Row, 8> kTable51 = {{
    {9.7, 1572.0}, {10.0, 1555.0}, {10.5, 1535.0}, {11.0, 1514.0},
    {12.1, 1482.0}, {12.5, 1468.0}, {13.0, 1452.0}, {14.0, 1426.0},
}};

std::array<Table51Result, 8> runTable51(const ActuatorParams& params) {
  std::array<Table51Result, 8> out{};
  for (size_t i = 0; i < kTable51.size(); ++i) {
    BenchParams bp;
    bp.actuator = params;
    bp.power = BatteryParams::benchSupply(kTable51[i].supply_v, 6.32);
    const Bench bench(bp);
    const double pwm = bench.pulseForThrust_us(kTable51Thrust_g);
    out[i] = {kTable51[i].supply_v, kTable51[i].measured_pwm_us, pwm,
              pwm - kTable51[i].measured_pwm_us};
  }
  return out;
}

DatasheetCheck checkDatasheet(const ActuatorParams& params, const DatasheetPoint& datasheet) {
  DatasheetCheck c;
  c.datasheet = datasheet;
  const Actuator act(params, Environment{});
  // Duty that reaches the datasheet rpm (rpm rises monotonically with duty).
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (act.steadyStateAtDuty(mid, datasheet.bus_v).rpm < datasheet.rpm ? lo : hi) = mid;
  }
  const OperatingPoint at_rpm = act.steadyStateAtDuty(0.5 * (lo + hi), datasheet.bus_v);
  c.model_throttle = at_rpm.duty;
  c.model_thrust_g = at_rpm.thrust_g;
  c.model_current_a = at_rpm.bus_current_a;
  c.model_rpm = at_rpm.rpm;
  const OperatingPoint at_thr = act.steadyStateAtDuty(datasheet.throttle, datasheet.bus_v);
  c.at_throttle_thrust_g = at_thr.thrust_g;
  c.at_throttle_current_a = at_thr.bus_current_a;
  c.at_throttle_rpm = at_thr.rpm;
  return c;
}

double stepTimeConstant_s(const ActuatorParams& params, double bus_v, double pulse_from_us,
                          double pulse_to_us, double dt_s) {
  Actuator act(params, Environment{});
  act.holdPulse(pulse_from_us);
  act.setSpeed_rpm(act.steadyState(pulse_from_us, bus_v).rpm);
  for (int i = 0; i < static_cast<int>(0.5 / dt_s); ++i) act.step(dt_s, bus_v);
  const double rpm0 = act.rpm();
  const double rpm1 = act.steadyState(pulse_to_us, bus_v).rpm;
  const double target = rpm0 + 0.632 * (rpm1 - rpm0);
  act.holdPulse(pulse_to_us);
  const double t0 = act.time_s();
  double prev = rpm0;
  for (int i = 0; i < static_cast<int>(5.0 / dt_s); ++i) {
    act.step(dt_s, bus_v);
    const double now = act.rpm();
    if ((rpm1 - target) * (now - target) >= 0.0) {
      // Linear interpolation inside the step that crossed the target.
      const double frac = (now != prev) ? (target - prev) / (now - prev) : 1.0;
      return act.time_s() - t0 - dt_s * (1.0 - std::clamp(frac, 0.0, 1.0));
    }
    prev = now;
  }
  return -1.0;  // never reached: the step was too small or the motor did not respond
}

}  // namespace plant
