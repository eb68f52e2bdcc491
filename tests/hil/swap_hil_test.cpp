// The swap experiment reduced (`thrustcal sim swap --rigs gimbal --modes force,force+dyn --parts
// kv900_11x4.7 --gains pd --imu-seeds 1 --dyn-from plant --dyn-steps 3`): four stock motors calibrated with the
// real gather_store, fly's 10-degree roll and pitch steps on the plus gimbal, motor 1 replaced by
// a KV900 with an 11x4.7 propeller (the part most unlike the stock one), only slot 1 calibrated
// again, the same steps with the same gains; then the same with each record holding its motor's
// dynamics (the plant's own: gather_store's `dyn` sessions cost 35 simulated seconds a motor)
// and fly's `dyn on` (equal dynamics). The targets of force mode with PD gains, and that
// equal dynamics bring the swap closer to stock, are asserted on the simulated figures (the rig's
// true attitude in simulated time), never on wall time. Each force+dyn flight flies three steps
// and its figures are their means (`dyn_steps`): one step's rise time scatters by about 1 % with
// the same motors, as much as force+dyn's target; force mode's targets (10 %) need one step.
// The calibrations are cached beside the test binary, as `sim swap`
// caches them.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <nlohmann/json.hpp>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

#include "hil_support.hpp"
#include "sim/swap.hpp"

namespace {

sim::swap::SwapOptions reducedSwapOptions() {
  sim::swap::SwapOptions o;
  o.gather_elf = hil::imagePath("gather_store");
  o.fly_elf = hil::imagePath("fly");
  o.out_dir = (std::filesystem::path(HIL_CACHE_DIR) / "swap").string();
  o.rigs = {sim::AirRig::kGimbal};
  o.modes = {sim::swap::Mode::kForce, sim::swap::Mode::kForceDyn};
  o.dyn_from = "plant";
  o.parts = {"kv900_11x4.7"};
  o.gains = {sim::swap::Gains::kPd};
  o.imu_seeds = {1};
  o.dyn_steps = 3;  // force mode: o.steps, one
  o.progress = [](const std::string&) {};
  return o;
}

TEST(SwapHil, ForceModeMeetsTheTargetsAndEqualDynamicsBringAKv900InSlot1CloserToStock) {
  HIL_REQUIRE_IMAGE("gather_store");
  HIL_REQUIRE_IMAGE("fly");
  // when
  const sim::swap::SwapResult r = sim::swap::runSwap(reducedSwapOptions());
  // then: stock and swapped, roll and pitch, each mode, each a step that rose and settled
  ASSERT_EQ(r.runs.size(), 8u);
  for (const sim::swap::RunResult& run : r.runs) {
    const std::string id = sim::swap::runId(run.spec);
    EXPECT_FALSE(std::isnan(run.metrics.rise_s)) << id;
    // force+dyn's three steps, force mode's one, each measured
    ASSERT_EQ(run.step_rise_s.size(), run.spec.mode == sim::swap::Mode::kForceDyn ? 3u : 1u) << id;
    for (const double rise_s : run.step_rise_s) EXPECT_NEAR(rise_s, run.metrics.rise_s, 0.05 * run.metrics.rise_s) << id;
    // force+dyn flies the reference's slower lag with force mode's gains: its steps ring
    // longer and may not settle within 2 % in the window (docs/fly.md, "Equal dynamics")
    if (run.spec.mode == sim::swap::Mode::kForce) {
      EXPECT_FALSE(std::isnan(run.metrics.settling_s)) << id;
    }
    EXPECT_GT(run.metrics.peak, run.y0_deg + 8.0) << id;  // it moved by about the 10 degrees asked
    EXPECT_DOUBLE_EQ(run.integrator_mnm, 0.0) << id;      // PD gains: no integral term
  }
  // the four targets: overshoot within 5 pp of stock, rise time within 10 %, sse <= 0.5 deg,
  // ITAE <= 1.5x stock, each the worst of the two axes
  ASSERT_EQ(r.targets.size(), 8u);
  for (const sim::swap::Target& t : r.targets) {
    if (t.mode == "force") {
      EXPECT_TRUE(t.met) << t.target << ": " << t.figure;
    }
  }
  // and what the calibration cannot change is measured: the KV900's own motor time constant
  ASSERT_EQ(r.dynamics.parts.size(), 1u);
  EXPECT_GT(r.dynamics.parts[0].tau_s, 0.0);
  EXPECT_NE(r.dynamics.parts[0].tau_s, r.dynamics.parts[0].stock_tau_s);
  // the public interface: runs[] and targets[] with the fields
  const nlohmann::json j = r.toJson();
  ASSERT_EQ(j.at("runs").size(), 8u);
  for (const char* key : {"rig", "mode", "part", "axis", "step_deg", "seed", "rise_s", "overshoot_pct",
                          "settling_s", "sse_deg", "itae", "integrator", "hover_pwm_spread_us"})
    EXPECT_TRUE(j["runs"][0].contains(key)) << key;
  for (const char* key : {"target", "figure", "wanted", "met"})
    EXPECT_TRUE(j["targets"][0].contains(key)) << key;
  // equal dynamics: on the roll axis (motor 1's), the KV900's rise time, overshoot and ITAE
  // against stock are closer with force+dyn than with force alone, overshoot within 1 pp and
  // ITAE within 1.05x (the targets), rise time within 1.5 % (the target is 1 %: measured
  // +0.5 % against force mode's +3.6 % on its one step; a change of fly's timing moves a
  // three-step mean by a few tenths, docs/fly.md, "Equal dynamics", has the figures)
  auto change = [&r](sim::swap::Mode mode, double sim::StepMetrics::*figure, bool ratio) {
    const sim::swap::RunResult *stock = nullptr, *part = nullptr;
    for (const sim::swap::RunResult& run : r.runs)
      if (run.spec.mode == mode && run.spec.axis == "roll") (run.spec.part == "stock" ? stock : part) = &run;
    EXPECT_TRUE(stock && part);
    if (!stock || !part) return 0.0;
    return ratio ? part->metrics.*figure / stock->metrics.*figure : part->metrics.*figure - stock->metrics.*figure;
  };
  using sim::swap::Mode;
  const double rise_force = change(Mode::kForce, &sim::StepMetrics::rise_s, true) - 1.0;
  const double rise_dyn = change(Mode::kForceDyn, &sim::StepMetrics::rise_s, true) - 1.0;
  EXPECT_LT(std::fabs(rise_dyn), std::fabs(rise_force)) << "rise vs stock: force " << rise_force << ", force+dyn "
                                                        << rise_dyn;
  EXPECT_LE(std::fabs(rise_dyn), 0.015);
  const double over_dyn = change(Mode::kForceDyn, &sim::StepMetrics::overshoot_pct, false);
  EXPECT_LT(std::fabs(over_dyn), std::fabs(change(Mode::kForce, &sim::StepMetrics::overshoot_pct, false)));
  EXPECT_LE(std::fabs(over_dyn), 1.0);
  const double itae_dyn = change(Mode::kForceDyn, &sim::StepMetrics::itae, true);
  EXPECT_LT(std::fabs(itae_dyn - 1.0), std::fabs(change(Mode::kForce, &sim::StepMetrics::itae, true) - 1.0));
  EXPECT_LE(itae_dyn, 1.05);
}

// Equal dynamics on the tethered lift-off (read_run): the swap's four stock motors (seeds 11-14,
// model v2; their time constants 70-89 ms) ramp to 300 g with and without `dyn on` (each record
// with the plant's dynamics); the four thrusts' largest spread during the ramp narrows, the
// hold's stays the model's. Issue 26: the lift-off's spread during the ramp, not only at hold.
TEST(SwapHil, DynOnNarrowsTheStockMotorsSpreadDuringTheLiftoffRamp) {
  HIL_REQUIRE_IMAGE("gather_store");
  HIL_REQUIRE_IMAGE("read_run");
  const sim::swap::SwapOptions swap = reducedSwapOptions();
  const sim::swap::Calibration c = sim::swap::calibrate(swap);  // cached by the test above, or
                                                                  // waits for it (the folder lock)
  sim::LiftoffOptions o;
  o.elf_path = hil::imagePath("read_run");
  o.eeprom = c.of("stock").eeprom;
  o.preset = swap.stock_preset;
  o.seeds = swap.stock_seeds;
  o.variation = swap.variation;
  o.link = sim::GatherLink::kInProcess;
  o.hold_ms = 1500;  // the ramp is what is measured
  o.progress = [](const std::string&) {};
  const sim::LiftoffResult off = sim::runLiftoff(o);
  o.dyn = true;
  const sim::LiftoffResult on = sim::runLiftoff(o);
  std::printf("lift-off ramp spread: dyn off %.2f %%, dyn on %.2f %%; hold %.2f / %.2f %%\n", off.ramp_spread_pct,
              on.ramp_spread_pct, off.thrust_spread_pct, on.thrust_spread_pct);
  EXPECT_LT(on.ramp_spread_pct, 0.75 * off.ramp_spread_pct);  // measured: 4.71 -> 2.10 %
  EXPECT_NEAR(on.thrust_spread_pct, off.thrust_spread_pct, 0.1);
}

// Two swaps on one --out-dir (two terminals; ctest runs the two tests above at once): the second
// waits for the first's calibrations instead of reading the sweeps it is writing. Here the
// folder is held as the first swap holds it, and a swap with a missing image waits, says so,
// and goes on (to its error) only once the folder is released.
TEST(SwapCalibration, ASecondSwapOnTheSameFolderWaitsUntilTheFirstReleasesIt) {
  // given: the calibration folder held
  const std::filesystem::path out = std::filesystem::path(HIL_CACHE_DIR) / "swap_lock";
  std::filesystem::create_directories(out / "calibration");
  const int held = ::open((out / "calibration" / ".lock").c_str(), O_RDWR | O_CREAT, 0644);
  ASSERT_GE(held, 0);
  ASSERT_EQ(::flock(held, LOCK_EX), 0);
  sim::swap::SwapOptions o = reducedSwapOptions();
  o.out_dir = out.string();
  o.gather_elf = (out / "no_such_gather_store.elf").string();
  std::mutex m;
  std::string said;
  o.progress = [&](const std::string& line) {
    const std::lock_guard<std::mutex> lock(m);
    said += line + "\n";
  };
  std::atomic<bool> returned{false};
  std::string error;
  // when
  std::thread second([&] {
    try {
      sim::swap::calibrate(o);
    } catch (const std::exception& e) {
      error = e.what();
    }
    returned = true;
  });
  bool waiting = false;
  for (int i = 0; i < 500 && !waiting; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const std::lock_guard<std::mutex> lock(m);
    waiting = said.find("waiting for another sim swap") != std::string::npos;
  }
  // then: it waits while the folder is held, and goes on once it is released
  EXPECT_TRUE(waiting) << said;
  EXPECT_FALSE(returned.load());
  ::close(held);
  second.join();
  EXPECT_TRUE(returned.load());
  EXPECT_NE(error.find("cannot read the image"), std::string::npos) << error;
}

}  // namespace
