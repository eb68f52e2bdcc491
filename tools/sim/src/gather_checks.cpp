// `sim gather`'s checks of what gather_store stored (gather_checks.hpp).
#include "gather_checks.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace sim {
namespace gather_checks {

std::string truePwm(const TruthTable& t, double grams) {
  const double p = t.pwmFor(grams);
  return std::isnan(p) ? std::string() : fmt::format("{:.1f}", p);
}

StoredCurve thesisCurve(const tc::ThesisCurve& curve) {
  return {curve.start_mv / 1000.0, curve.maxGrams(),
          [curve](int g) { return static_cast<int>(curve.pwmForGrams(static_cast<uint16_t>(g))); }};
}

// Model v2 at a sweep's conditions, in steady state as read_run holds a force: the bus
// voltage is what the plant settles at for the PWM sent (a fixed point, found by iterating
// from the resting voltage; the motor's own command does not change, so no sag prediction).
// The curve refers to `truth`, which must outlive it.
StoredCurve modelV2Curve(const tc::ModelV2& model, uint16_t rest_mv, const TruthTable& truth) {
  auto pwm = [model, rest_mv, &truth](int g) {
    tc::BusVoltageFilter bus;
    bus.reset(rest_mv);
    uint16_t pwm_us = 0;
    for (int i = 0; i < 6; ++i) {
      pwm_us = tc::forceToPwmV2(model, static_cast<uint16_t>(g * 10), bus).pwm_us;
      bus.reset(static_cast<uint16_t>(std::lround(truth.busVoltsAt(pwm_us) * 1000)));
    }
    return static_cast<int>(pwm_us);
  };
  return {rest_mv / 1000.0, model.maxForceDg() / 10, pwm};
}

// Error of a stored curve against the truth over band_min_g .. band_top_frac * its heaviest
// gram, no heavier than the sweep measured (v1's curve ends there anyway; v2's curve, shared
// by both sweeps, goes on where the sweep's supply could not follow).
void checkCurve(const StoredCurve& curve, const TruthTable& truth, const GatherOptions& o,
                CurveCheck& out) {
  out.start_v = curve.start_v;
  out.max_g = std::min(curve.max_g, static_cast<int>(std::floor(out.sweep_max_g)));
  out.band_lo_g = o.band_min_g;
  out.band_hi_g = std::floor(o.band_top_frac * out.max_g);
  double sum2 = 0;
  int n = 0;
  out.error_max_g = 0;
  out.error_max_pct = 0;
  for (int g = static_cast<int>(out.band_lo_g); g <= static_cast<int>(out.band_hi_g); ++g) {
    const double thrust = truth.thrustAt(curve.pwm_us_for_g(g));
    const double err = std::fabs(thrust - g);
    out.error_max_g = std::max(out.error_max_g, err);
    if (g >= 50) out.error_max_pct = std::max(out.error_max_pct, 100.0 * err / g);
    sum2 += err * err;
    ++n;
  }
  out.error_rms_g = n > 0 ? std::sqrt(sum2 / n) : 0;
}

// The slot's stored model as two curves, one per sweep's conditions; throws when the slot
// does not hold what the store commands should have written.
std::array<StoredCurve, 2> storedCurves(const std::vector<uint8_t>& eeprom,
                                        const GatherOptions& o,
                                        const std::array<TruthTable, 2>& truth,
                                        GatherMotorResult& mr) {
  std::string shown;
  for (const auto& l : mr.show) shown += "  | " + l + "\n";
  if (o.model == GatherModel::kThesisV1) {
    tc::MotorCalibration calib;
    const std::string status = decodeSlot(eeprom, mr.slot, calib);
    if (status != "ok" || !calib.hasSecondCurve())
      throw std::runtime_error(fmt::format(
          "slot {}: the EEPROM record after store 1/2 decodes as '{}'{}; show said:\n{}", mr.slot,
          status, calib.hasSecondCurve() ? "" : " without a second curve", shown));
    return {thesisCurve(calib.first), thesisCurve(calib.second)};
  }
  tc::ModelV2 model;
  const std::string status = decodeSlotV2(eeprom, mr.slot, model);
  if (status != "ok" || model.second_mv == 0)
    throw std::runtime_error(fmt::format(
        "slot {}: the EEPROM after two store v2 holds {}; the second sweep must rest >= 0.5 V "
        "away from the first to refine the model (try another --supply-v); show said:\n{}",
        mr.slot, status != "ok" ? "no v2 model (" + status + ")" : "an unrefined model v2",
        shown));
  mr.v2_start_us = model.start_q4_us / 16.0;
  mr.v2_knots = model.knots;
  return {modelV2Curve(model, model.rest_mv, truth[0]),
          modelV2Curve(model, model.second_mv, truth[1])};
}

// gather_slotK_curves.csv: the stored model's PWM per gram at each sweep's conditions beside
// the plant's true PWM for the same thrust.
void writeCurvesCsv(const GatherOptions& o, const std::array<StoredCurve, 2>& stored,
                    const std::array<TruthTable, 2>& tables, GatherMotorResult& mr) {
  mr.curves_csv_path =
      (std::filesystem::path(o.log_dir) / fmt::format("gather_slot{}_curves.csv", mr.slot)).string();
  std::ofstream out(mr.curves_csv_path, std::ios::trunc);
  out << fmt::format("# stored {} (PWM per gram, from EEPROM) and the plant's true PWM for "
                     "the same thrust at each sweep's starting conditions\n",
                     o.model == GatherModel::kModelV2
                         ? "model v2 holding each force at each sweep's conditions"
                         : "curves");
  out << "force_g,curve1_pwm_us,curve2_pwm_us,true1_pwm_us,true2_pwm_us\n";
  const int top = std::max(stored[0].max_g, stored[1].max_g);
  for (int g = 1; g <= top; ++g) {
    auto pwm = [g](const StoredCurve& c) {
      return g <= c.max_g ? std::to_string(c.pwm_us_for_g(g)) : "";
    };
    out << g << "," << pwm(stored[0]) << "," << pwm(stored[1]) << "," << truePwm(tables[0], g)
        << "," << truePwm(tables[1], g) << "\n";
  }
}

}  // namespace gather_checks

namespace {
nlohmann::json curveJson(const CurveCheck& c) {
  return {{"start_v", c.start_v},           {"max_g", c.max_g},
          {"band_g", {c.band_lo_g, c.band_hi_g}}, {"error_max_g", c.error_max_g},
          {"error_rms_g", c.error_rms_g},   {"error_max_pct_above_50g", c.error_max_pct},
          {"samples", c.samples},           {"sweep_max_g", c.sweep_max_g},           {"sweep_simulated_s", c.sweep_simulated_s},
          {"sweep_wall_s", c.sweep_wall_s}, {"csv", c.csv_path}};
}
}  // namespace

nlohmann::json GatherResult::toJson() const {
  const bool v2 = model == GatherModel::kModelV2;
  nlohmann::json motors_json = nlohmann::json::array();
  for (const auto& m : motors) {
    nlohmann::json mj = {{"slot", m.slot},
                         {"seed", m.seed},
                         {"mount_weight_g", m.mount_weight_g},
                         {"curve1", curveJson(m.curve1)},
                         {"curve2", curveJson(m.curve2)},
                         {"second_source", m.second_source},
                         {"curves_csv", m.curves_csv_path},
                         {"store", m.store},
                         {"show", m.show}};
    if (v2) {
      mj["start_us"] = m.v2_start_us;
      mj["knots"] = m.v2_knots;
    }
    motors_json.push_back(std::move(mj));
  }
  const nlohmann::json calibration = {{"model", gatherModelName(model)},
                                      {"curve_error_max_g", curve_error_max_g},
                                      {"motors", motors_json}};
  return {{"calibration", v2 ? nlohmann::json{{"v2", calibration}} : calibration},
          {"sim",
           {{"link", gatherLinkName(link)},
            {"session_wall_s", session_wall_s},
            {"realtime_factor", realtime_factor},
            {"sweep_realtime_factor", sweep_realtime_factor},
            {"simulated_s", simulated_s},
            {"wall_s", wall_s}}}};
}

}  // namespace sim
