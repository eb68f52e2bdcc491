// fly's mixer alone (firmware/fly/mixer.hpp, linking fly_mixer and the flight types only): the
// forces it gives must make the torque asked for on the airframe's geometry (plus, X, seesaw),
// and its integer saturation path must stay in range and near the float reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "mixer.hpp"

namespace {

using namespace fly;
constexpr double kG0 = 9.80665;


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

Made torqueOf(Layout layout, const Forces& force, double arm_m, double kq_m) {
  Made m;
  const auto ms = mounts(layout, arm_m);
  for (std::size_t i = 0; i < ms.size(); ++i) {
    const double f_g = force.dg[i] / 10.0;
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

TEST(Mixer, UnsaturatedForcesMakeTheTorqueAndTheCollectiveAskedForToTheDecigram) {
  const MixCase cases[] = {
      {Layout::kPlus, 300, {0.0f, 0.0f, 0.0f}},    {Layout::kPlus, 300, {0.2f, 0.0f, 0.0f}},
      {Layout::kPlus, 300, {0.0f, -0.3f, 0.0f}},   {Layout::kPlus, 300, {0.1f, 0.1f, 0.02f}},
      {Layout::kX, 300, {0.2f, 0.0f, 0.0f}},       {Layout::kX, 300, {0.0f, 0.2f, 0.0f}},
      {Layout::kX, 300, {-0.15f, 0.1f, -0.02f}},   {Layout::kX, 250, {0.0f, 0.0f, 0.03f}},
      {Layout::kSeesaw, 300, {0.3f, 0.2f, 0.05f}},  // pitch and yaw: not on a seesaw
  };
  for (const MixCase& c : cases) {
    Mixer mixer;
    mixer.configure({c.layout, 0.225f, 0.015f});
    Forces f;
    const uint8_t limits = mixer.mix(forceDgOf(c.collective_g), c.torque, forceDgOf(20), forceDgOf(800), f);
    const Made made = torqueOf(c.layout, f, 0.225, 0.015);
    const int layout = static_cast<int>(c.layout);
    EXPECT_EQ(limits, 0) << layout;
    EXPECT_NEAR(made.x_nm, c.torque.x_nm, 5e-4) << layout;  // forces in decigrams
    if (c.layout == Layout::kSeesaw) {
      EXPECT_EQ(f.dg[2], 0);
      EXPECT_EQ(f.dg[3], 0);
      EXPECT_NEAR(made.total_g, 2 * c.collective_g, 0.1);
      continue;
    }
    EXPECT_NEAR(made.y_nm, c.torque.y_nm, 5e-4) << layout;
    EXPECT_NEAR(made.z_nm, c.torque.z_nm, 5e-5) << layout;
    EXPECT_NEAR(made.total_g, 4 * c.collective_g, 0.2) << layout;
  }
}

TEST(Mixer, PlusLayoutRollsOnTheSideMotorsAndPitchesOnFrontAndRear) {
  Mixer mixer;
  mixer.configure({Layout::kPlus, 0.225f, 0.015f});
  Forces f;
  mixer.mix(forceDgOf(300), {0.1f, 0.0f, 0.0f}, 0, forceDgOf(1000), f);
  EXPECT_EQ(f.dg[0], forceDgOf(300)) << "front: no roll";
  EXPECT_EQ(f.dg[2], forceDgOf(300)) << "rear: no roll";
  EXPECT_GT(f.dg[1], forceDgOf(300)) << "positive roll (right side down) pushes the left motor up";
  EXPECT_LT(f.dg[3], forceDgOf(300));
  mixer.mix(forceDgOf(300), {0.0f, 0.1f, 0.0f}, 0, forceDgOf(1000), f);
  EXPECT_GT(f.dg[2], forceDgOf(300)) << "positive pitch (nose down) pushes the rear up";
  EXPECT_LT(f.dg[0], forceDgOf(300));
  EXPECT_EQ(f.dg[1], forceDgOf(300));
}

TEST(Mixer, RollAndPitchBeyondTheRangeAreScaledDownKeepingTheirDirectionAndYawIsDropped) {
  Mixer mixer;
  mixer.configure({Layout::kX, 0.225f, 0.015f});
  Forces f;
  const Torque asked = {3.0f, 1.5f, 0.05f};  // far more than 20..800 g can make
  const uint8_t limits = mixer.mix(forceDgOf(300), asked, forceDgOf(20), forceDgOf(800), f);
  EXPECT_EQ(limits & (kMixRollPitchLimited | kMixYawLimited), kMixRollPitchLimited | kMixYawLimited);
  for (ForceDg v : f.dg) {
    EXPECT_GE(v, forceDgOf(20) - 1);
    EXPECT_LE(v, forceDgOf(800) + 1);
  }
  const Made made = torqueOf(Layout::kX, f, 0.225, 0.015);
  EXPECT_NEAR(made.x_nm / made.y_nm, 2.0, 2e-3) << "the direction of the roll/pitch torque";
  EXPECT_NEAR(made.z_nm, 0.0, 1e-4);
  ForceDg lo = f.dg[0], hi = f.dg[0];
  for (ForceDg v : f.dg) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  EXPECT_NEAR(hi - lo, forceDgOf(780), 2) << "the whole range is used";
}

TEST(Mixer, YawIsScaledToFitWhileRollAndPitchStayWhole) {
  Mixer mixer;
  mixer.configure({Layout::kPlus, 0.225f, 0.015f});
  Forces f;
  const Torque asked = {0.3f, 0.0f, 0.2f};  // the roll fits alone, roll + yaw do not
  const uint8_t limits = mixer.mix(forceDgOf(300), asked, forceDgOf(20), forceDgOf(600), f);
  EXPECT_EQ(limits & kMixYawLimited, kMixYawLimited);
  EXPECT_EQ(limits & kMixRollPitchLimited, 0);
  const Made made = torqueOf(Layout::kPlus, f, 0.225, 0.015);
  EXPECT_NEAR(made.x_nm, 0.3, 3e-4) << "roll untouched";
  EXPECT_GT(made.z_nm, 0.0);
  EXPECT_LT(made.z_nm, 0.2);
  for (ForceDg v : f.dg) {
    EXPECT_GE(v, forceDgOf(20) - 1);
    EXPECT_LE(v, forceDgOf(600) + 1);
  }
}

// The saturation path as it was in float (a * num / den per motor, rounded to a decigram): the
// reference the integer path (a 16-bit fraction and a shift, floored; yaw's share towards zero)
// is held to. Tolerance: kSaturatedToleranceDg per motor (3 dg): the fraction's relative
// 2^-15 and the floor against the float's rounding put each scaled term within ~1.5 of the
// float's for scaled values (which never exceed the range) up to 2^15 (3.2 kg), whatever the torque
// asked for; the collective shifts by the bounds, which may differ as much. The roll/pitch and
// yaw limit bits are the same (decided before any scaling); the collective's bit may differ
// where the float path's rounding left its spread a decigram over the range. Unlike the float
// path the integer one never leaves [min, max] (the floors keep each spread at most the range).
constexpr ForceDg kSaturatedToleranceDg = 3;

struct FloatMix {
  ForceDg force[4];
  uint8_t limits;
};

FloatMix floatReferenceMix(Layout layout, ForceDg collective, TorqueDg t, ForceDg min, ForceDg max) {
  const int n = layout == Layout::kSeesaw ? 2 : 4;
  const ForceDg z = layout == Layout::kSeesaw ? 0 : t.z;
  ForceDg rp[4];
  switch (layout) {
    case Layout::kPlus:
      rp[0] = -t.y, rp[1] = t.x, rp[2] = t.y, rp[3] = -t.x;
      break;
    default:  // kX
      rp[0] = t.x - t.y, rp[1] = t.x + t.y, rp[2] = t.y - t.x, rp[3] = -t.x - t.y;
      break;
  }
  if (layout == Layout::kSeesaw) rp[0] = t.x, rp[1] = -t.x, rp[2] = 0, rp[3] = 0;
  auto bounds = [n](const ForceDg (&v)[4], ForceDg& lo, ForceDg& hi) {
    lo = hi = v[0];
    for (int i = 1; i < n; ++i) lo = std::min(lo, v[i]), hi = std::max(hi, v[i]);
  };
  auto scaled = [](ForceDg a, ForceDg num, ForceDg den) {
    return forceDgOf(gramsOf(a) * (static_cast<float>(num) / static_cast<float>(den)));
  };
  FloatMix out{};
  ForceDg e[4];
  for (int i = 0; i < 4; ++i) e[i] = (i & 1) ? rp[i] + z : rp[i] - z;
  ForceDg lo, hi;
  bounds(e, lo, hi);
  const ForceDg range = max > min ? max - min : 0;
  if (hi - lo > range) {
    const ForceDg full = hi - lo;
    bounds(rp, lo, hi);
    const ForceDg rp_spread = hi - lo;
    if (rp_spread > range) {
      for (int i = 0; i < 4; ++i) e[i] = scaled(rp[i], range, rp_spread);
      out.limits = kMixRollPitchLimited | kMixYawLimited;
    } else {
      const ForceDg share = scaled(z, range - rp_spread, full - rp_spread);
      for (int i = 0; i < 4; ++i) e[i] = (i & 1) ? rp[i] + share : rp[i] - share;
      out.limits = kMixYawLimited;
    }
    bounds(e, lo, hi);
  }
  ForceDg c = collective;
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
  TorqueDg torque;  // decigrams per motor
  uint8_t limits;   // what the mixer must say it gave up (the collective's bit aside)
};

TEST(Mixer, TheIntegerSaturationPathMatchesTheFloatReferenceWithinThreeDecigrams) {
  constexpr uint8_t kRpYaw = kMixRollPitchLimited | kMixYawLimited;
  const SaturatedCase cases[] = {
      // roll and pitch alone too wide: scaled, yaw dropped
      {Layout::kX, 300, 20, 800, {forceDgOf(700), forceDgOf(350), forceDgOf(40)}, kRpYaw},
      {Layout::kX, 300, 20, 800, {forceDgOf(-700), forceDgOf(350), forceDgOf(-40)}, kRpYaw},
      {Layout::kX, 500, 0, 1000, {forceDgOf(3000), forceDgOf(-2900), forceDgOf(900)}, kRpYaw},
      {Layout::kX, 300, 20, 800, {forceDgOf(401), 0, 0}, kRpYaw},  // just over, on one axis
      {Layout::kPlus, 300, 20, 800, {forceDgOf(500), forceDgOf(-450), 7}, kRpYaw},
      {Layout::kPlus, 300, 20, 600, {forceDgOf(-1200), forceDgOf(10), forceDgOf(-5)}, kRpYaw},
      {Layout::kSeesaw, 300, 20, 800, {forceDgOf(900), forceDgOf(100), forceDgOf(100)}, kRpYaw},
      {Layout::kSeesaw, 400, 0, 1200, {forceDgOf(-1999.9f), 0, 0}, kRpYaw},
      // roll and pitch fit, yaw scaled to the rest
      {Layout::kX, 300, 20, 800, {forceDgOf(150), forceDgOf(-100), forceDgOf(300)}, kMixYawLimited},
      {Layout::kX, 300, 20, 800, {forceDgOf(-150), forceDgOf(100), forceDgOf(-300)}, kMixYawLimited},
      {Layout::kX, 700, 20, 800, {forceDgOf(30), forceDgOf(30), forceDgOf(500)}, kMixYawLimited},
      {Layout::kPlus, 300, 20, 600, {forceDgOf(90), 0, forceDgOf(250)}, kMixYawLimited},
      {Layout::kPlus, 100, 20, 600, {0, forceDgOf(-120), forceDgOf(-2000)}, kMixYawLimited},
      {Layout::kPlus, 300, 0, 1000, {forceDgOf(499), forceDgOf(499), forceDgOf(3)}, kMixYawLimited},
      {Layout::kX, 2000, 0, 4000, {forceDgOf(900), forceDgOf(800), forceDgOf(9000)}, kMixYawLimited},  // > 2^15
  };
  for (const SaturatedCase& c : cases) {
    SCOPED_TRACE(testing::Message() << "layout " << static_cast<int>(c.layout) << " torque " << c.torque.x
                                    << " " << c.torque.y << " " << c.torque.z);
    Mixer mixer;
    mixer.configure({c.layout, 0.225f, 0.015f});
    Forces f;
    const ForceDg min = forceDgOf(c.min_g), max = forceDgOf(c.max_g);
    const uint8_t limits = mixer.mixDg(forceDgOf(c.collective_g), c.torque, min, max, f);
    const FloatMix ref = floatReferenceMix(c.layout, forceDgOf(c.collective_g), c.torque, min, max);
    EXPECT_EQ(limits & kRpYaw, c.limits);
    EXPECT_EQ(limits & kRpYaw, ref.limits & kRpYaw);
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(f.dg[i], ref.force[i], kSaturatedToleranceDg) << "motor " << i;
      if (mixer.flies(static_cast<uint8_t>(i))) {
        EXPECT_GE(f.dg[i], min) << "motor " << i;
        EXPECT_LE(f.dg[i], max) << "motor " << i;
      } else {
        EXPECT_EQ(f.dg[i], 0);
      }
    }
  }
}

// The same over random torques up to 2 kg a motor on each axis (most of them saturate) on each
// layout: never outside [min, max], within the tolerance of the float reference, the same
// roll/pitch and yaw limits.
TEST(Mixer, RandomSaturatedTorquesStayInRangeAndNearTheFloatReference) {
  std::mt19937 rng(19);
  std::uniform_int_distribution<ForceDg> torque(-forceDgOf(2000), forceDgOf(2000));
  std::uniform_int_distribution<ForceDg> collective(forceDgOf(0), forceDgOf(1000));
  ForceDg worst = 0;
  for (Layout layout : {Layout::kPlus, Layout::kX, Layout::kSeesaw}) {
    Mixer mixer;
    mixer.configure({layout, 0.225f, 0.015f});
    for (int k = 0; k < 20000; ++k) {
      const TorqueDg t = {torque(rng), torque(rng), torque(rng)};
      const ForceDg min = forceDgOf(20), max = forceDgOf(800), c = collective(rng);
      Forces f;
      const uint8_t limits = mixer.mixDg(c, t, min, max, f);
      const FloatMix ref = floatReferenceMix(layout, c, t, min, max);
      ASSERT_EQ(limits & (kMixRollPitchLimited | kMixYawLimited),
                ref.limits & (kMixRollPitchLimited | kMixYawLimited))
          << k;
      for (int i = 0; i < 4; ++i) {
        worst = std::max(worst, std::abs(f.dg[i] - ref.force[i]));
        ASSERT_NEAR(f.dg[i], ref.force[i], kSaturatedToleranceDg) << k << " motor " << i;
        if (mixer.flies(static_cast<uint8_t>(i))) {
          ASSERT_GE(f.dg[i], min) << k;
          ASSERT_LE(f.dg[i], max) << k;
        }
      }
    }
  }
  RecordProperty("worst_dg", worst);
}

TEST(Mixer, TheCollectiveGivesWayToTheTorqueAtTheBottomAndTheTop) {
  Mixer mixer;
  mixer.configure({Layout::kX, 0.225f, 0.015f});
  for (float collective : {10.0f, 790.0f}) {
    Forces f;
    const uint8_t limits = mixer.mix(forceDgOf(collective), {0.2f, 0.0f, 0.0f}, forceDgOf(20), forceDgOf(800), f);
    EXPECT_EQ(limits, kMixCollectiveLimited) << collective;
    const Made made = torqueOf(Layout::kX, f, 0.225, 0.015);
    EXPECT_NEAR(made.x_nm, 0.2, 3e-4) << collective;
    for (ForceDg v : f.dg) {
      EXPECT_GE(v, forceDgOf(20));
      EXPECT_LE(v, forceDgOf(800));
    }
  }
}

}  // namespace
