// `sim gather`'s checks of what gather_store stored (internal to tools/sim): the plant's true
// thrust per PWM, the stored model as a PWM per gram, its error against the truth, the curves'
// CSV and the result's JSON (gather_checks.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "plant/bench.hpp"
#include "sim/scenarios.hpp"
#include "thrustcal/model_v2.hpp"

namespace sim::gather_checks {

// The plant's steady-state thrust at every whole PWM 1000..2000 us on a frozen bench (power
// source and winding temperature as when the snapshot was taken): stored PWMs are whole
// microseconds, so the thrust at a stored PWM is an exact lookup.
struct TruthTable {
  static constexpr int kLo = 1000, kHi = 2000;
  std::vector<double> thrust_g, bus_v;
  explicit TruthTable(const plant::Bench& bench) {
    thrust_g.reserve(kHi - kLo + 1);
    bus_v.reserve(kHi - kLo + 1);
    for (int p = kLo; p <= kHi; ++p) {
      const plant::OperatingPoint op = bench.steadyState(p);
      thrust_g.push_back(op.thrust_g);
      bus_v.push_back(op.bus_v);
    }
  }
  static std::size_t index(int pwm_us) {
    return static_cast<std::size_t>(std::clamp(pwm_us, kLo, kHi) - kLo);
  }
  double thrustAt(int pwm_us) const { return thrust_g[index(pwm_us)]; }
  double busVoltsAt(int pwm_us) const { return bus_v[index(pwm_us)]; }
  // Smallest PWM (interpolated) whose thrust reaches `grams`; NaN when out of reach.
  double pwmFor(double grams) const {
    for (std::size_t i = 1; i < thrust_g.size(); ++i)
      if (thrust_g[i] >= grams && thrust_g[i - 1] < grams)
        return kLo + (i - 1) + (grams - thrust_g[i - 1]) / (thrust_g[i] - thrust_g[i - 1]);
    return std::nan("");
  }
};

// A stored model as the checks see it: the PWM it gives for each whole gram at one sweep's
// conditions, up to the heaviest gram it reaches there.
struct StoredCurve {
  double start_v = 0;
  int max_g = 0;
  std::function<int(int)> pwm_us_for_g;
};

std::string truePwm(const TruthTable& t, double grams);
StoredCurve thesisCurve(const tc::ThesisCurve& curve);
StoredCurve modelV2Curve(const tc::ModelV2& model, uint16_t rest_mv, const TruthTable& truth);
void checkCurve(const StoredCurve& curve, const TruthTable& truth, const GatherOptions& o, CurveCheck& out);
std::array<StoredCurve, 2> storedCurves(const std::vector<uint8_t>& eeprom, const GatherOptions& o,
                                        const std::array<TruthTable, 2>& truth, GatherMotorResult& mr);
void writeCurvesCsv(const GatherOptions& o, const std::array<StoredCurve, 2>& stored,
                    const std::array<TruthTable, 2>& tables, GatherMotorResult& mr);

}  // namespace sim::gather_checks
