// Model v2 as read_run flies it (model_v2_runtime.hpp): the frame of four motors. Its plain
// path (no sag change predicted) is forceToPwmV2 at the filtered voltage to the bit, for every
// force; the prediction moves the pulse by the bench sag of all motors' commands, one frame
// late; the edges (stopped, saturated, clamped, bus not valid, insane sample) behave as
// forceToPwmV2 and BusVoltageFilter::update.
#include <gtest/gtest.h>

#include <cmath>

#include "synthetic_motor.hpp"
#include "thrustcal/model_v2_curve.hpp"
#include "thrustcal/model_v2_runtime.hpp"

using tc_test::SyntheticMotor;

namespace {

struct Fleet {
  tc::ModelV2 model[4];
  tc::ModelV2Run run[4];
  tc::V2Frame frame;
  tc::V2Lane* lane = frame.lane;

  explicit Fleet(double sag_r_ohm = 0.0) {
    SyntheticMotor m[4];
    m[1].exponent = 1.6;
    m[1].start_us = 1080;
    m[2].exponent = 2.0;
    m[2].start_us = 1115;
    m[3].full_at_9v9_g = 900;
    for (int i = 0; i < 4; ++i) {
      m[i].source_r_ohm = sag_r_ohm;
      model[i] = tc_test::fittedModel(m[i], 12.4);
      EXPECT_TRUE(run[i].load(model[i]));
      lane[i].setModel(&run[i]);
    }
    frame.count = 4;
  }
  // One frame at `mv` (the bus filter takes the reading).
  void fly(uint16_t mv, uint8_t extra = 0) { frame.fly(mv, extra); }
};

tc::BusVoltageFilter frameBusAt(uint16_t mv) {
  tc::BusVoltageFilter bus;
  bus.reset(mv);
  return bus;
}

TEST(V2Frame, SteadyFrameIsForceToPwmV2ForEveryForce) {
  // given: four models; the sag filter settled on the commands (no change predicted)
  Fleet fleet(0.08);
  for (const uint16_t mv : {3000, 6000, 9900, 11100, 12600, 17500, 26000}) {
    for (uint16_t f = 0; f <= fleet.run[3].max_force_dg + 200; f = static_cast<uint16_t>(f + 3)) {
      for (int i = 0; i < 4; ++i) fleet.lane[i].force_dg = static_cast<uint16_t>(f + 37 * i);
      fleet.frame.bus = frameBusAt(mv);
      fleet.frame.sag = tc::BusSagFilter();
      // when: the same commands twice at a steady reading (the second frame predicts nothing)
      fleet.fly(mv);
      fleet.frame.sag.seen_q4 = fleet.frame.sag.last_q4;
      fleet.frame.sag.rem = 0;
      fleet.fly(mv);
      // then
      for (int i = 0; i < 4; ++i) {
        const tc::ForcePwmResult want = tc::forceToPwmV2(fleet.model[i], fleet.lane[i].force_dg, fleet.frame.bus);
        ASSERT_EQ(fleet.lane[i].pwm_us, want.pwm_us) << "motor " << i << ", " << fleet.lane[i].force_dg << " dg, " << mv << " mV";
        ASSERT_EQ(fleet.lane[i].flags, want.flags) << "motor " << i << ", " << fleet.lane[i].force_dg << " dg, " << mv << " mV";
      }
    }
  }
}

// A motor at the edges of what model v2 holds, from a curve in doubles (as lab export makes
// one): force ~ drive^1.8 up to max_g, bench sag up to sag_mv at the top.
tc::ModelV2 edgeModel(double max_g, double start_us, double rest_mv, double sag_mv) {
  double drive[41], force[41], sag[41];
  const double top_usv = 900.0 * rest_mv / 1000.0;  // 900 us above start at the resting voltage
  for (int i = 0; i <= 40; ++i) {
    drive[i] = top_usv * (i + 1) / 41.0;
    force[i] = max_g * std::pow((i + 1) / 41.0, 1.8);
    sag[i] = sag_mv * (i + 1) / 41.0;
  }
  tc::ModelV2 m;
  EXPECT_TRUE(tc::modelV2FromCurve(m, start_us, drive, force, 41, rest_mv, sag)) << max_g << " g";
  return m;
}

TEST(V2Frame, RangeEdgesAreForceToPwmV2ToTheBit) {
  // given: a 5 g motor on 1S (one run of small steps: the Q16 knot position), a 5 kg motor on
  // 6S (16 fine + 16 coarse knots up to 50000 dg), a 15 g one (Q16) and a 2 kg one
  tc::ModelV2 model[4] = {edgeModel(5.0, 1040.0, 3700.0, 60.0), edgeModel(5000.0, 1120.0, 25000.0, 2400.0),
                          edgeModel(15.0, 1060.0, 4100.0, 90.0), edgeModel(2000.0, 1100.0, 16000.0, 900.0)};
  ASSERT_EQ(model[0].q16_inverse, 1);
  ASSERT_EQ(model[2].q16_inverse, 1);
  ASSERT_EQ(model[1].q16_inverse, 0);
  ASSERT_GT(model[1].maxForceDg(), 49000);
  ASSERT_LE(model[0].maxForceDg(), 50);
  tc::ModelV2Run run[4];
  tc::V2Frame frame;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(run[i].load(model[i]));
    frame.lane[i].setModel(&run[i]);
  }
  frame.count = 4;
  // the bus at the ends of 1S..6S and between; every force of the small motors, a dense grid of
  // the big ones, past the curves' ends
  for (const uint16_t mv : {3000, 3001, 3300, 4200, 8400, 12600, 16800, 25200, 25999, 26000}) {
    for (uint32_t f = 0; f <= 50100; f += 1) {
      const uint16_t fd[4] = {static_cast<uint16_t>(f % 60), static_cast<uint16_t>(f),
                              static_cast<uint16_t>(f % 170), static_cast<uint16_t>((f * 7) % 20300)};
      if (f > 200 && f % 7 != 0) continue;  // every force below 20 g, then every 7th decigram
      for (int i = 0; i < 4; ++i) frame.lane[i].force_dg = fd[i];
      frame.bus = frameBusAt(mv);
      frame.sag = tc::BusSagFilter();
      // when: the same commands twice at a steady reading (the second frame predicts nothing)
      frame.fly(mv);
      frame.sag.seen_q4 = frame.sag.last_q4;
      frame.sag.rem = 0;
      frame.fly(mv);
      // then
      for (int i = 0; i < 4; ++i) {
        const tc::ForcePwmResult want = tc::forceToPwmV2(model[i], fd[i], frame.bus);
        ASSERT_EQ(frame.lane[i].pwm_us, want.pwm_us) << "motor " << i << ", " << fd[i] << " dg, " << mv << " mV";
        ASSERT_EQ(frame.lane[i].flags, want.flags) << "motor " << i << ", " << fd[i] << " dg, " << mv << " mV";
      }
    }
  }
  // and: the bus never valid flies each model's resting voltage, as forceToPwmV2
  frame.bus = tc::BusVoltageFilter();
  for (int i = 0; i < 4; ++i) frame.lane[i].force_dg = static_cast<uint16_t>(model[i].maxForceDg() / 2);
  frame.fly(2999);  // below one cell: ignored
  for (int i = 0; i < 4; ++i) {
    const tc::ForcePwmResult want = tc::forceToPwmV2(model[i], frame.lane[i].force_dg, tc::BusVoltageFilter());
    EXPECT_EQ(frame.lane[i].pwm_us, want.pwm_us) << i;
    EXPECT_EQ(frame.lane[i].flags, want.flags) << i;
    EXPECT_TRUE(want.flags & tc::kVoltageInvalid);
  }
}

TEST(V2Frame, BusFilterAtTheRangeEndsIsBusVoltageFilterUpdate) {
  // given: readings jumping between 3.0 and 26.0 V, ramps across the range, just-outside ones
  Fleet fleet;
  tc::BusVoltageFilter alone;
  const uint16_t ends[] = {3000, 26000, 3000, 25999, 3001, 12600, 26000};
  for (int frame = 0; frame < 4000; ++frame) {
    uint16_t mv = ends[(frame / 40) % 7];
    if (frame >= 2000) mv = static_cast<uint16_t>(3000 + ((frame - 2000) * 23) % 23001);  // ramps
    if (frame % 301 == 5) mv = frame % 2 ? 2999 : 26001;  // just outside: ignored
    if (frame == 3000) fleet.frame.bus.shift = alone.shift = 6;
    for (int i = 0; i < 4; ++i) fleet.lane[i].force_dg = static_cast<uint16_t>((frame * 131 + i * 877) % 4000);
    // when
    fleet.fly(mv);
    alone.update(mv);
    // then
    ASSERT_EQ(fleet.frame.bus.mv, alone.mv) << frame;
    ASSERT_EQ(fleet.frame.bus.rem, alone.rem) << frame;
    ASSERT_EQ(fleet.frame.bus.recip_q27, alone.recip_q27) << frame;
    const int exact = static_cast<int>(tc::kRecipOne / alone.mv);  // Newton: within (1/128)^2
    ASSERT_LE(std::abs(int(alone.recip_q27) - exact), 1 + exact / 8192) << frame;
  }
  EXPECT_GE(alone.reseeds, 10);
  EXPECT_GE(alone.rejected, 10);
}

TEST(V2Frame, BusFilterStepIsBusVoltageFilterUpdate) {
  // given: a draining, noisy reading with a jump (re-seed) and insane samples in it
  Fleet fleet;
  tc::BusVoltageFilter& in_frame = fleet.frame.bus;
  tc::BusVoltageFilter alone;
  for (int frame = 0; frame < 3000; ++frame) {
    uint16_t mv = static_cast<uint16_t>(12600 - frame / 2 + (frame * 37) % 23);
    if (frame == 1000) mv = 9000;       // a jump: more than 1/128
    if (frame % 500 == 7) mv = 1500;    // wire off for a frame
    for (int i = 0; i < 4; ++i) fleet.lane[i].force_dg = static_cast<uint16_t>(1000 + (frame * 131 + i * 877) % 3501);
    // when
    fleet.fly(mv);
    alone.update(mv);
    // then
    ASSERT_EQ(in_frame.mv, alone.mv) << frame;
    ASSERT_EQ(in_frame.rem, alone.rem) << frame;
    ASSERT_EQ(in_frame.recip_q27, alone.recip_q27) << frame;
  }
  EXPECT_EQ(in_frame.reseeds, alone.reseeds);
  EXPECT_EQ(in_frame.rejected, alone.rejected);
  EXPECT_GE(in_frame.reseeds, 1);
  EXPECT_EQ(in_frame.rejected, 6);
}

TEST(V2Frame, CommandStepIsPredictedFromAllMotorsBenchSagOneFrameLate) {
  // given: four motors whose bench saw the monitor sag (0.08 ohm source), at rest, steady
  Fleet fleet(0.08);
  const uint16_t mv = 11800;
  fleet.frame.bus = frameBusAt(mv);
  const tc::BusVoltageFilter& bus = fleet.frame.bus;
  const tc::BusSagFilter& sag = fleet.frame.sag;
  for (int i = 0; i < 4; ++i) fleet.lane[i].force_dg = 0;
  fleet.fly(mv);

  // when: all four step to 350 g; the reading does not show it yet
  for (int i = 0; i < 4; ++i) fleet.lane[i].force_dg = 3500;
  fleet.fly(mv);
  uint16_t first[4], second[4];
  for (int i = 0; i < 4; ++i) first[i] = fleet.lane[i].pwm_us;
  fleet.fly(mv);
  for (int i = 0; i < 4; ++i) second[i] = fleet.lane[i].pwm_us;

  // then: the step's own frame flies the plain model; the next one expects the bus to drop by
  // the four motors' bench sag at 350 g, and gives each motor the PWM of that voltage
  double total_sag_mv = 0;
  for (int i = 0; i < 4; ++i) {
    const tc::ModelV2& m = fleet.model[i];
    // the knot below 350 g and the one above: the bench sag there, interpolated
    uint8_t k = 0;
    while (k + 1 < m.knots && m.knotForceDg(k) < 3500) ++k;
    const double f0 = k ? m.knotForceDg(static_cast<uint8_t>(k - 1)) : 0.0, f1 = m.knotForceDg(k);
    const double s0 = k ? m.sag_10mv[k - 1] : 0.0, s1 = m.sag_10mv[k];
    total_sag_mv += 10.0 * (s0 + (s1 - s0) * (3500 - f0) / (f1 - f0));
  }
  ASSERT_GT(total_sag_mv, 100.0) << "the bench sag is in the models";
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(first[i], tc::forceToPwmV2(fleet.model[i], 3500, bus).pwm_us);
    const double start_us = fleet.model[i].start_q4_us / 16.0;
    const double want = start_us + (first[i] - start_us) * mv / (mv - total_sag_mv);
    EXPECT_NEAR(second[i], want, 1.0 + 0.02 * (want - first[i]));
    EXPECT_GT(second[i], first[i]);
  }

  // and once the reading shows the sag (filter settled), the plain model at the reading flies
  const uint16_t sagged = static_cast<uint16_t>(std::lround(mv - total_sag_mv));
  for (int frame = 0; frame < 200; ++frame) fleet.fly(sagged);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(sag.seen_q4, sag.last_q4);
    EXPECT_EQ(fleet.lane[i].pwm_us, tc::forceToPwmV2(fleet.model[i], 3500, bus).pwm_us);
  }
}

TEST(V2Frame, EdgesBehaveAsForceToPwmV2) {
  Fleet fleet;
  struct Case {
    const char* what;
    uint16_t force_dg;
    uint16_t mv;  // 0: the bus never had a sane reading
    tc::ForcePwmLimits limits;
  };
  tc::ForcePwmLimits narrow;
  narrow.pwm_min_us = 1300;
  narrow.pwm_max_us = 1400;
  const Case cases[] = {
      {"stopped", 0, 11000, tc::ForcePwmLimits()},
      {"above the curve: saturated", 60000, 11000, tc::ForcePwmLimits()},
      {"not enough voltage: saturated at the maximum pulse", 9000, 6000, tc::ForcePwmLimits()},
      {"below the minimum pulse: clamped", 200, 11000, narrow},
      {"above the maximum pulse: saturated", 4000, 11000, narrow},
      {"bus never valid: the model's resting voltage", 3000, 0, tc::ForcePwmLimits()},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    fleet.frame.bus = c.mv ? frameBusAt(c.mv) : tc::BusVoltageFilter();
    fleet.frame.sag = tc::BusSagFilter();
    fleet.frame.pwm_min_us = c.limits.pwm_min_us;
    fleet.frame.pwm_max_us = c.limits.pwm_max_us;
    for (int i = 0; i < 4; ++i) fleet.lane[i].force_dg = c.force_dg;
    fleet.fly(c.mv ? c.mv : 1000);  // 1000 mV: insane, the filter stays invalid
    for (int i = 0; i < 4; ++i) {
      const tc::ForcePwmResult want = tc::forceToPwmV2(fleet.model[i], c.force_dg, fleet.frame.bus, c.limits);
      EXPECT_EQ(fleet.lane[i].pwm_us, want.pwm_us) << i;
      EXPECT_EQ(fleet.lane[i].flags, want.flags) << i;
    }
  }
}

TEST(V2Frame, ExtraFlagsReachEveryLaneAndZeroLanesIsNothing) {
  Fleet fleet;
  fleet.frame.bus = frameBusAt(11000);
  for (int i = 0; i < 4; ++i) fleet.lane[i].force_dg = 2500;
  fleet.fly(11000, tc::kVoltageInvalid);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(fleet.lane[i].flags, tc::kVoltageInvalid);
  const uint16_t before = fleet.lane[0].pwm_us;
  fleet.lane[0].force_dg = 4000;
  fleet.frame.count = 0;
  fleet.fly(11000);
  EXPECT_EQ(fleet.lane[0].pwm_us, before);
}

TEST(ModelV2Run, HeadroomIsThatOfTheModelItWasLoadedFrom) {
  Fleet fleet;
  for (int i = 0; i < 4; ++i) {
    for (uint16_t mv = 6000; mv <= 17500; mv = static_cast<uint16_t>(mv + 37)) {
      ASSERT_EQ(tc::headroomDg(fleet.run[i], mv), tc::headroomDg(fleet.model[i], mv)) << i << " " << mv;
    }
    EXPECT_EQ(fleet.run[i].startQ4Us(), fleet.model[i].start_q4_us);
    EXPECT_EQ(fleet.run[i].rest_mv, fleet.model[i].rest_mv);
  }
  tc::ModelV2Run none;
  EXPECT_FALSE(none.load(tc::ModelV2()));
  EXPECT_FALSE(none.isPresent());
}

}  // namespace
