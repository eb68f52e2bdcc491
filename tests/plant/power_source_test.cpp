// LiPo and bench supply.
#include <gtest/gtest.h>

#include "plant/plant.hpp"

namespace {

using namespace plant;

struct OcvCase {
  double soc;
  double cell_v;
};

TEST(LipoOcv, FollowsTheDesignTableAtEveryPointAndLinearlyBetween) {
  const OcvCase rows[] = {{1.00, 4.20}, {0.90, 4.11}, {0.80, 4.02}, {0.70, 3.95}, {0.60, 3.87},
                          {0.50, 3.84}, {0.40, 3.80}, {0.30, 3.77}, {0.20, 3.73}, {0.10, 3.69},
                          {0.05, 3.61}, {0.00, 3.27}, {0.95, 4.155}, {0.025, 3.44},
                          {1.50, 4.20}, {-0.2, 3.27}};
  for (const OcvCase& r : rows) {
    SCOPED_TRACE(r.soc);
    EXPECT_NEAR(lipoCellOcv_v(r.soc), r.cell_v, 1e-9);
  }
}

TEST(LipoOcv, SocForCellOcvInvertsTheTable) {
  for (double soc : {0.03, 0.15, 0.45, 0.77, 0.99}) {
    EXPECT_NEAR(socForCellOcv(lipoCellOcv_v(soc)), soc, 1e-9);
  }
  EXPECT_EQ(socForCellOcv(5.0), 1.0);
  EXPECT_EQ(socForCellOcv(2.0), 0.0);
}

TEST(Lipo, FullPackRestsAtTwelvePointSixVoltsAndSagsUnderLoad) {
  PowerSource pack(BatteryParams::lipo3s(1.0));
  EXPECT_NEAR(pack.restingVoltage_v(), 12.6, 1e-9);
  const double loaded = pack.solveBusVoltage(BusLoad{0.0, 10.0});
  const BatteryParams& p = pack.params();
  EXPECT_NEAR(loaded, 12.6 - 10.0 * (p.r_internal_ohm + p.wiring_r_ohm), 1e-9);
}

TEST(Lipo, DrainsByTheChargeDrawn) {
  // given a full 3000 mAh pack
  PowerSource pack(BatteryParams::lipo3s(1.0));
  // when 3 A flow for 30 minutes
  for (int i = 0; i < 1800; ++i) pack.step(1.0, 3.0);
  // then half the charge is gone and the resting voltage is near the 50 % OCV
  EXPECT_NEAR(pack.soc(), 0.5, 1e-6);
  EXPECT_NEAR(pack.drawnCharge_mah(), 1500.0, 1e-6);
  EXPECT_NEAR(pack.openCircuitVoltage_v(), 3 * 3.84, 1e-6);
  // polarization: resting right after the load is below the OCV, and recovers
  EXPECT_LT(pack.restingVoltage_v(), pack.openCircuitVoltage_v() - 0.02);
  for (int i = 0; i < 200; ++i) pack.step(1.0, 0.0);
  EXPECT_NEAR(pack.restingVoltage_v(), pack.openCircuitVoltage_v(), 0.001);
}

TEST(BenchSupply, HoldsItsVoltageBelowTheLimitAndDeliversTheLimitAbove) {
  PowerSource ps(BatteryParams::benchSupply(12.0, 6.32));
  // a light load: constant voltage minus lead drop
  const double v_light = ps.solveBusVoltage(BusLoad{0.0, 2.0});
  EXPECT_NEAR(v_light, 12.0 - 2.0 * ps.params().wiring_r_ohm, 1e-9);
  EXPECT_FALSE(ps.isCurrentLimited());
  // a 1 ohm load would draw 12 A: the voltage folds back to 6.32 V
  const BusLoad one_ohm{1.0, 0.0};
  const double v = ps.solveBusVoltage(one_ohm);
  EXPECT_TRUE(ps.isCurrentLimited());
  EXPECT_NEAR(one_ohm.currentAt_a(v), 6.32, 1e-9);
  // and it never drains
  ps.step(3600.0, 6.32);
  EXPECT_EQ(ps.restingVoltage_v(), 12.0);
}

}  // namespace
