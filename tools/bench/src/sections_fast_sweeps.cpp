// Benchmark 4's fast sweeps (issue 26 item 2): the same four motors calibrated with 200 ms and
// 100 ms per step, as read and corrected with each motor's measured dynamics, beside gather_store's
// default sweep (settle auto). The dynamics are measured first, as a user would: `dyn cell` once
// (a weight lifted off the plate), then per slot a sweep, `store v2` and `dyn`
// (sim/dynamics_session.hpp); that EEPROM is where the corrected calibrations start from, so
// gather_store corrects its own readings with the dynamics its slots hold.
#ifdef THRUSTCAL_BENCH_HAVE_SIM
#include <iostream>

#include <fmt/format.h>

#include "calibration_runs.hpp"
#include "sim/dynamics_session.hpp"
#include "thrustcal/sweep_rules.hpp"

namespace bench {

namespace {

// Issue 26 item 2: calibration at least this much faster than settle auto, model v2 within
// these over 100-450 g (bench accuracy's band).
constexpr double kSpeedupTarget = 2.5;
constexpr double kFastRmsPct = 0.35;
constexpr double kFastMaxPct = 1.2;

// The board's EEPROM after dyn cell and, per slot (0, 1, ... for `seeds`), a calibration and dyn;
// from `eeprom` (empty: erased; a calibration sweep and store v2 before each dyn) or from one
// whose slots hold model v2 (dyn alone).
std::vector<uint8_t> measureDynamics(const AvrPaths& paths, const std::vector<uint64_t>& seeds,
                                     std::vector<uint8_t> eeprom = {}) {
  const bool calibrate = eeprom.empty();
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    sim::DynSessionOptions o;
    o.elf_path = paths.elf("gather_store");
    o.motor = sim::motorForSeed(kPreset, seeds[i], kVariation);
    o.slot = static_cast<int>(i);
    o.eeprom = eeprom;
    o.calibrate = calibrate;
    o.noise_seed = seeds[i];
    o.progress = [](const std::string&) {};
    std::cerr << fmt::format("bench: gather_store dyn in simavr, slot {} (seed {})\n", i, seeds[i]);
    eeprom = sim::runDynSession(o).eeprom;
  }
  return eeprom;
}

MethodRun corrected(const AvrPaths& paths, const std::vector<uint8_t>& with_dynamics, const std::string& key,
                    int step_us, int settle_ms, const std::vector<uint64_t>& seeds) {
  MethodRun m = gatherWith(paths, key,
                           fmt::format("v2: {} us, settle {} ms, store v2, corrected with the slots' dynamics",
                                       step_us, settle_ms),
                           step_us, settle_ms, sim::GatherModel::kModelV2, false, with_dynamics, seeds);
  checkStoredV2(m);
  return m;
}

// A corrected row against issue 26's target: accuracy over 100-450 g, and (speed_judged) the
// speed-up over settle auto's sweep of `auto_s`.
struct FastVerdict {
  double rms_pct = 0, max_pct = 0, speedup = 0;
  bool met = false;
};
FastVerdict judge(const MethodRun& m, const nlohmann::json& j, double auto_s, bool speed_judged) {
  FastVerdict v;
  v.rms_pct = j["curve_error_rms_pct_100_450g"];
  v.max_pct = j["curve_error_max_pct_100_450g"];
  v.speedup = m.sweep_s_max > 0 ? auto_s / m.sweep_s_max : 0.0;
  v.met = v.rms_pct <= kFastRmsPct && v.max_pct <= kFastMaxPct && (!speed_judged || v.speedup >= kSpeedupTarget);
  return v;
}

}  // namespace

void addFastSweepRows(const AvrPaths& paths, const MethodRun& settle_auto, Table& t, nlohmann::json& json,
                      std::vector<TargetCheck>& targets) {
  const std::vector<uint8_t> with_dynamics = measureDynamics(paths, kSeeds);
  MethodRun raw = gatherWith(paths, "v2_200ms_raw", "v2: 10 us, settle 200 ms, store v2, as read", 10, 200,
                             sim::GatherModel::kModelV2);
  checkStoredV2(raw);
  const MethodRun runs[] = {
      raw, corrected(paths, with_dynamics, "v2_200ms_corrected", 10, 200, kSeeds),
      corrected(paths, with_dynamics, "v2_100ms_corrected", 10, 100, kSeeds),
      corrected(paths, with_dynamics, "v2_fast_corrected", tc::kFastSweepStepUs, tc::kFastSweepSettleMs, kSeeds)};
  const double auto_s = settle_auto.sweep_s_max;
  for (const MethodRun& m : runs) {
    const nlohmann::json j = methodJson(m);
    // The 200 ms sweeps: the accuracy target for them; the quicker ones: the speed too.
    const bool judged = m.key != "v2_200ms_raw";
    const bool speed_judged = judged && m.key != "v2_200ms_corrected";
    const FastVerdict v = judge(m, j, auto_s, speed_judged);
    const double rms = v.rms_pct, worst = v.max_pct, speedup = v.speedup;
    const bool met = v.met;
    const std::string target =
        !judged ? "-"
                : fmt::format("{}RMS <= {:.2f}, max <= {:.1f} % (100-450 g)",
                              speed_judged ? fmt::format(">= {:.1f}x faster, ", kSpeedupTarget) : "", kFastRmsPct,
                              kFastMaxPct);
    t.addRow({m.name, fmt::format("{:.1f} ({:.1f}x faster)", m.sweep_s_max, speedup),
              fixed(j["curve_error_rms_pct"].get<double>(), 2), fixed(j["curve_error_max_pct"].get<double>(), 2),
              fixed(rms, 2), fixed(worst, 2), target, judged ? verdict(met) : "-"});
    json[m.key] = j;
    json[m.key]["speedup_over_settle_auto"] = speedup;
    if (!judged) continue;
    json["met"][m.key] = met;
    targets.push_back({fmt::format("4. calibration, {} us steps, {} ms settle, corrected with the measured dynamics",
                                   m.step_us, m.settle_ms),
                       fmt::format("{:.1f} s ({:.1f}x faster than settle auto), RMS {:.2f} %, max {:.2f} %",
                                   m.sweep_s_max, speedup, rms, worst),
                       target, met});
  }
  t.addNote("fast rows (issue 26 item 2): the EEPROM of the corrected rows holds each slot's dynamics, measured by "
            "gather_store's dyn cell and dyn first (bench dynamics); a fixed-settle sweep of such a slot corrects "
            "its readings for the lag (docs/model_v2.md, \"Dynamics\"); \"x faster\": settle auto's longest first "
            "sweep over this row's");
  t.addNote(fmt::format("fast calibration (gather_store: step {}, settle {} on a slot with dyn): issue 26's target, "
                        "at least {:.1f}x faster than settle auto with model v2 within {:.2f} % RMS and {:.1f} % max "
                        "over 100-450 g; 200 ms sweeps corrected: the same accuracy",
                        tc::kFastSweepStepUs, tc::kFastSweepSettleMs, kSpeedupTarget, kFastRmsPct, kFastMaxPct));
}

nlohmann::json fastCalibrationCheck(const AvrPaths& paths, const std::vector<uint64_t>& seeds) {
  MethodRun settle_auto = gatherWith(paths, "v2_default", "v2: gather_store's default sweep, store v2", 10,
                                     tc::kDefaultSettleCapMs, sim::GatherModel::kModelV2, true, {}, seeds);
  checkStoredV2(settle_auto);
  const MethodRun fast = corrected(paths, measureDynamics(paths, seeds, settle_auto.eeprom), "v2_fast_corrected",
                                   tc::kFastSweepStepUs, tc::kFastSweepSettleMs, seeds);
  nlohmann::json j = {{"settle_auto", methodJson(settle_auto)}, {"fast", methodJson(fast)}};
  const FastVerdict v = judge(fast, j["fast"], settle_auto.sweep_s_max, true);
  j["speedup_over_settle_auto"] = v.speedup;
  j["met"] = v.met;
  return j;
}

}  // namespace bench

#else
#include <stdexcept>

#include "bench/sections.hpp"

namespace bench {

nlohmann::json fastCalibrationCheck(const AvrPaths&, const std::vector<uint64_t>&) {
  throw std::runtime_error("tools/sim (thrustcal_sim) is not part of this build: no gather scenario");
}

}  // namespace bench

#endif  // THRUSTCAL_BENCH_HAVE_SIM
