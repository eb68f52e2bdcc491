// The thesis bench: one actuator on the load-cell plate, powered by a LiPo or a bench supply,
// with the load cell on ADC channel 0 (A0) and the battery monitor on channel 1 (A1).
//
// Typical use by the simulator (all times in simulated seconds from 0):
//   plant::Bench bench(plant::BenchParams::thesis());
//   on each falling ESC edge:  bench.setPulse(width_us, edge_time_s);
//   every ~1 ms:               bench.step(0.001);
//   on each ADC conversion:    mv = bench.adcMillivolts(channel);
// step() costs well under a microsecond and never allocates.
#pragma once
#include "plant/actuator.hpp"
#include "plant/power_source.hpp"
#include "plant/sensors.hpp"

namespace plant {

struct BenchParams {
  ActuatorParams actuator;  // default: kv1100_9x4.7
  BatteryParams power;      // default: 3S LiPo, full
  LoadCellParams load_cell;
  BatterySensorParams battery_sensor;
  Environment env;

  // Thesis bench with a preset actuator: LiPo (full) or bench supply at set_v (6.32 A limit).
  static BenchParams thesis(const std::string& preset = "kv1100_9x4.7");
  static BenchParams thesisOnSupply(double set_v, const std::string& preset = "kv1100_9x4.7");
};

class Bench {
 public:
  explicit Bench(const BenchParams& params = BenchParams());

  void setPulse(double pulse_us, double t_s) { actuator_.setPulse(pulse_us, t_s); }
  // Advance dt_s: solve the bus voltage, step the actuator, drain the source, filter sensors.
  void step(double dt_s);
  // Run for duration_s in steps of dt_s (tests, the model lab).
  void run(double duration_s, double dt_s = 0.001);
  double time_s() const { return actuator_.time_s(); }

  // ADC channel 0 = load cell (A0), 1 = battery monitor (A1); other channels read 0 mV.
  // Draws sensor noise (each call is one conversion).
  double adcMillivolts(int channel);
  int readCounts(int channel) { return adcCountsFromMillivolts(adcMillivolts(channel)); }

  // Calibration weights on the plate (grams, on top of plate + motor + propeller).
  void placeWeight_g(double weight_g) { extra_weight_g_ += weight_g; }
  void removeWeights() { extra_weight_g_ = 0.0; }
  double extraWeight_g() const { return extra_weight_g_; }
  // Everything pressing the plate down except the plate itself: mount + weights - thrust.
  double downForce_g() const;

  double busVoltage_v() const { return bus_v_; }          // at ESC / monitor point
  double restingVoltage_v() const { return power_.restingVoltage_v(); }
  double busCurrent_a() const { return bus_current_a_; }

  Actuator& actuator() { return actuator_; }
  const Actuator& actuator() const { return actuator_; }
  PowerSource& power() { return power_; }
  const PowerSource& power() const { return power_; }
  LoadCellSensor& loadCell() { return load_cell_; }
  BatterySensor& batterySensor() { return battery_sensor_; }
  const BenchParams& params() const { return p_; }
  void setEnvironment(const Environment& env);

  // Steady state of the whole bench at a pulse (actuator + source + wiring, no time stepping;
  // winding at its present temperature, source in its present state).
  OperatingPoint steadyState(double pulse_us) const;
  // Lowest pulse giving thrust_g on this bench (bisection over steadyState() on the rising part
  // of the curve: past a supply's current limit thrust falls again); full_us if unreachable.
  double pulseForThrust_us(double thrust_g) const;

 private:
  BenchParams p_;
  Actuator actuator_;
  PowerSource power_;
  LoadCellSensor load_cell_;
  BatterySensor battery_sensor_;
  double extra_weight_g_ = 0.0;
  double bus_v_ = 0.0;
  double bus_current_a_ = 0.0;
};

}  // namespace plant
