// Evidence from the responses (evidence.hpp): a current that stops at one ceiling is a current
// limit, current and rpm that stop together a saturated ESC, a force that stops while the rotor
// still speeds up a clipped load cell, a power that stops a power limit, a force that falls with
// a slowing rotor a stall; clean data give no evidence at all.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "lab/evidence.hpp"
#include "lab/generate.hpp"

namespace {

lab::Dataset generated(const char* hidden) {
  lab::GenerateOptions o;
  o.hidden = hidden;
  o.noise_g = 0.5;
  return lab::generate(o);
}

const lab::Evidence* find(const std::vector<lab::Evidence>& ev, const std::string& kind) {
  for (const auto& e : ev)
    if (e.kind == kind) return &e;
  return nullptr;
}

// Above `from_us` every response of a row takes the value it had at `from_us` in its run and
// sweep direction (what the stand saw when nothing changed any more), for the named columns.
void freezeAbove(lab::Dataset& d, double from_us, const std::vector<std::string>& columns) {
  const auto& p = d.col("pwm_us");
  const auto& dir = d.col("dir");
  for (const auto& name : columns) {
    std::vector<double> v = d.col(name);
    for (std::size_t i = 0; i < d.rows(); ++i) {
      if (p[i] <= from_us) continue;
      for (std::size_t j = 0; j < d.rows(); ++j)
        if (d.run[j] == d.run[i] && p[j] == from_us && dir[j] == dir[i]) v[i] = d.col(name)[j];
    }
    d.set(name, v);
  }
}

TEST(LabEvidence, ACurrentThatStopsAtOneCeilingInEveryRunIsACurrentLimit) {
  // given a bench supply limited at 6.32 A at four set voltages
  const lab::Dataset d = generated("current_limit");
  // when the responses are read
  const auto ev = lab::gatherEvidence(d);
  // then the current's ceiling is found in every run and named as a current limit
  const lab::Evidence* c = find(ev, "current_plateau");
  ASSERT_NE(c, nullptr);
  EXPECT_NEAR(c->level, 6.32, 0.02);
  EXPECT_EQ(c->runs.size(), 4u);
  EXPECT_NE(c->cause.find("current limit at 6.32 A"), std::string::npos) << c->cause;
  EXPECT_GT(c->from_pwm_us, 1550);
  EXPECT_LT(c->from_pwm_us, 1750);
  // and the force that falls above it is put down to that limit, not to a stall
  EXPECT_EQ(find(ev, "force_falls"), nullptr);
  const lab::Evidence* f = find(ev, "force_falls_at_limit");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->runs.size(), 4u);
  EXPECT_NE(f->cause.find("current limit"), std::string::npos) << f->cause;
  EXPECT_TRUE(f->where.empty()) << "a limit is physics to model, not rows to drop";
}

TEST(LabEvidence, CleanSweepsGiveNoEvidence) {
  for (const char* hidden : {"none", "sag", "motor"})
    EXPECT_TRUE(lab::gatherEvidence(generated(hidden)).empty()) << hidden;
}

TEST(LabEvidence, AForceThatStopsWhileTheRotorSpeedsUpIsAClippedLoadCell) {
  // given a load cell whose reading stops at 600 g (its ADC's full scale)
  lab::Dataset d = generated("none");
  std::vector<double> f = d.col("force_g");
  for (auto& x : f) x = std::min(x, 600.0);
  d.set("force_g", f);
  const auto ev = lab::gatherEvidence(d);
  const lab::Evidence* e = find(ev, "force_clipped");
  ASSERT_NE(e, nullptr);
  EXPECT_NEAR(e->level, 600, 1);
  EXPECT_EQ(e->where, "force_g < 594") << "the rows at the clip do not measure the force";
  EXPECT_EQ(find(ev, "current_plateau"), nullptr);
}

TEST(LabEvidence, CurrentAndSpeedThatStopTogetherAreASaturatedEsc) {
  // given an ESC at full throttle from 1800 us: nothing changes above it
  lab::Dataset d = generated("none");
  freezeAbove(d, 1800, {"force_g", "current_a", "rpm", "torque_nm"});
  const auto ev = lab::gatherEvidence(d);
  const lab::Evidence* e = find(ev, "esc_saturated");
  ASSERT_NE(e, nullptr);
  EXPECT_NEAR(e->from_pwm_us, 1800, 1);
  EXPECT_NE(e->cause.find("saturated ESC"), std::string::npos) << e->cause;
  EXPECT_EQ(find(ev, "current_plateau"), nullptr) << "not a current limit: the speed stops too";
  EXPECT_EQ(find(ev, "force_clipped"), nullptr) << "not a clipped reading: the rotor stops too";
}

TEST(LabEvidence, APowerThatStopsRisingIsAPowerLimit) {
  lab::Dataset d = generated("none");
  std::vector<double> w(d.rows());
  for (std::size_t i = 0; i < d.rows(); ++i) w[i] = d.col("vbat_v")[i] * d.col("current_a")[i];
  d.set("power_w", w);
  freezeAbove(d, 1750, {"power_w"});
  const auto ev = lab::gatherEvidence(d);
  const lab::Evidence* e = find(ev, "power_plateau");
  ASSERT_NE(e, nullptr);
  EXPECT_NE(e->cause.find("power limit"), std::string::npos) << e->cause;
}

TEST(LabEvidence, AForceThatFallsWithTheRotorSlowingToAFractionIsAStall) {
  // given a motor that loses sync above 1800 us: speed and force collapse, no current logged
  lab::Dataset d = generated("none");
  const auto& p = d.col("pwm_us");
  std::vector<double> f = d.col("force_g"), rpm = d.col("rpm");
  for (std::size_t i = 0; i < d.rows(); ++i)
    if (p[i] > 1800) f[i] *= 0.3, rpm[i] *= 0.3;
  d.set("force_g", f), d.set("rpm", rpm);
  lab::Dataset no_current;
  no_current.run = d.run, no_current.run_labels = d.run_labels;
  for (const char* c : {"pwm_us", "force_g", "rpm", "dir"}) no_current.set(c, d.col(c));
  const auto ev = lab::gatherEvidence(no_current);
  const lab::Evidence* e = find(ev, "motor_stalls");
  ASSERT_NE(e, nullptr);
  EXPECT_NE(e->cause.find("stalled motor"), std::string::npos) << e->cause;
}

}  // namespace
