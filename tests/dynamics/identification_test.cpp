// Identification against the plant (issue 26 item 1): the bench's response from a weight
// lifted off, each motor's spin-up and spin-down time constants from force steps, against the
// plant's own (plant::stepTimeConstant_s, what `thrustcal plant step` prints).
#include <gtest/gtest.h>

#include <cmath>

#include "plant/fidelity.hpp"
#include "plant_logs.hpp"

namespace {

using dyntest::BenchDriver;

// The thesis bench with the amplifier's offset trimmed for `headroom_g` of weight above the
// motor (the thesis's offset leaves about 15 g above its 81 g motor).
plant::BenchParams benchFor(const char* preset, uint64_t seed, double headroom_g = 60) {
  plant::BenchParams p = plant::BenchParams::thesis(preset);
  p.actuator = plant::makeVaried(plant::presetParams(preset), seed, 0.03);
  p.load_cell.seed = seed * 7 + 1;
  const double heavier_g = p.actuator.mountWeight_g() + headroom_g - 81.0 - 15.0;
  p.load_cell.offset_mv += p.load_cell.millivoltsPerGram() * heavier_g;
  return p;
}

tc::BenchResponse identifyBench(plant::Bench& bench, BenchDriver& drv) {
  bench.placeWeight_g(50);
  drv.run(1.0);
  const auto step = drv.logStep(0.1, 0.6, [&] { bench.removeWeights(); }, false);
  const tc::BenchStepFit fit = tc::fitBenchStep(step.log());
  EXPECT_TRUE(fit.ok()) << tc::stepFitWhyText(fit.why);
  EXPECT_NEAR(fit.step_s, step.step_s, 0.003);
  return fit.response();
}

TEST(DynamicsIdentification, BenchResponseOfTheThesisCellIsThreeStagesOfThirtyMs) {
  plant::Bench bench(benchFor("kv1100_9x4.7", 11));
  BenchDriver drv(bench);
  const tc::BenchResponse r = identifyBench(bench, drv);
  EXPECT_EQ(r.stages, 3);
  EXPECT_NEAR(r.tauS(), 0.0305, 0.002);
}

TEST(DynamicsIdentification, MotorTimeConstantsWithinFivePercentOfThePlants) {
  for (const char* preset : {"kv1100_9x4.7", "kv900_11x4.7"}) {
    plant::Bench bench(benchFor(preset, 12));
    BenchDriver drv(bench);
    const tc::BenchResponse br = identifyBench(bench, drv);
    drv.setPulse(1000);
    drv.run(1.5);  // arm
    for (double f : {80.0, 200.0, 320.0, 440.0}) {
      const double v = bench.busVoltage_v() > 5 ? bench.busVoltage_v() : 12.0;
      const double lo = std::round(bench.actuator().pulseForThrust_us(0.9 * f, v));
      const double hi = std::round(bench.actuator().pulseForThrust_us(1.1 * f, v));
      drv.setPulse(lo);
      drv.run(1.0);
      auto up = drv.logStep(0.05, 0.75, [&] { drv.setPulse(hi); }, true);
      auto down = drv.logStep(0.05, 0.75, [&] { drv.setPulse(lo); }, true);
      up.start_us = down.start_us = static_cast<float>(bench.params().actuator.esc.start_us);
      const auto fu = tc::fitMotorStep(up.log(), br, 2);
      const auto fd = tc::fitMotorStep(down.log(), br, 2);
      ASSERT_TRUE(fu.ok() && fd.ok()) << tc::stepFitWhyText(fu.why) << " / " << tc::stepFitWhyText(fd.why);
      const double tu = plant::stepTimeConstant_s(bench.params().actuator, up.bus_v, lo, hi);
      const double td = plant::stepTimeConstant_s(bench.params().actuator, down.bus_v, hi, lo);
      std::printf("%s %5.0f g: up %.4f (plant %.4f, %+.1f %%) down %.4f (plant %.4f, %+.1f %%) rms %.2f g\n", preset,
                  f, fu.tau_s, tu, 100 * (fu.tau_s / tu - 1), fd.tau_s, td, 100 * (fd.tau_s / td - 1), fu.rms_g);
      EXPECT_NEAR(fu.tau_s / tu, 1.0, 0.05);
      EXPECT_NEAR(fd.tau_s / td, 1.0, 0.05);
    }
  }
}

}  // namespace
