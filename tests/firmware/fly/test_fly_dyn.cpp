// fly's `dyn on|off` against the fake HAL: the force API shapes each motor's command in flight
// (equal dynamics, thrustcal/dyn_shaper.hpp), status says so, it is refused while armed, and a
// disarm stops every ESC at once whatever the filters hold.
#include <gtest/gtest.h>

#include <string>

#include "fly_fixture.hpp"

namespace {

using namespace fly_test;
namespace fake = hal::fake;

tc::MotorDynamics lawMs(uint16_t up_ms) {
  tc::MotorDynamics d;
  d.points = 1;
  d.lo_dg = d.hi_dg = 3000;
  d.up_lo_01ms = d.up_hi_01ms = d.down_lo_01ms = d.down_hi_01ms = static_cast<uint16_t>(up_ms * 10);
  return d;
}

class FlyDyn : public Fly {
 protected:
  void storeMotorsWithDynamics() {
    const uint16_t rest_mv = mvFromCounts(kCountsV1);
    const double k[4] = {13.5, 12.0, 15.0, 14.0};
    const uint16_t tau_ms[4] = {70, 80, 90, 100};
    for (uint8_t i = 0; i < 4; ++i) {
      tc::ModelV2 model = fitV2Model(k[i], rest_mv);
      model.dynamics = lawMs(tau_ms[i]);
      ASSERT_EQ(tc::writeModelV2<hal::Eeprom>(i, model).status, tc::WriteV2Status::kWritten);
    }
  }
};

TEST_F(FlyDyn, ShapesEachMotorsCommandInFlightAndStopsAtOnceOnDisarm) {
  // given
  storeMotorsWithDynamics();
  bootReady();
  ASSERT_EQ(calibrated_, 4);
  EXPECT_TRUE(contains(command("status"), "dyn off: every motor flies its force as commanded"));
  // when
  EXPECT_TRUE(contains(command("dyn on"), "dyn on: motors 0 1 2 3 follow the slowest motor's response"));
  EXPECT_TRUE(contains(command("status"), "dyn on: motors 0 1 2 3"));
  armAndSpool(1200);
  EXPECT_TRUE(contains(command("dyn off"), "error: armed; send disarm first"));
  command("sp 10 0");
  // then: on the roll step the slowest motor (the reference) flies its command as given, the
  // faster ones a command held back towards the reference
  runFor(30);
  const fw::Motor& fast = app_->motors().motor(0);
  const fw::Motor& slow = app_->motors().motor(3);
  EXPECT_NE(fast.shaped_dg, fast.force_dg);
  EXPECT_NEAR(slow.shaped_dg, slow.force_dg, 2);
  // when: disarm; then every ESC stops now
  command("disarm");
  EXPECT_TRUE(allStopped());
  EXPECT_TRUE(contains(command("dyn off"), "dyn off: every motor flies its force as commanded"));
}

}  // namespace
