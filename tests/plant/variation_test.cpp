// Per-part variation and deterministic randomness.
#include <gtest/gtest.h>

#include <cmath>

#include "plant/plant.hpp"

namespace {

using namespace plant;

TEST(Rng, SameSeedGivesTheSameNormalsAndTheyHaveUnitSpread) {
  Rng a(42), b(42), c(43);
  double sum = 0.0, sum2 = 0.0;
  bool differs = false;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const double x = a.normal();
    EXPECT_EQ(x, b.normal());
    differs |= (x != c.normal());
    sum += x;
    sum2 += x * x;
  }
  EXPECT_TRUE(differs);
  EXPECT_NEAR(sum / n, 0.0, 0.03);
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.03);
}

TEST(Rng, UniformStreamIsTheStandardMersenneTwister64) {
  // std::mt19937_64's 10000th output is specified by the C++ standard: 9981545732273789042.
  std::mt19937_64 reference(5489u);
  reference.discard(9999);
  Rng rng(5489u);
  for (int i = 0; i < 9999; ++i) rng.uniform();
  EXPECT_EQ(rng.uniform(), static_cast<double>(reference() >> 11) / 9007199254740992.0);
}

TEST(Variation, SameSeedGivesIdenticalMotorsAndDifferentSeedsDifferentOnes) {
  const ActuatorParams base = presetParams("kv1100_9x4.7");
  const ActuatorParams a1 = makeVaried(base, 1), a1_again = makeVaried(base, 1);
  const ActuatorParams a2 = makeVaried(base, 2);
  EXPECT_EQ(a1.motor.kv_rpm_per_v, a1_again.motor.kv_rpm_per_v);
  EXPECT_EQ(a1.prop.ct_low, a1_again.prop.ct_low);
  EXPECT_EQ(a1.esc.start_us, a1_again.esc.start_us);
  const double t1 = Actuator(a1).steadyState(1500.0, 11.1).thrust_g;
  const double t1_again = Actuator(a1_again).steadyState(1500.0, 11.1).thrust_g;
  const double t2 = Actuator(a2).steadyState(1500.0, 11.1).thrust_g;
  EXPECT_EQ(t1, t1_again);
  EXPECT_NE(a1.motor.kv_rpm_per_v, a2.motor.kv_rpm_per_v);
  EXPECT_GT(std::fabs(t1 - t2), 0.1);
}

TEST(Variation, FourVariedMotorsNeedVisiblyDifferentPulsesForTheSameThrust) {
  const ActuatorParams base = presetParams("kv1100_9x4.7");
  double lo = 1e9, hi = 0.0;
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    const double pwm = Actuator(makeVaried(base, seed)).pulseForThrust_us(300.0, 11.1);
    lo = std::min(lo, pwm);
    hi = std::max(hi, pwm);
  }
  EXPECT_GT(hi - lo, 5.0);   // calibration has something to fix
  EXPECT_LT(hi - lo, 80.0);  // but they are still the same kind of motor
}

TEST(Variation, SpreadSetsTheRelativeSigmaOfKv) {
  const ActuatorParams base = presetParams("kv1100_9x4.7");
  double sum2 = 0.0;
  const int n = 400;
  for (int seed = 1; seed <= n; ++seed) {
    const double rel = makeVaried(base, seed, 0.03).motor.kv_rpm_per_v / base.motor.kv_rpm_per_v - 1.0;
    EXPECT_LE(std::fabs(rel), 0.09 + 1e-12);  // clamped at 3 sigma
    sum2 += rel * rel;
  }
  EXPECT_NEAR(std::sqrt(sum2 / n), 0.03, 0.005);
}

TEST(Variation, ZeroSpreadReturnsThePresetUnchanged) {
  const ActuatorParams base = presetParams("kv900_11x4.7");
  const ActuatorParams same = makeVaried(base, 7, 0.0);
  EXPECT_EQ(same.motor.kv_rpm_per_v, base.motor.kv_rpm_per_v);
  EXPECT_EQ(same.prop.diameter_m, base.prop.diameter_m);
  EXPECT_EQ(same.name, base.name);
}

TEST(Presets, UnknownNameIsRefusedWithTheListOfKnownNames) {
  EXPECT_FALSE(findPreset("kv2300_5x3").has_value());
  try {
    presetParams("kv2300_5x3");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("kv1100_9x4.7"), std::string::npos);
  }
  EXPECT_EQ(presets().size(), 4u);
}

}  // namespace
