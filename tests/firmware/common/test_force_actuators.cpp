// The force API's parts beyond what read_run's tests cover (firmware/common/force_actuators.hpp):
// a motor flying another slot's model (fly's generic mode), the heaviest force a model makes,
// and frame() split into the battery's readings and the output.
#include <gtest/gtest.h>

#include "force_actuators.hpp"
#include "hal/fake.hpp"
#include "records_fixture.hpp"

namespace {

using namespace records_test;
namespace fake = hal::fake;

class ForceApi : public ::testing::Test {
 protected:
  void SetUp() override {
    fake::reset();
    fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
    hal::Esc::init(400);
  }
  void load() {
    motors_.loadSettings();
    motors_.loadSlots(nullptr);
  }
  // Every motor at `force_g`, a few frames (the battery median and the v2 filter settle).
  void fly(uint16_t force_g) {
    for (uint8_t i = 0; i < 4; ++i) motors_.setForceDg(i, static_cast<uint16_t>(force_g * 10));
    for (int k = 0; k < 40; ++k) motors_.frame();
  }
  fw::ForceActuators motors_;
};

TEST_F(ForceApi, GenericFlightGivesEveryMotorThePulseOfTheSourceSlotsThesisRecord) {
  // given: four different motors, all flying slot 2's record
  storeMotor(0, {12.0, true, 0});
  storeMotor(1, {13.0, true, 0});
  storeMotor(2, {15.0, true, 0});
  storeMotor(3, {14.0, true, 0});
  load();
  fly(300);
  const uint16_t own_pulse_2 = motors_.motor(2).pwm_us;
  EXPECT_NE(motors_.motor(0).pwm_us, own_pulse_2) << "different motors, different pulses";
  motors_.stopAll();
  // when
  for (uint8_t i = 0; i < 4; ++i) ASSERT_TRUE(motors_.setModelSource(i, 2));
  fly(300);
  // then
  for (uint8_t i = 0; i < 4; ++i) {
    EXPECT_EQ(motors_.motor(i).pwm_us, own_pulse_2) << "motor " << int(i);
    EXPECT_EQ(motors_.motor(i).source, 2);
  }
}

TEST_F(ForceApi, GenericFlightOnAV2RecordGivesEveryMotorALaneOfThatModel) {
  // given
  const uint16_t rest_mv = mvFromCounts(kCountsV1);
  storeV2Motor(0, 12.0, rest_mv);
  storeV2Motor(1, 15.0, rest_mv);
  storeMotor(2, {13.0, true, 0});  // a thesis record: generic flight replaces it too
  load();
  EXPECT_EQ(motors_.v2Motors(), 2);
  // when
  for (uint8_t i = 0; i < 4; ++i) ASSERT_TRUE(motors_.setModelSource(i, 1));
  fly(250);
  // then: one lane per motor, all the same pulse (the bench-sag prediction sums four motors)
  EXPECT_EQ(motors_.v2Motors(), 4);
  for (uint8_t i = 1; i < 4; ++i) EXPECT_EQ(motors_.motor(i).pwm_us, motors_.motor(0).pwm_us) << int(i);
  EXPECT_GT(motors_.motor(0).pwm_us, 1100);
}

TEST_F(ForceApi, AnUncalibratedMotorFliesOnlyWhileItsSourceIsACalibratedSlot) {
  // given: slot 3 erased
  storeMotor(0, {13.5, true, 0});
  load();
  EXPECT_FALSE(motors_.isArmable(3));
  // when: motor 3 flies slot 0's record
  ASSERT_TRUE(motors_.setModelSource(3, 0));
  fly(200);
  // then
  EXPECT_TRUE(motors_.isArmable(3));
  EXPECT_FALSE(motors_.motor(3).isArmable()) << "its own slot is still erased";
  EXPECT_EQ(motors_.motor(3).pwm_us, motors_.motor(0).pwm_us);
  EXPECT_EQ(motors_.armableCount(), 1) << "calibrated slots, not motors";
  // and back to its own slot: held at the stop pulse, the force ignored
  motors_.stopAll();
  EXPECT_TRUE(motors_.setModelSource(3, 3)) << "its own slot, whatever it holds";
  EXPECT_FALSE(motors_.isArmable(3));
  fly(200);
  EXPECT_EQ(motors_.motor(3).pwm_us, tc::kStopPwmUs);
  EXPECT_EQ(motors_.motor(3).force_dg, 0);
}

TEST_F(ForceApi, ModelSourcesChangeOnlyWhileNothingRunsAndOnlyToCalibratedSlots) {
  storeMotor(0, {13.5, true, 0});
  storeMotor(1, {12.5, true, 0});
  load();
  EXPECT_FALSE(motors_.setModelSource(0, 2)) << "slot 2 is erased";
  EXPECT_FALSE(motors_.setModelSource(4, 0)) << "no motor 4";
  EXPECT_FALSE(motors_.setModelSource(0, 4)) << "no slot 4";
  motors_.setForceDg(0, 1000);
  EXPECT_FALSE(motors_.setModelSource(1, 0)) << "a motor runs";
  EXPECT_EQ(motors_.motor(1).source, 1);
  motors_.stopAll();
  EXPECT_TRUE(motors_.setModelSource(1, 0));
}

TEST_F(ForceApi, ReloadingTheSlotsGivesEveryMotorItsOwnModelAgain) {
  storeMotor(0, {13.5, true, 0});
  storeMotor(1, {12.5, true, 0});
  load();
  ASSERT_TRUE(motors_.setModelSource(1, 0));
  load();
  EXPECT_EQ(motors_.motor(1).source, 1);
}

TEST_F(ForceApi, MaxForceIsTheLighterCurvesHeaviestGramOrTheV2ModelsLastKnotOrZero) {
  // given: a thesis record (both curves reach 500 g, the curve's end), a v2 model, nothing
  storeMotor(0, {13.5, true, 0});
  storeMotor(1, {3.0, true, 0});  // a weak motor: its curves end below 500 g
  const tc::ModelV2 v2 = storeV2Motor(2, 13.5, mvFromCounts(kCountsV1));
  load();
  auto cal1 = storedCalibration(1);
  // then
  EXPECT_EQ(motors_.maxForceDg(0), 5000);
  EXPECT_EQ(motors_.maxForceDg(1), 10 * std::min(cal1->first.maxGrams(), cal1->second.maxGrams()));
  EXPECT_LT(motors_.maxForceDg(1), 5000);
  EXPECT_EQ(motors_.maxForceDg(2), v2.maxForceDg());
  EXPECT_EQ(motors_.maxForceDg(3), 0);
  ASSERT_TRUE(motors_.setModelSource(3, 2));
  EXPECT_EQ(motors_.maxForceDg(3), motors_.maxForceDg(2)) << "its source's model";
}

TEST_F(ForceApi, FrameIsTheBatterysReadingsThenTheOutputAndOutputAloneReadsNothing) {
  // given
  storeMotor(0, {13.5, true, 0});
  load();
  motors_.setForceDg(0, 3000);
  // when / then
  const uint32_t before = fake::adcConversions();
  motors_.output();
  EXPECT_EQ(fake::adcConversions(), before) << "output() flies on the last readings";
  motors_.sampleBattery();
  EXPECT_EQ(fake::adcConversions(), before + fw::BatteryInput::kSamplesPerFrame);
  const uint32_t writes = fake::escWriteAlls();
  motors_.output();
  EXPECT_EQ(fake::escWriteAlls(), writes + 1) << "the four pulses, once";
  const uint16_t split_pulse = motors_.motor(0).pwm_us;
  motors_.frame();
  EXPECT_EQ(motors_.motor(0).pwm_us, split_pulse) << "same battery, same pulse";
  EXPECT_EQ(fake::adcConversions(), before + 2 * fw::BatteryInput::kSamplesPerFrame);
}

}  // namespace
