// Fidelity: the plant against the thesis's own measurements and the T-motor datasheet.
#include <gtest/gtest.h>

#include <cmath>

#include "plant/plant.hpp"

namespace {

using namespace plant;

TEST(PlantFidelity, ReproducesThesisTable51WithinTenMicrosecondsAtEveryVoltage) {
  // given the thesis motor on the thesis bench supply (6.32 A limit)
  const ActuatorParams params = presetParams("kv1100_9x4.7");
  // when we ask for the pulse that gives 300 g at each of the eight voltages
  const auto rows = runTable51(params);
  // then every row is within 10 us of the thesis measurement
  for (const auto& r : rows) {
    SCOPED_TRACE(testing::Message() << r.supply_v << " V: measured " << r.measured_pwm_us
                                    << " us, model " << r.model_pwm_us << " us");
    EXPECT_NEAR(r.model_pwm_us, r.measured_pwm_us, 10.0);
  }
}

TEST(PlantFidelity, ThrustFollowsDutyTimesVoltageLikeTable51) {
  // given the thesis observation that (PWM - ~1097) * V is constant within ~1 % at 300 g
  const ActuatorParams params = presetParams("kv1100_9x4.7");
  const auto rows = runTable51(params);
  // when we form the same product from the model's pulses
  double lo = 1e9, hi = 0.0;
  for (const auto& r : rows) {
    const double product = (r.model_pwm_us - params.esc.start_us) * r.supply_v;
    lo = std::min(lo, product);
    hi = std::max(hi, product);
  }
  // then it is just as constant
  EXPECT_LT((hi - lo) / lo, 0.02);
}

struct DatasheetCase {
  const char* preset;
};

class PlantDatasheet : public testing::TestWithParam<DatasheetCase> {};

TEST_P(PlantDatasheet, MatchesTheDatasheetPointWithinTwentyPercentAtTheDatasheetRpm) {
  // given a preset and its T-motor datasheet row (11.1 V, 75 % throttle)
  const auto preset = findPreset(GetParam().preset);
  ASSERT_TRUE(preset.has_value());
  // when the model runs at the datasheet's rpm on an ideal 11.1 V supply
  const DatasheetCheck c = checkDatasheet(preset->params, preset->datasheet);
  // then throttle, thrust and current are each within 20 %
  EXPECT_NEAR(c.model_rpm, c.datasheet.rpm, 1.0);
  EXPECT_NEAR(c.model_throttle / c.datasheet.throttle, 1.0, 0.20);
  EXPECT_NEAR(c.model_thrust_g / c.datasheet.thrust_g, 1.0, 0.20);
  EXPECT_NEAR(c.model_current_a / c.datasheet.current_a, 1.0, 0.20);
}

INSTANTIATE_TEST_SUITE_P(AllPresets, PlantDatasheet,
                         testing::Values(DatasheetCase{"kv1100_9x4.7"}, DatasheetCase{"kv1100_10x3.8"},
                                         DatasheetCase{"kv900_10x3.8"}, DatasheetCase{"kv900_11x4.7"}),
                         [](const testing::TestParamInfo<DatasheetCase>& info) {
                           std::string n = info.param.preset;
                           for (char& ch : n) if (ch == '.') ch = '_';
                           return n;
                         });

TEST(PlantFidelity, SpeedStepTimeConstantIsBetweenFiftyAndHundredTwentyMilliseconds) {
  // given the thesis motor at 11.1 V
  const ActuatorParams params = presetParams("kv1100_9x4.7");
  // when the pulse steps up around the hover band
  const double tau_up = stepTimeConstant_s(params, 11.1, 1300.0, 1500.0);
  const double tau_hi = stepTimeConstant_s(params, 11.1, 1450.0, 1600.0);
  // then the rpm reaches 63 % of its change within 0.05..0.12 s
  EXPECT_GT(tau_up, 0.05);
  EXPECT_LT(tau_up, 0.12);
  EXPECT_GT(tau_hi, 0.05);
  EXPECT_LT(tau_hi, 0.12);
}

TEST(PlantFidelity, SpinDownIsSlowerThanSpinUpBecauseTheEscDoesNotBrake) {
  const ActuatorParams params = presetParams("kv1100_9x4.7");
  const double tau_up = stepTimeConstant_s(params, 11.1, 1300.0, 1500.0);
  const double tau_down = stepTimeConstant_s(params, 11.1, 1500.0, 1300.0);
  EXPECT_GT(tau_down, 1.5 * tau_up);
}

TEST(PlantFidelity, LiPoBenchThrustMatchesBenchSupplyAtTheSameVoltageBelowTheLimit) {
  // thesis fig. 5.11: "the Lipo battery and the power supply give the same result"
  const BenchParams lipo_p = BenchParams::thesis();
  const Bench lipo(lipo_p);
  const OperatingPoint on_lipo = lipo.steadyState(1450.0);
  BenchParams ps_p = BenchParams::thesisOnSupply(lipo.restingVoltage_v());
  const Bench ps(ps_p);
  const OperatingPoint on_ps = ps.steadyState(1450.0);
  EXPECT_NEAR(on_lipo.thrust_g, on_ps.thrust_g, 0.03 * on_ps.thrust_g);
}

TEST(PlantFidelity, BenchSupplyFoldsBackAtItsCurrentLimitAndCapsThrust) {
  // given the 6.32 A supply at 12 V
  const Bench bench(BenchParams::thesisOnSupply(12.0));
  // when the pulse goes past the point where the limit is reached
  const OperatingPoint high = bench.steadyState(1800.0);
  // then the supply delivers exactly its limit and the voltage has folded back
  EXPECT_NEAR(high.bus_current_a, 6.32, 0.01);
  EXPECT_LT(high.bus_v, 11.0);
  // and the thrust on a LiPo at the same resting voltage is clearly higher
  BenchParams lp = BenchParams::thesis();
  lp.power.soc = socForCellOcv(12.0 / 3.0);
  const Bench lipo(lp);
  EXPECT_GT(lipo.steadyState(1800.0).thrust_g, high.thrust_g + 100.0);
}

}  // namespace

namespace {

using namespace plant;

TEST(PlantFidelity, BenchDrivenByServoPulsesSettlesOnItsSteadyStateAndTheLoadCellShowsTheThrust) {
  // given the thesis bench on a LiPo, driven like the firmware does: 50 Hz pulses, arm first
  BenchParams bp = BenchParams::thesis();
  bp.load_cell.noise_mv = 0.0;
  bp.load_cell.vibration_frac = 0.0;
  Bench bench(bp);
  const int empty_counts = bench.readCounts(0);
  double next = 0.0;
  auto runWith = [&](double pulse_us, double seconds) {
    const double end = bench.time_s() + seconds;
    while (bench.time_s() < end) {
      if (bench.time_s() >= next) {
        bench.setPulse(pulse_us, next);
        next += 0.02;
      }
      bench.step(0.001);
    }
  };
  runWith(1000.0, 1.5);
  ASSERT_TRUE(bench.actuator().isArmed());
  // when it holds 1550 us for 3 s
  runWith(1550.0, 3.0);
  // then thrust and bus voltage equal the steady state of the whole bench (at the present
  // winding temperature and state of charge)
  const OperatingPoint ss = bench.steadyState(1550.0);
  EXPECT_NEAR(bench.actuator().thrust_g(), ss.thrust_g, 0.01 * ss.thrust_g);
  EXPECT_NEAR(bench.busVoltage_v(), ss.bus_v, 0.02);
  // and the load cell rose by the thrust at 4/3 counts per gram
  EXPECT_NEAR((bench.readCounts(0) - empty_counts) * 0.75, ss.thrust_g, 1.5);
}

}  // namespace
