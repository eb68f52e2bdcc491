// gather_store's `settle auto` on the real image in simavr, on the plant bench (one varied
// KV1100 + 9x4.7 on a full LiPo, 81 steps of 10 us): sweep time and the accuracy of the model
// v2 that `store v2` fits from it on the board, for fixed settle times and for settle auto.
//
// Accuracy: for commands 50..450 g, the PWM the stored model gives for a step from rest at the
// sweep's resting reading (tc::forceToPwmV2 with the bench sag predicted, as read_run does),
// then the plant's steady thrust at that PWM; error in percent of the command, RMS and max,
// against the bench as it was when the sweep started.
//
// Measured (simavr, this plant): fixed 200 ms 20.1 s, 2.42 % RMS / 4.71 % max (the load
// cell's third-order low-pass is still moving after 200 ms); fixed 500 ms 44.5 s, 0.36 / 0.52 %;
// settle auto with a 200 ms cap ~18.4 s, ~2.4 / 4.7 % (most steps end at the cap: no gain;
// the figures move by a few hundredths when the image's timing changes the noise draws);
// settle auto with a 500 ms cap 33.8 s, 0.48 / 1.25 % (the worst at 50 g, where one step moves
// the force by only 1-3 counts). So settle auto pays with a cap that lets the cell settle.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "plant/bench.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#include "thrustcal/eeprom_image.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/record_v2.hpp"

namespace {

namespace fs = std::filesystem;

std::string gatherStoreElf() {
  return (fs::path(THRUSTCAL_AVR_BUILD_DIR) / "firmware" / "gather_store" / "gather_store.elf")
      .string();
}

struct SettleRun {
  std::string settle;          // the settle command
  double sweep_simulated_s = 0;
  double error_rms_pct = 0, error_max_pct = 0;
  std::string store_line;
};

SettleRun calibrate(const std::string& settle_command) {
  SettleRun r;
  r.settle = settle_command;
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = sim::motorForSeed("kv1100_9x4.7", 31, 0.03);
  params.load_cell.seed = 31 * 1000003ULL + 17;
  params.battery_sensor.seed = 31 * 1000003ULL + 29;
  sim::BenchRig rig(gatherStoreElf(), params, 0);
  sim::Console con(rig.board, "gs> ");
  con.waitPrompt(10.0);
  auto must = [&](const std::string& line, double budget_s) {
    const auto lines = con.command(line, budget_s);
    for (const auto& l : lines)
      if (l.rfind("error:", 0) == 0) ADD_FAILURE() << line << " -> " << l;
    return lines;
  };
  must(fmt::format("cal {}", static_cast<int>(std::lround(params.actuator.mountWeight_g()))), 15);
  std::size_t pos = 0;
  for (std::size_t semi; (semi = settle_command.find(';', pos)) != std::string::npos; pos = semi + 1)
    must(settle_command.substr(pos, semi - pos), 5);
  must(settle_command.substr(pos), 5);
  rig.board.runFor(2.0);  // ESC armed before the sweep starts: its time is the steps only
  const plant::Bench truth = rig.bench;
  const double t0 = rig.board.simulatedSeconds();
  must("sweep", 120);
  r.sweep_simulated_s = rig.board.simulatedSeconds() - t0;
  for (const auto& l : must("store v2", 10))
    if (l.rfind("stored model v2", 0) == 0) r.store_line = l;
  const std::vector<uint8_t> image = rig.board.eeprom();
  tc::ModelV2 model;
  const tc::EepromImage::Use use(image);
  const bool ok = tc::readModelV2<tc::EepromImage>(0, model).status == tc::DecodeStatus::kOk;
  EXPECT_TRUE(ok) << r.store_line;
  if (!ok) return r;
  double sum2 = 0;
  int n = 0;
  for (double g = 50; g <= 450; g += 25) {
    // read_run's step from rest at the sweep's resting reading: the bus at the command is
    // predicted from the bench sag the model stored
    tc::BusVoltageFilter bus;
    bus.reset(model.rest_mv);
    const auto out = tc::forceToPwmV2(model, static_cast<uint16_t>(g * 10), bus, 0);
    const double err = 100.0 * (truth.steadyState(out.pwm_us).thrust_g - g) / g;
    sum2 += err * err;
    ++n;
    r.error_max_pct = std::max(r.error_max_pct, std::fabs(err));
  }
  r.error_rms_pct = std::sqrt(sum2 / n);
  return r;
}

TEST(SettleAuto, WithA500MsCapSweepsAQuarterFasterThanFixed500MsAndKeepsV2WithinOnePercent) {
  if (!fs::exists(gatherStoreElf()))
    GTEST_SKIP() << "no AVR image " << gatherStoreElf()
                 << ": build the AVR tree first (tools/test.sh does), or set THRUSTCAL_AVR_BUILD_DIR";
  // given / when: the same motor calibrated with fixed 200 ms steps and with settle auto
  const SettleRun fixed = calibrate("settle 200");
  const SettleRun fixed500 = calibrate("settle 500");
  const SettleRun automatic = calibrate("settle auto");
  const SettleRun auto500 = calibrate("settle 500;settle auto");
  // then
  for (const SettleRun* r : {&fixed, &fixed500, &automatic, &auto500}) {
    std::printf("%-12s sweep %.1f s simulated, model v2 force error %.2f %% RMS, %.2f %% max\n",
                r->settle.c_str(), r->sweep_simulated_s, r->error_rms_pct, r->error_max_pct);
    std::string key = r->settle;
    for (char& c : key)
      if (c == ' ' || c == ';') c = '_';
    RecordProperty(key + "_sweep_s", fmt::format("{:.1f}", r->sweep_simulated_s));
    RecordProperty(key + "_rms_pct", fmt::format("{:.2f}", r->error_rms_pct));
    RecordProperty(key + "_max_pct", fmt::format("{:.2f}", r->error_max_pct));
  }
  // settle auto never waits longer than the fixed time it is capped by (500 ms by default)
  EXPECT_LE(automatic.sweep_simulated_s, fixed500.sweep_simulated_s);
  // with a cap that lets the cell settle: faster than the fixed cap, issue targets held
  // (v2 error within 1 % RMS, 3 % max; sweep within 60 simulated seconds)
  EXPECT_LT(auto500.sweep_simulated_s, 0.85 * fixed500.sweep_simulated_s);
  EXPECT_LT(auto500.sweep_simulated_s, 60.0);
  EXPECT_LE(auto500.error_rms_pct, 1.0);
  EXPECT_LE(auto500.error_max_pct, 3.0);
  EXPECT_LE(fixed500.error_rms_pct, 1.0);
}

}  // namespace
