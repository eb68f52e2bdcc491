// Benchmark 4's fast sweeps (issue 26 item 2): the same four motors calibrated with 200 ms and
// 100 ms per step, as read and corrected with each motor's measured dynamics, beside gather_store's
// default sweep (settle auto). The dynamics are measured first, as a user would: `dyn cell` once
// (a weight lifted off the plate), then per slot a sweep, `store v2` and `dyn`
// (sim/dynamics_session.hpp); that EEPROM is where the corrected calibrations start from, so
// gather_store corrects its own readings with the dynamics its slots hold.
#ifdef THRUSTCAL_BENCH_HAVE_SIM
#include <algorithm>
#include <iostream>

#include <fmt/format.h>

#include "calibration_runs.hpp"
#include "sim/dynamics_session.hpp"

namespace bench {

namespace {

constexpr double kSpeedupTarget = 2.5;

// The board's EEPROM after dyn cell and, per slot, a calibration and dyn.
std::vector<uint8_t> measureDynamics(const AvrPaths& paths) {
  std::vector<uint8_t> eeprom;
  for (std::size_t i = 0; i < kSeeds.size(); ++i) {
    sim::DynSessionOptions o;
    o.elf_path = paths.elf("gather_store");
    o.motor = sim::motorForSeed(kPreset, kSeeds[i], kVariation);
    o.slot = static_cast<int>(i);
    o.eeprom = eeprom;
    o.noise_seed = kSeeds[i];
    o.progress = [](const std::string&) {};
    std::cerr << fmt::format("bench: gather_store dyn in simavr, slot {} (seed {})\n", i, kSeeds[i]);
    eeprom = sim::runDynSession(o).eeprom;
  }
  return eeprom;
}

}  // namespace

void addFastSweepRows(const AvrPaths& paths, const MethodRun& settle_auto, Table& t, nlohmann::json& json,
                      std::vector<TargetCheck>& targets) {
  const std::vector<uint8_t> with_dynamics = measureDynamics(paths);
  const auto run = [&](const char* key, int settle_ms, bool corrected) {
    MethodRun m = gatherWith(paths, key,
                             fmt::format("v2: 10 us, settle {} ms, store v2{}", settle_ms,
                                         corrected ? ", corrected with the slots' dynamics" : ", as read"),
                             10, settle_ms, sim::GatherModel::kModelV2, false,
                             corrected ? with_dynamics : std::vector<uint8_t>());
    checkStoredV2(m);
    return m;
  };
  const MethodRun runs[] = {run("v2_200ms_raw", 200, false), run("v2_200ms_corrected", 200, true),
                            run("v2_100ms_corrected", 100, true)};
  const nlohmann::json auto_json = methodJson(settle_auto);
  const double auto_s = settle_auto.sweep_s_max;
  const double auto_max = auto_json["curve_error_max_pct_100_450g"];
  for (const MethodRun& m : runs) {
    const nlohmann::json j = methodJson(m);
    const double worst = j["curve_error_max_pct_100_450g"];
    const double speedup = m.sweep_s_max > 0 ? auto_s / m.sweep_s_max : 0.0;
    t.addRow({m.name, fmt::format("{:.1f} ({:.1f}x faster)", m.sweep_s_max, speedup),
              fixed(j["curve_error_rms_pct"].get<double>(), 2), fixed(j["curve_error_max_pct"].get<double>(), 2),
              fixed(worst, 2), "-", "-"});
    json[m.key] = j;
    json[m.key]["speedup_over_settle_auto"] = speedup;
    if (m.key != "v2_200ms_corrected") continue;
    const bool met = speedup >= kSpeedupTarget && worst <= std::max(1.0, auto_max);
    json["met"][m.key] = met;
    targets.push_back({"4. calibration, 200 ms sweeps corrected with the measured dynamics",
                       fmt::format("{:.1f}x faster than settle auto, max {:.2f} % (auto: {:.2f} %)", speedup, worst,
                                   auto_max),
                       fmt::format(">= {:.1f}x faster, max <= 1 % or auto's", kSpeedupTarget), met});
  }
  t.addNote("fast rows (issue 26 item 2): the EEPROM of the corrected rows holds each slot's dynamics, measured by "
            "gather_store's dyn cell and dyn first (bench dynamics); a fixed-settle sweep of such a slot corrects "
            "its readings for the lag (docs/model_v2.md, \"Dynamics\"); \"x faster\": settle auto's longest first "
            "sweep over this row's");
}

}  // namespace bench

#endif  // THRUSTCAL_BENCH_HAVE_SIM
