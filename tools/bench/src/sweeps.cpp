#include "bench/sweeps.hpp"

#include <algorithm>
#include <cmath>

#include "plant/bench.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/load_cell.hpp"

namespace bench {

namespace {

constexpr int kForceReadings = 201;    // gather_store: median of 201
constexpr int kBatteryReadings = 101;  // gather_store: median of 101

uint16_t medianCounts(plant::Bench& bench, int channel, int n) {
  std::vector<int> v(static_cast<size_t>(n));
  for (int& c : v) c = bench.readCounts(channel);
  std::nth_element(v.begin(), v.begin() + n / 2, v.end());
  return static_cast<uint16_t>(v[static_cast<size_t>(n / 2)]);
}

}  // namespace

plant::BatteryParams lipoAt(double rest_v) {
  plant::BatteryParams p = plant::BatteryParams::lipo3s(1.0);
  p.soc = plant::socForCellOcv(rest_v / p.cells);
  return p;
}

Sweep simulateSweep(const plant::ActuatorParams& motor, const plant::BatteryParams& power,
                    const SweepSpec& spec) {
  plant::BenchParams params;
  params.actuator = motor;
  params.power = power;
  params.load_cell.seed = spec.noise_seed * 2654435761u + 17;
  params.battery_sensor.seed = spec.noise_seed * 40503u + 29;
  plant::Bench bench(params);
  Sweep sweep;
  sweep.rest_v = bench.restingVoltage_v();

  // Motor at rest, pulse at the bottom: let the filters settle, then tare.
  bench.actuator().holdPulse(spec.pwm_min_us);
  bench.run(0.5);
  tc::LoadCell cell;
  cell.tare(medianCounts(bench, 0, kForceReadings));
  const tc::BatteryMonitor monitor;

  const double settle_s = spec.settle_ms / 1000.0;
  for (int pwm = spec.pwm_min_us; pwm <= spec.pwm_max_us; pwm += spec.step_us) {
    bench.actuator().holdPulse(pwm);
    bench.run(settle_s);
    SweepPoint pt;
    pt.pwm_us = static_cast<uint16_t>(pwm);
    const int32_t mg = cell.forceMilligrams(medianCounts(bench, 0, kForceReadings));
    pt.force_dg = static_cast<int16_t>(std::clamp<int32_t>(
        static_cast<int32_t>(std::lround(mg / 100.0)), INT16_MIN, INT16_MAX));
    pt.vbat_mv = monitor.millivoltsFromCounts(medianCounts(bench, 1, kBatteryReadings));
    pt.true_thrust_g = bench.actuator().thrust_g();
    pt.true_bus_v = bench.busVoltage_v();
    sweep.points.push_back(pt);
  }
  bench.actuator().holdPulse(spec.pwm_min_us);
  sweep.simulated_s = bench.time_s();
  return sweep;
}

}  // namespace bench
