#include "plant/bench.hpp"

#include <algorithm>

#include "hal/board.hpp"

namespace plant {

BenchParams BenchParams::thesis(const std::string& preset) {
  BenchParams p;
  p.actuator = presetParams(preset);
  p.power = BatteryParams::lipo3s(1.0);
  return p;
}

BenchParams BenchParams::thesisOnSupply(double set_v, const std::string& preset) {
  BenchParams p = thesis(preset);
  p.power = BatteryParams::benchSupply(set_v, 6.32);
  return p;
}

Bench::Bench(const BenchParams& params)
    : p_(params),
      actuator_(params.actuator, params.env),
      power_(params.power),
      load_cell_(params.load_cell),
      battery_sensor_(params.battery_sensor) {
  bus_v_ = power_.solveBusVoltage(actuator_.busLoad());
  load_cell_.settle(downForce_g());
  battery_sensor_.settle(bus_v_);
}

void Bench::setEnvironment(const Environment& env) {
  p_.env = env;
  actuator_.setEnvironment(env);
}

double Bench::downForce_g() const {
  return p_.actuator.mountWeight_g() + extra_weight_g_ - actuator_.thrust_g();
}

void Bench::step(double dt_s) {
  bus_v_ = power_.solveBusVoltage(actuator_.busLoad());
  bus_current_a_ = actuator_.step(dt_s, bus_v_);
  power_.step(dt_s, bus_current_a_);
  load_cell_.step(dt_s, downForce_g(), actuator_.thrust_g());
  battery_sensor_.step(dt_s, bus_v_);
}

void Bench::run(double duration_s, double dt_s) {
  const double end = time_s() + duration_s - 0.5 * dt_s;
  while (time_s() < end) step(dt_s);
}

double Bench::adcMillivolts(int channel) {
  switch (channel) {
    case hal::kAdcLoadCell: return load_cell_.adcMillivolts();
    case hal::kAdcBattery: return battery_sensor_.adcMillivolts();
    default: return 0.0;
  }
}

OperatingPoint Bench::steadyState(double pulse_us) const {
  // Find the bus voltage V at which the source, loaded by the actuator's steady bus current
  // I(V), delivers V. V - V_source(I(V)) rises with V, so bisection converges.
  const double v_max = std::max(power_.openCircuitVoltage_v(), power_.restingVoltage_v());
  double lo = 0.0, hi = v_max;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    const double i_bus = actuator_.steadyState(pulse_us, mid).bus_current_a;
    const double v_src = power_.solveBusVoltage(BusLoad{0.0, i_bus});
    (mid < v_src ? lo : hi) = mid;
  }
  return actuator_.steadyState(pulse_us, 0.5 * (lo + hi));
}

double Bench::pulseForThrust_us(double thrust_g) const {
  const EscParams& e = p_.actuator.esc;
  double lo = e.start_us, hi = e.full_us;
  if (thrust_g <= 0.0) return lo;
  // A current-limited supply makes thrust fall again past the limit, so find the first 10 us
  // bracket on the rising part instead of assuming monotony over the whole range.
  bool found = false;
  for (double p = lo + 10.0; p < e.full_us + 10.0; p += 10.0) {
    hi = std::min(p, e.full_us);
    if (steadyState(hi).thrust_g >= thrust_g) {
      found = true;
      break;
    }
    lo = hi;
  }
  if (!found) return e.full_us;
  for (int i = 0; i < 50; ++i) {
    const double mid = 0.5 * (lo + hi);
    (steadyState(mid).thrust_g < thrust_g ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace plant
