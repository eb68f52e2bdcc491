#include "bench/sweeps.hpp"

#include <algorithm>
#include <cmath>

#include "plant/bench.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/load_cell.hpp"
#include "thrustcal/limits.hpp"
#include "thrustcal/median_filter.hpp"
#include "thrustcal/sweep_lag.hpp"
#include "thrustcal/sweep_rules.hpp"

namespace bench {

namespace {

// The time gather_store's 201 force readings take (201 conversions of 104 us): the sweep's
// clock runs on by this much after each force median.
constexpr uint32_t kForceReadingMs = 21;

uint16_t medianCounts(plant::Bench& bench, int channel, int n) {
  std::vector<int> v(static_cast<size_t>(n));
  for (int& c : v) c = bench.readCounts(channel);
  std::nth_element(v.begin(), v.begin() + n / 2, v.end());
  return static_cast<uint16_t>(v[static_cast<size_t>(n / 2)]);
}

// 201 load-cell readings: their median, and in `q4` the reading the sweep converts (fine: the
// mean of the middle 65 in 1/16 count, as gather_store since issue 11; else the median * 16).
uint16_t forceCounts(plant::Bench& bench, bool fine, uint16_t& q4) {
  static tc::MedianFilter<tc::kForceWindow> window;
  window.reset();
  for (int i = 0; i < tc::kForceWindow; ++i) window.push(static_cast<uint16_t>(bench.readCounts(0)));
  const uint16_t median = window.median();
  q4 = fine ? window.centralMeanQ4(tc::kForceCentral) : static_cast<uint16_t>(median * 16u);
  return median;
}

// gather_store's settle auto (tc::settleAutoNext / settleAutoDone): force medians until the
// rule says the step has settled or the cap has passed. Returns the last median's counts.
uint16_t settleByMeasurement(plant::Bench& bench, const SweepSpec& spec, uint16_t& q4) {
  tc::SettleAuto settle;
  uint32_t waited_ms = 0;
  uint16_t counts = 0;
  do {
    bench.run(tc::kSettleProbeMs / 1000.0);
    counts = forceCounts(bench, spec.fine_force, q4);
    bench.run(kForceReadingMs / 1000.0);
    waited_ms += tc::kSettleProbeMs + kForceReadingMs;
    settle = tc::settleAutoNext(settle, counts);
  } while (!tc::settleAutoDone(settle, waited_ms, static_cast<uint16_t>(spec.settle_ms)));
  return counts;
}

// The corrector is one step behind: the reading just taken in, the one before it corrected.
void correctLastButOne(tc::SweepLagCorrector& lag, double edge_s, double read_s, std::vector<SweepPoint>& points) {
  const SweepPoint& p = points.back();
  tc::SweepPointV2 out;
  if (lag.push(static_cast<float>(edge_s), static_cast<float>(read_s), {p.pwm_us, p.force_dg, p.vbat_mv}, out))
    points[points.size() - 2].force_dg = out.force_dg;
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
  uint16_t q4 = 0;
  forceCounts(bench, spec.fine_force, q4);
  cell.tareQ4(q4);
  const tc::BatteryMonitor monitor;

  const double settle_s = spec.settle_ms / 1000.0;
  const bool correct = !spec.settle_auto && spec.lag_dynamics.isPresent();
  tc::SweepLagCorrector lag;
  lag.start(spec.lag_dynamics, spec.lag_bench);
  for (int pwm = spec.pwm_min_us; pwm <= spec.pwm_max_us; pwm += spec.step_us) {
    const double edge_s = bench.time_s();
    bench.actuator().holdPulse(pwm);
    if (spec.settle_auto) {
      settleByMeasurement(bench, spec, q4);
    } else {
      bench.run(settle_s);
      forceCounts(bench, spec.fine_force, q4);
    }
    SweepPoint pt;
    pt.pwm_us = static_cast<uint16_t>(pwm);
    const int32_t mg = cell.forceMilligramsQ4(q4);
    pt.force_dg = static_cast<int16_t>(std::clamp<int32_t>(
        static_cast<int32_t>(std::lround(mg / 100.0)), INT16_MIN, INT16_MAX));
    pt.vbat_mv = monitor.millivoltsFromCounts(medianCounts(bench, 1, tc::kBatteryWindow));
    pt.true_thrust_g = bench.actuator().thrust_g();
    pt.true_bus_v = bench.busVoltage_v();
    sweep.points.push_back(pt);
    if (correct) correctLastButOne(lag, edge_s, bench.time_s(), sweep.points);
  }
  if (correct) {
    tc::SweepPointV2 out;
    if (lag.finish(out)) sweep.points.back().force_dg = out.force_dg;
    sweep.largest_correction_g = lag.largestCorrectionDg() / 10.0;
  }
  bench.actuator().holdPulse(spec.pwm_min_us);
  sweep.simulated_s = bench.time_s();
  return sweep;
}

uint16_t monitorReading_mv(double bus_v) {
  const plant::BatterySensorParams sensor;
  const int counts = plant::adcCountsFromMillivolts(bus_v * 1000.0 * sensor.ratio());
  return tc::BatteryMonitor().millivoltsFromCounts(static_cast<uint16_t>(counts));
}

}  // namespace bench
