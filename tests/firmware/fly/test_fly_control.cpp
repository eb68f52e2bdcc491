// fly's control parts without booting the image: the mixer (plus, X, seesaw; saturation), the
// controller (thesis gains, derivative on the rate, integrators), the estimator (atan2, gyro
// bias at rest, static tilt, a rate step, the accelerometer's correction) and ArduPilot's thrust
// curve against the lab's reference implementation of ArduPilot's source.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "ardupilot_curve.hpp"
#include "controller.hpp"
#include "estimator.hpp"
#include "lab/autopilot.hpp"
#include "mixer.hpp"

namespace {

using namespace fly;
constexpr double kG0 = 9.80665;
constexpr double kDeg = M_PI / 180.0;

// ---------------------------------------------------------------------------------------------
// Mixer: the forces it gives must make the torque asked for, on the airframe's geometry as the
// simulated airframe has it (written out here on its own, not from the mixer's tables).

struct Mount {
  double x, y;
  int spin;
};

std::vector<Mount> mounts(Layout layout, double a) {
  const double c = a / std::sqrt(2.0);
  switch (layout) {
    case Layout::kPlus:
      return {{a, 0, 1}, {0, a, -1}, {-a, 0, 1}, {0, -a, -1}};
    case Layout::kX:
      return {{c, c, 1}, {-c, c, -1}, {-c, -c, 1}, {c, -c, -1}};
    case Layout::kSeesaw:
      return {{0, a, 0}, {0, -a, 0}};
  }
  return {};
}

struct Made {
  double x_nm = 0, y_nm = 0, z_nm = 0, total_g = 0;
};

Made torqueOf(Layout layout, const ForceQ4 (&force)[4], double arm_m, double kq_m) {
  Made m;
  const auto ms = mounts(layout, arm_m);
  for (std::size_t i = 0; i < ms.size(); ++i) {
    const double f_g = force[i] / 16.0;
    const double f_n = f_g * kG0 / 1000.0;
    m.x_nm += ms[i].y * f_n;
    m.y_nm += -ms[i].x * f_n;
    m.z_nm += -ms[i].spin * kq_m * f_n;
    m.total_g += f_g;
  }
  return m;
}

struct MixCase {
  Layout layout;
  float collective_g;
  Torque torque;
};

TEST(Mixer, UnsaturatedForcesMakeTheTorqueAndTheCollectiveAskedForToTheSixteenthOfAGram) {
  const MixCase cases[] = {
      {Layout::kPlus, 300, {0.0f, 0.0f, 0.0f}},    {Layout::kPlus, 300, {0.2f, 0.0f, 0.0f}},
      {Layout::kPlus, 300, {0.0f, -0.3f, 0.0f}},   {Layout::kPlus, 300, {0.1f, 0.1f, 0.02f}},
      {Layout::kX, 300, {0.2f, 0.0f, 0.0f}},       {Layout::kX, 300, {0.0f, 0.2f, 0.0f}},
      {Layout::kX, 300, {-0.15f, 0.1f, -0.02f}},   {Layout::kX, 250, {0.0f, 0.0f, 0.03f}},
      {Layout::kSeesaw, 300, {0.3f, 0.2f, 0.05f}},  // pitch and yaw: not on a seesaw
  };
  for (const MixCase& c : cases) {
    Mixer mixer;
    mixer.configure(c.layout, 0.225f, 0.015f);
    ForceQ4 f[4];
    const uint8_t limits = mixer.mix(toQ4(c.collective_g), c.torque, toQ4(20), toQ4(800), f);
    const Made made = torqueOf(c.layout, f, 0.225, 0.015);
    const int layout = static_cast<int>(c.layout);
    EXPECT_EQ(limits, 0) << layout;
    EXPECT_NEAR(made.x_nm, c.torque.x_nm, 3e-4) << layout;  // forces in 1/16 g
    if (c.layout == Layout::kSeesaw) {
      EXPECT_EQ(f[2], 0);
      EXPECT_EQ(f[3], 0);
      EXPECT_NEAR(made.total_g, 2 * c.collective_g, 0.07);
      continue;
    }
    EXPECT_NEAR(made.y_nm, c.torque.y_nm, 3e-4) << layout;
    EXPECT_NEAR(made.z_nm, c.torque.z_nm, 3e-5) << layout;
    EXPECT_NEAR(made.total_g, 4 * c.collective_g, 0.13) << layout;
  }
}

TEST(Mixer, PlusLayoutRollsOnTheSideMotorsAndPitchesOnFrontAndRear) {
  Mixer mixer;
  mixer.configure(Layout::kPlus, 0.225f, 0.015f);
  ForceQ4 f[4];
  mixer.mix(toQ4(300), {0.1f, 0.0f, 0.0f}, 0, toQ4(1000), f);
  EXPECT_EQ(f[0], toQ4(300)) << "front: no roll";
  EXPECT_EQ(f[2], toQ4(300)) << "rear: no roll";
  EXPECT_GT(f[1], toQ4(300)) << "positive roll (right side down) pushes the left motor up";
  EXPECT_LT(f[3], toQ4(300));
  mixer.mix(toQ4(300), {0.0f, 0.1f, 0.0f}, 0, toQ4(1000), f);
  EXPECT_GT(f[2], toQ4(300)) << "positive pitch (nose down) pushes the rear up";
  EXPECT_LT(f[0], toQ4(300));
  EXPECT_EQ(f[1], toQ4(300));
}

TEST(Mixer, RollAndPitchBeyondTheRangeAreScaledDownKeepingTheirDirectionAndYawIsDropped) {
  Mixer mixer;
  mixer.configure(Layout::kX, 0.225f, 0.015f);
  ForceQ4 f[4];
  const Torque asked = {3.0f, 1.5f, 0.05f};  // far more than 20..800 g can make
  const uint8_t limits = mixer.mix(toQ4(300), asked, toQ4(20), toQ4(800), f);
  EXPECT_EQ(limits & (kMixRollPitchLimited | kMixYawLimited), kMixRollPitchLimited | kMixYawLimited);
  for (ForceQ4 v : f) {
    EXPECT_GE(v, toQ4(20) - 1);
    EXPECT_LE(v, toQ4(800) + 1);
  }
  const Made made = torqueOf(Layout::kX, f, 0.225, 0.015);
  EXPECT_NEAR(made.x_nm / made.y_nm, 2.0, 2e-3) << "the direction of the roll/pitch torque";
  EXPECT_NEAR(made.z_nm, 0.0, 1e-4);
  ForceQ4 lo = f[0], hi = f[0];
  for (ForceQ4 v : f) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  EXPECT_NEAR(hi - lo, toQ4(780), 2) << "the whole range is used";
}

TEST(Mixer, YawIsScaledToFitWhileRollAndPitchStayWhole) {
  Mixer mixer;
  mixer.configure(Layout::kPlus, 0.225f, 0.015f);
  ForceQ4 f[4];
  const Torque asked = {0.3f, 0.0f, 0.2f};  // the roll fits alone, roll + yaw do not
  const uint8_t limits = mixer.mix(toQ4(300), asked, toQ4(20), toQ4(600), f);
  EXPECT_EQ(limits & kMixYawLimited, kMixYawLimited);
  EXPECT_EQ(limits & kMixRollPitchLimited, 0);
  const Made made = torqueOf(Layout::kPlus, f, 0.225, 0.015);
  EXPECT_NEAR(made.x_nm, 0.3, 3e-4) << "roll untouched";
  EXPECT_GT(made.z_nm, 0.0);
  EXPECT_LT(made.z_nm, 0.2);
  for (ForceQ4 v : f) {
    EXPECT_GE(v, toQ4(20) - 1);
    EXPECT_LE(v, toQ4(600) + 1);
  }
}

// The saturation path as it was in float (a * num / den per motor, rounded to 1/16 g): the
// reference the integer path (a 16-bit fraction and a shift, floored; yaw's share towards zero)
// is held to. Tolerance: kSaturatedToleranceQ4 per motor (3/16 g): the fraction's relative
// 2^-15 and the floor against the float's rounding put each scaled term within ~1.5 of the
// float's for scaled values (which never exceed the range) up to 2^15 (2 kg), whatever the torque
// asked for; the collective shifts by the bounds, which may differ as much. The roll/pitch and
// yaw limit bits are the same (decided before any scaling); the collective's bit may differ
// where the float path's rounding left its spread a sixteenth over the range. Unlike the float
// path the integer one never leaves [min, max] (the floors keep each spread at most the range).
constexpr ForceQ4 kSaturatedToleranceQ4 = 3;

struct FloatMix {
  ForceQ4 force[4];
  uint8_t limits;
};

FloatMix floatReferenceMix(Layout layout, ForceQ4 collective, TorqueQ4 t, ForceQ4 min, ForceQ4 max) {
  const int n = layout == Layout::kSeesaw ? 2 : 4;
  const ForceQ4 z = layout == Layout::kSeesaw ? 0 : t.z;
  ForceQ4 rp[4];
  switch (layout) {
    case Layout::kPlus:
      rp[0] = -t.y, rp[1] = t.x, rp[2] = t.y, rp[3] = -t.x;
      break;
    default:  // kX
      rp[0] = t.x - t.y, rp[1] = t.x + t.y, rp[2] = t.y - t.x, rp[3] = -t.x - t.y;
      break;
  }
  if (layout == Layout::kSeesaw) rp[0] = t.x, rp[1] = -t.x, rp[2] = 0, rp[3] = 0;
  auto bounds = [n](const ForceQ4 (&v)[4], ForceQ4& lo, ForceQ4& hi) {
    lo = hi = v[0];
    for (int i = 1; i < n; ++i) lo = std::min(lo, v[i]), hi = std::max(hi, v[i]);
  };
  auto scaled = [](ForceQ4 a, ForceQ4 num, ForceQ4 den) {
    return toQ4(gramsOf(a) * (static_cast<float>(num) / static_cast<float>(den)));
  };
  FloatMix out{};
  ForceQ4 e[4];
  for (int i = 0; i < 4; ++i) e[i] = (i & 1) ? rp[i] + z : rp[i] - z;
  ForceQ4 lo, hi;
  bounds(e, lo, hi);
  const ForceQ4 range = max > min ? max - min : 0;
  if (hi - lo > range) {
    const ForceQ4 full = hi - lo;
    bounds(rp, lo, hi);
    const ForceQ4 rp_spread = hi - lo;
    if (rp_spread > range) {
      for (int i = 0; i < 4; ++i) e[i] = scaled(rp[i], range, rp_spread);
      out.limits = kMixRollPitchLimited | kMixYawLimited;
    } else {
      const ForceQ4 share = scaled(z, range - rp_spread, full - rp_spread);
      for (int i = 0; i < 4; ++i) e[i] = (i & 1) ? rp[i] + share : rp[i] - share;
      out.limits = kMixYawLimited;
    }
    bounds(e, lo, hi);
  }
  ForceQ4 c = collective;
  if (c < min - lo) {
    c = min - lo;
    out.limits |= kMixCollectiveLimited;
  } else if (c > max - hi) {
    c = max - hi;
    out.limits |= kMixCollectiveLimited;
  }
  for (int i = 0; i < 4; ++i) out.force[i] = i < n ? c + e[i] : 0;
  return out;
}

struct SaturatedCase {
  Layout layout;
  float collective_g, min_g, max_g;
  TorqueQ4 torque;  // 1/16 g per motor
  uint8_t limits;   // what the mixer must say it gave up (the collective's bit aside)
};

TEST(Mixer, TheIntegerSaturationPathMatchesTheFloatReferenceWithinThreeSixteenthsOfAGram) {
  constexpr uint8_t kRpYaw = kMixRollPitchLimited | kMixYawLimited;
  const SaturatedCase cases[] = {
      // roll and pitch alone too wide: scaled, yaw dropped
      {Layout::kX, 300, 20, 800, {toQ4(700), toQ4(350), toQ4(40)}, kRpYaw},
      {Layout::kX, 300, 20, 800, {toQ4(-700), toQ4(350), toQ4(-40)}, kRpYaw},
      {Layout::kX, 500, 0, 1000, {toQ4(3000), toQ4(-2900), toQ4(900)}, kRpYaw},
      {Layout::kX, 300, 20, 800, {toQ4(401), 0, 0}, kRpYaw},  // just over, on one axis
      {Layout::kPlus, 300, 20, 800, {toQ4(500), toQ4(-450), 7}, kRpYaw},
      {Layout::kPlus, 300, 20, 600, {toQ4(-1200), toQ4(10), toQ4(-5)}, kRpYaw},
      {Layout::kSeesaw, 300, 20, 800, {toQ4(900), toQ4(100), toQ4(100)}, kRpYaw},
      {Layout::kSeesaw, 400, 0, 1200, {toQ4(-1999.9f), 0, 0}, kRpYaw},
      // roll and pitch fit, yaw scaled to the rest
      {Layout::kX, 300, 20, 800, {toQ4(150), toQ4(-100), toQ4(300)}, kMixYawLimited},
      {Layout::kX, 300, 20, 800, {toQ4(-150), toQ4(100), toQ4(-300)}, kMixYawLimited},
      {Layout::kX, 700, 20, 800, {toQ4(30), toQ4(30), toQ4(500)}, kMixYawLimited},
      {Layout::kPlus, 300, 20, 600, {toQ4(90), 0, toQ4(250)}, kMixYawLimited},
      {Layout::kPlus, 100, 20, 600, {0, toQ4(-120), toQ4(-2000)}, kMixYawLimited},
      {Layout::kPlus, 300, 0, 1000, {toQ4(499), toQ4(499), toQ4(3)}, kMixYawLimited},
      {Layout::kX, 2000, 0, 4000, {toQ4(900), toQ4(800), toQ4(9000)}, kMixYawLimited},  // > 2^15
  };
  for (const SaturatedCase& c : cases) {
    SCOPED_TRACE(testing::Message() << "layout " << static_cast<int>(c.layout) << " torque " << c.torque.x
                                    << " " << c.torque.y << " " << c.torque.z);
    Mixer mixer;
    mixer.configure(c.layout, 0.225f, 0.015f);
    ForceQ4 f[4];
    const ForceQ4 min = toQ4(c.min_g), max = toQ4(c.max_g);
    const uint8_t limits = mixer.mixQ4(toQ4(c.collective_g), c.torque, min, max, f);
    const FloatMix ref = floatReferenceMix(c.layout, toQ4(c.collective_g), c.torque, min, max);
    EXPECT_EQ(limits & kRpYaw, c.limits);
    EXPECT_EQ(limits & kRpYaw, ref.limits & kRpYaw);
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(f[i], ref.force[i], kSaturatedToleranceQ4) << "motor " << i;
      if (mixer.flies(static_cast<uint8_t>(i))) {
        EXPECT_GE(f[i], min) << "motor " << i;
        EXPECT_LE(f[i], max) << "motor " << i;
      } else {
        EXPECT_EQ(f[i], 0);
      }
    }
  }
}

// The same over random torques up to 2 kg a motor on each axis (most of them saturate) on each
// layout: never outside [min, max], within the tolerance of the float reference, the same
// roll/pitch and yaw limits.
TEST(Mixer, RandomSaturatedTorquesStayInRangeAndNearTheFloatReference) {
  std::mt19937 rng(19);
  std::uniform_int_distribution<ForceQ4> torque(-toQ4(2000), toQ4(2000));
  std::uniform_int_distribution<ForceQ4> collective(toQ4(0), toQ4(1000));
  ForceQ4 worst = 0;
  for (Layout layout : {Layout::kPlus, Layout::kX, Layout::kSeesaw}) {
    Mixer mixer;
    mixer.configure(layout, 0.225f, 0.015f);
    for (int k = 0; k < 20000; ++k) {
      const TorqueQ4 t = {torque(rng), torque(rng), torque(rng)};
      const ForceQ4 min = toQ4(20), max = toQ4(800), c = collective(rng);
      ForceQ4 f[4];
      const uint8_t limits = mixer.mixQ4(c, t, min, max, f);
      const FloatMix ref = floatReferenceMix(layout, c, t, min, max);
      ASSERT_EQ(limits & (kMixRollPitchLimited | kMixYawLimited),
                ref.limits & (kMixRollPitchLimited | kMixYawLimited))
          << k;
      for (int i = 0; i < 4; ++i) {
        worst = std::max(worst, std::abs(f[i] - ref.force[i]));
        ASSERT_NEAR(f[i], ref.force[i], kSaturatedToleranceQ4) << k << " motor " << i;
        if (mixer.flies(static_cast<uint8_t>(i))) {
          ASSERT_GE(f[i], min) << k;
          ASSERT_LE(f[i], max) << k;
        }
      }
    }
  }
  RecordProperty("worst_q4", worst);
}

TEST(Mixer, TheCollectiveGivesWayToTheTorqueAtTheBottomAndTheTop) {
  Mixer mixer;
  mixer.configure(Layout::kX, 0.225f, 0.015f);
  for (float collective : {10.0f, 790.0f}) {
    ForceQ4 f[4];
    const uint8_t limits = mixer.mix(toQ4(collective), {0.2f, 0.0f, 0.0f}, toQ4(20), toQ4(800), f);
    EXPECT_EQ(limits, kMixCollectiveLimited) << collective;
    const Made made = torqueOf(Layout::kX, f, 0.225, 0.015);
    EXPECT_NEAR(made.x_nm, 0.2, 3e-4) << collective;
    for (ForceQ4 v : f) {
      EXPECT_GE(v, toQ4(20));
      EXPECT_LE(v, toQ4(800));
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Controller

TEST(Controller, TheThesisGainsAreKp22AndKd04ConvertedToTorqueOnTheIqarus) {
  // 2.2 us/deg and 0.4 us/(deg/s) on two opposite motors 0.225 m out, 1.44 g/us (table 5.1:
  // 300 g at 1514 us, thrust from ~1097 us, F ~ (pwm - start)^2).
  const double slope_g_per_us = 2.0 * 300.0 / (1514.0 - 1097.0);
  const double nm_per_us_per_motor_pair = slope_g_per_us * 2.0 * 0.225 * kG0 / 1000.0;
  EXPECT_NEAR(kThesisGains.kp_nm_per_rad, 2.2 * nm_per_us_per_motor_pair / kDeg, 0.001);
  EXPECT_NEAR(kThesisGains.kd_nm_s_per_rad, 0.4 * nm_per_us_per_motor_pair / kDeg, 0.001);
  EXPECT_EQ(kThesisGains.ki_nm_per_rad_s, 0.0f) << "the thesis flew a PD";
}

TEST(Controller, ProportionalOnTheAngleErrorDerivativeOnTheMeasuredRate) {
  AttitudeController c;
  c.setGains({0.8f, 0.0f, 0.15f}, {0.1f, 0.0f});
  Attitude a;
  a.roll_rad = 0.1f;
  a.pitch_rad = -0.05f;
  a.rate_rad_s[0] = 0.5f;
  a.rate_rad_s[1] = 0.0f;
  a.rate_rad_s[2] = 0.2f;
  Setpoint sp;
  sp.pitch_rad = 0.05f;
  const Torque t = c.torque(a, sp);
  EXPECT_NEAR(t.x_nm, 0.8 * -0.1 - 0.15 * 0.5, 1e-6);
  EXPECT_NEAR(t.y_nm, 0.8 * 0.1, 1e-6);
  EXPECT_NEAR(t.z_nm, 0.1 * -0.2, 1e-6);
  // a setpoint step changes the torque by kp times the step, no more (no derivative kick)
  Setpoint step = sp;
  step.roll_rad += 0.2f;
  EXPECT_NEAR(c.torque(a, step).x_nm - t.x_nm, 0.8 * 0.2, 1e-6);
}

TEST(Controller, IntegratorsAccumulateClampHoldWhenTheMixerLimitsAndReset) {
  AttitudeController c;
  c.setGains({0.0f, 2.0f, 0.0f}, {0.0f, 1.0f});
  Attitude a;
  a.rate_rad_s[2] = -0.5f;
  Setpoint sp;
  sp.roll_rad = 0.1f;
  c.integrate(a, sp, 0.0025f, 0);
  EXPECT_NEAR(c.integralNm(0), 2.0 * 0.1 * 0.0025, 1e-7);
  EXPECT_NEAR(c.integralNm(2), 1.0 * 0.5 * 0.0025, 1e-7);
  c.integrate(a, sp, 0.0025f, kMixRollPitchLimited);
  EXPECT_NEAR(c.integralNm(0), 2.0 * 0.1 * 0.0025, 1e-7) << "held while roll/pitch are limited";
  EXPECT_NEAR(c.integralNm(2), 2 * 1.0 * 0.5 * 0.0025, 1e-7);
  for (int i = 0; i < 10000; ++i) c.integrate(a, sp, 0.0025f, kMixYawLimited);
  EXPECT_FLOAT_EQ(c.integralNm(0), AttitudeController::kIntegralMaxNm);
  EXPECT_NEAR(c.integralNm(2), 2 * 1.0 * 0.5 * 0.0025, 1e-7) << "yaw held";
  EXPECT_NEAR(c.torque(a, sp).x_nm, AttitudeController::kIntegralMaxNm, 1e-6);
  c.reset();
  EXPECT_EQ(c.integralNm(0), 0.0f);
  EXPECT_EQ(c.integralNm(2), 0.0f);
}

// The frame path (torqueQ4 on the estimator's fixed-point units, in the mixer's 1/16 g) is the
// law torque() writes in N m, times the mixer's scale: within a sixteenth of a gram per term.
TEST(Controller, TheFixedPointTorqueIsTheLawTimesTheMixersScale) {
  Mixer m;
  m.configure(Layout::kPlus, 0.225f, 0.0149f);
  AttitudeController c;
  c.setGains({0.8f, 0.0f, 0.146f}, {0.1f, 0.0f});
  c.setForceScale(m.q4PerNmXy(), m.q4PerNmZ());
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> angle(-0.6, 0.6), rate(-6.0, 6.0);
  for (int k = 0; k < 2000; ++k) {
    AttitudeQ q;
    q.roll = angleUnits(static_cast<float>(angle(rng)));
    q.pitch = angleUnits(static_cast<float>(angle(rng)));
    for (int32_t& r : q.rate) r = static_cast<int32_t>(std::lround(rate(rng) / kRadPerRateUnit));
    Setpoint sp;
    sp.roll_rad = static_cast<float>(angle(rng) / 3);
    sp.pitch_rad = static_cast<float>(angle(rng) / 3);
    Attitude a;  // the same state in radians, in double first
    a.roll_rad = static_cast<float>(q.roll * static_cast<double>(kRadPerAngleUnit));
    a.pitch_rad = static_cast<float>(q.pitch * static_cast<double>(kRadPerAngleUnit));
    for (int i = 0; i < 3; ++i) a.rate_rad_s[i] = static_cast<float>(q.rate[i] * static_cast<double>(kRadPerRateUnit));
    const Torque t = c.torque(a, sp);
    const TorqueQ4 f = c.torqueQ4(q, fixedSetpoint(sp));
    ASSERT_NEAR(f.x, t.x_nm * m.q4PerNmXy(), 2.0) << k;
    ASSERT_NEAR(f.y, t.y_nm * m.q4PerNmXy(), 2.0) << k;
    ASSERT_NEAR(f.z, t.z_nm * m.q4PerNmZ(), 2.0) << k;
  }
}

// ---------------------------------------------------------------------------------------------
// Estimator

ImuSample sampleAt(double roll_deg, double pitch_deg, const double (&rate_dps)[3] = {0, 0, 0},
                   const int16_t (&bias_lsb)[3] = {0, 0, 0}, double g = 1.0) {
  const double r = roll_deg * kDeg, p = pitch_deg * kDeg;
  ImuSample s;
  const double a[3] = {-std::sin(p), std::sin(r) * std::cos(p), std::cos(r) * std::cos(p)};
  for (int i = 0; i < 3; ++i) {
    s.accel[i] = static_cast<int16_t>(std::lround(a[i] * g * 4096.0));
    s.gyro[i] = static_cast<int16_t>(std::lround(rate_dps[i] * 16.4) + bias_lsb[i]);
  }
  s.fresh = true;
  return s;
}

TEST(Estimator, Atan2ApproxIsWithinTwoHundredThousandthsOfARadianEverywhere) {
  double worst = 0;
  for (int i = 0; i < 720; ++i) {
    const double angle = (i - 360) * M_PI / 360.0 + 0.001;
    for (double radius : {0.01, 1.0, 4096.0}) {
      const float y = static_cast<float>(radius * std::sin(angle)),
                  x = static_cast<float>(radius * std::cos(angle));
      worst = std::max(worst, std::fabs(static_cast<double>(atan2Approx(y, x)) - std::atan2(y, x)));
    }
  }
  EXPECT_LT(worst, 2e-5);
  EXPECT_EQ(atan2Approx(0, 0), 0.0f);
  EXPECT_NEAR(atan2Approx(1, 0), M_PI / 2, 1e-6);
  EXPECT_NEAR(atan2Approx(0, -1), M_PI, 1e-6);
}

TEST(Estimator, GyroBiasAtRestIsTheMeanAndMotionStartsTheCalibrationAgain) {
  GyroCalibration cal;
  cal.restart();
  const int16_t bias[3] = {100, -50, 20};
  // given: a moving start (30 deg/s about x), then rest with +-3 LSB of noise
  EXPECT_FALSE(cal.add(sampleAt(0, 0, {0, 0, 0}, bias)));
  EXPECT_FALSE(cal.add(sampleAt(0, 0, {30, 0, 0}, bias)));
  EXPECT_EQ(cal.restarts(), 1);
  int n = 0;
  bool done = false;
  while (!done && n < 1000) {
    ImuSample s = sampleAt(0, 0, {0, 0, 0}, bias);
    for (int i = 0; i < 3; ++i) s.gyro[i] = static_cast<int16_t>(s.gyro[i] + (n + 2 * i) % 7 - 3);
    done = cal.add(s);
    ++n;
  }
  // then
  EXPECT_EQ(n, GyroCalibration::kSamples);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(cal.biasLsb(i), bias[i], 0.5) << i;
  EXPECT_NEAR(cal.accelMeanLsb(2), 4096, 1);
}

TEST(Estimator, AnAccelerometerFarFromOneGIsNoRestForTheCalibration) {
  GyroCalibration cal;
  cal.restart();
  for (int n = 0; n < 500; ++n) EXPECT_FALSE(cal.add(sampleAt(0, 0, {0, 0, 0}, {0, 0, 0}, 1.3)));
  EXPECT_FALSE(cal.done());
}

AttitudeEstimator startedAt(double roll_deg, double pitch_deg, const int16_t (&bias)[3] = {0, 0, 0}) {
  GyroCalibration cal;
  cal.restart();
  while (!cal.add(sampleAt(roll_deg, pitch_deg, {0, 0, 0}, bias))) {
  }
  AttitudeEstimator e;
  e.start(cal);
  return e;
}

TEST(Estimator, AStaticTiltIsTheFirstAttitude) {
  const struct { double roll, pitch; } tilts[] = {{0, 0}, {10, -5}, {-30, 20}, {60, 0}, {0, -80}};
  for (const auto& t : tilts) {
    const AttitudeEstimator e = startedAt(t.roll, t.pitch);
    EXPECT_NEAR(e.attitude().roll_rad / kDeg, t.roll, 0.05) << t.roll << " " << t.pitch;
    EXPECT_NEAR(e.attitude().pitch_rad / kDeg, t.pitch, 0.05) << t.roll << " " << t.pitch;
  }
}

TEST(Estimator, ARateStepIntegratesWithTheBiasRemoved) {
  const int16_t bias[3] = {-120, 80, 33};
  AttitudeEstimator e = startedAt(0, 0, bias);
  for (int k = 0; k < 100; ++k) e.propagate(sampleAt(0, 0, {100, 0, 0}, bias), 1);  // 0.25 s, a frame each
  EXPECT_NEAR(e.attitude().roll_rad / kDeg, 25.0, 0.1);
  EXPECT_NEAR(e.attitude().pitch_rad / kDeg, 0.0, 0.01);
  EXPECT_NEAR(e.attitude().rate_rad_s[0] / kDeg, 100.0, 0.05);
  for (int k = 0; k < 100; ++k) e.propagate(sampleAt(25, 0, {0, -40, 0}, bias), 1);
  EXPECT_NEAR(e.attitude().pitch_rad / kDeg, -10.0, 0.1);
}

TEST(Estimator, YawingWhileRolledTurnsRollIntoPitch) {
  AttitudeEstimator e = startedAt(10, 0);
  for (int k = 0; k < 40; ++k) e.propagate(sampleAt(10, 0, {0, 0, 90}), 1);  // 0.1 s at 90 deg/s
  // pitch' = q - r roll: -90 deg/s * 0.1745 rad * 0.1 s = -1.57 deg
  EXPECT_NEAR(e.attitude().pitch_rad / kDeg, -1.57, 0.05);
}

TEST(Estimator, TheAccelerometerPullsADriftedEstimateBackWithItsTimeConstant) {
  AttitudeEstimator e = startedAt(0, 0);
  // the vehicle is at roll 5, pitch -3 deg, still; the estimate says level
  const ImuSample s = sampleAt(5, -3);
  const float interval_s = 8 * 0.0025f;
  const int per_tau = static_cast<int>(AttitudeEstimator::kTimeConstantS / interval_s + 0.5f);
  for (int k = 0; k < per_tau; ++k) {
    e.correctRoll(s, interval_s);
    e.correctPitch(s, interval_s);
  }
  EXPECT_NEAR(e.attitude().roll_rad / kDeg, 5.0 * (1 - std::exp(-1.0)), 0.1) << "one time constant";
  for (int k = 0; k < 6 * per_tau; ++k) {
    e.correctRoll(s, interval_s);
    e.correctPitch(s, interval_s);
  }
  EXPECT_NEAR(e.attitude().roll_rad / kDeg, 5.0, 0.02);
  EXPECT_NEAR(e.attitude().pitch_rad / kDeg, -3.0, 0.02);
  // a specific force far from 1 g (a jolt) says nothing of tilt: ignored
  const float before = e.attitude().roll_rad;
  e.correctRoll(sampleAt(40, 0, {0, 0, 0}, {0, 0, 0}, 1.4), interval_s);
  EXPECT_EQ(e.attitude().roll_rad, before);
  EXPECT_EQ(e.untrustedAccel(), 1u);
}

// ---------------------------------------------------------------------------------------------
// ArduPilot's curve against the lab's implementation of ArduPilot's source (double precision)

lab::autopilot::ArduPilotParams labParams(const ArduPilotParams& p) {
  lab::autopilot::ArduPilotParams l;
  l.thst_expo = p.expo;
  l.spin_min = p.spin_min;
  l.spin_max = p.spin_max;
  l.pwm_min_us = p.pwm_min_us;
  l.pwm_max_us = p.pwm_max_us;
  l.bat_volt_max_v = p.bat_volt_max_v;
  l.bat_volt_min_v = p.bat_volt_min_v;
  return l;
}

// The parameters `lab export --to ardupilot` fitted in docs/autopilot.md's walkthrough.
ArduPilotParams walkthroughParams() {
  ArduPilotParams p;
  p.expo = 0.6913f;
  p.spin_min = 0.1581f;
  p.spin_max = 0.95f;
  p.bat_volt_max_v = 12.6f;
  p.bat_volt_min_v = 9.9f;
  p.full_thrust_g = 1315.1f;
  return p;
}

TEST(ArduPilotCurve, PulsesAreWhatArduPilotSendsWithinOneMicrosecondAtEveryForceAndVoltage) {
  const ArduPilotParams fitted = walkthroughParams();
  ArduPilotParams linear = fitted;
  linear.expo = 0.0f;
  ArduPilotParams negative = fitted;
  negative.expo = -0.3f;
  negative.pwm_min_us = 1100;
  negative.pwm_max_us = 1900;
  ArduPilotParams no_volts = fitted;
  no_volts.bat_volt_max_v = 0;
  int compared = 0;
  for (const ArduPilotParams& p : {fitted, linear, negative, no_volts}) {
    for (uint16_t mv : {7000, 9500, 10500, 11100, 12000, 12600, 13500}) {
      ArduPilotCurve curve;
      curve.setParams(p);
      curve.updateBattery(mv, 0.01f);  // the first reading sets the filter
      for (int f = 0; f <= 1400; f += 10) {
        const int want =
            lab::autopilot::ardupilot::pwmForThrust(labParams(p), f / p.full_thrust_g, mv / 1000.0);
        ASSERT_NEAR(curve.pulseUs(static_cast<float>(f)), want, 1)
            << "expo " << p.expo << " at " << mv << " mV, " << f << " g";
        ++compared;
      }
      EXPECT_NEAR(curve.liftMax(), lab::autopilot::ardupilot::liftMax(labParams(p), mv / 1000.0), 1e-5);
    }
  }
  EXPECT_EQ(compared, 4 * 7 * 141);
}

// The frame path: the integer table (pulseUsQ4) against the same reference, same tolerance.
TEST(ArduPilotCurve, TheTablesPulsesAreWhatArduPilotSendsWithinOneMicrosecond) {
  const ArduPilotParams fitted = walkthroughParams();
  ArduPilotParams negative = fitted;
  negative.expo = -0.3f;
  negative.pwm_min_us = 1100;
  negative.pwm_max_us = 1900;
  ArduPilotParams low_min = fitted;  // V_MIN raised to 0.6 V_MAX: the largest 1 / v
  low_min.bat_volt_min_v = 5.0f;
  ArduPilotParams steep = fitted;
  steep.expo = ArduPilotCurve::kTableMaxExpo;
  for (const ArduPilotParams& p : {fitted, negative, low_min, steep}) {
    for (uint16_t mv : {7000, 7560, 9500, 11100, 12600, 13500}) {
      ArduPilotCurve curve;
      curve.setParams(p);
      ASSERT_TRUE(curve.usesTable()) << "expo " << p.expo;
      curve.updateBattery(mv, 0.01f);
      for (int q4 = 0; q4 <= 1400 * 16; q4 += 7) {
        const int want =
            lab::autopilot::ardupilot::pwmForThrust(labParams(p), q4 / 16.0 / p.full_thrust_g, mv / 1000.0);
        ASSERT_NEAR(curve.pulseUsQ4(q4), want, 1) << "expo " << p.expo << " at " << mv << " mV, " << q4 << " q4";
      }
    }
  }
}

// The table's interpolation error, swept over the expo at the lowest voltage ratio (0.6): within
// kTableMaxErrorUs up to kTableMaxExpo; beyond it pulseUsQ4 flies the float arithmetic.
TEST(ArduPilotCurve, TheTableIsWithinHalfAMicrosecondUpToItsExpoLimitAndFloatBeyond) {
  ArduPilotParams p;
  p.bat_volt_max_v = 12.6f;
  p.bat_volt_min_v = 7.56f;
  p.full_thrust_g = 1300;
  float worst = 0;
  for (int e100 = -100; e100 <= 100; ++e100) {
    p.expo = e100 / 100.0f;
    ArduPilotCurve curve;
    curve.setParams(p);
    const bool inside = std::fabs(p.expo) <= ArduPilotCurve::kTableMaxExpo;
    EXPECT_EQ(curve.usesTable(), inside) << "expo " << p.expo;
    if (!inside) {
      curve.updateBattery(9000, 0.01f);
      for (int q4 = 0; q4 <= 1300 * 16; q4 += 160) EXPECT_EQ(curve.pulseUsQ4(q4), curve.pulseUs(q4 / 16.0f));
      continue;
    }
    const float error = curve.tableErrorUs();
    EXPECT_LT(error, ArduPilotCurve::kTableMaxErrorUs) << "expo " << p.expo;
    worst = std::max(worst, error);
  }
  RecordProperty("worst_table_error_us", std::to_string(worst));
}

TEST(ArduPilotCurve, TheVoltageFollowsArduPilotsHalfHertzFilter) {
  ArduPilotParams p;
  p.bat_volt_max_v = 12.6f;
  p.bat_volt_min_v = 9.9f;
  p.full_thrust_g = 1300;
  ArduPilotCurve curve;
  curve.setParams(p);
  curve.updateBattery(12600, 0.01f);
  EXPECT_FLOAT_EQ(curve.voltageRatio(), 1.0f);
  // a step to 11.34 V (ratio 0.9): after one time constant 1 / (2 pi 0.5 Hz) = 0.318 s, 63 %
  for (int k = 0; k < 32; ++k) curve.updateBattery(11340, 0.01f);
  EXPECT_NEAR(curve.voltageRatio(), 1.0 - 0.1 * (1 - std::exp(-1.0)), 0.003);
  for (int k = 0; k < 400; ++k) curve.updateBattery(11340, 0.01f);
  EXPECT_NEAR(curve.voltageRatio(), 0.9, 1e-4);
  EXPECT_NEAR(curve.maxForceG(), 1300 * (0.9 * (1 - 0.65) + 0.65 * 0.81), 0.05);
}

TEST(ArduPilotCurve, WithoutAFullThrustTheModeIsNotReady) {
  ArduPilotCurve curve;
  EXPECT_FALSE(curve.ready());
  ArduPilotParams p;
  p.full_thrust_g = 1000;
  curve.setParams(p);
  EXPECT_TRUE(curve.ready());
}

}  // namespace
