// fly against the fake HAL: start-up (the IMU's settings, WHO_AM_I, the gyro at rest), arming
// and its refusals, the four modes' pulses on known records. Every disarm cause within 100 ms of
// simulated time, the watchdog's kicks, status and the stream: test_fly_disarm.cpp.
//
// Seam: the test links fly_app + fw_force + core + the fake HAL; the IMU is FakeImu on the fake
// TWI (fly_fixture.hpp), the records are built as gather_store builds them (records_fixture.hpp).
#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>

#include "fly_fixture.hpp"
#include "lab/autopilot.hpp"

namespace {

using namespace fly_test;

// ---------------------------------------------------------------------------------------------
// Start-up

TEST_F(Fly, StartUpSetsTheImuUpAsTheDatasheetSaysAndMeasuresTheGyroAtRest) {
  storeFourV2Motors();
  boot();
  const std::string out = fake::output();
  // the settings, in order, after WHO_AM_I and the device reset
  const std::vector<std::pair<uint8_t, uint8_t>> expected = {
      {0x6B, 0x80}, {0x6B, 0x03}, {0x19, 0x00}, {0x1A, 0x02}, {0x1B, 0x18}, {0x1C, 0x10}, {0x38, 0x01}};
  ASSERT_EQ(fake::twiWrites().size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(fake::twiWrites()[i].reg, expected[i].first) << i;
    EXPECT_EQ(fake::twiWrites()[i].value, expected[i].second) << i;
  }
  EXPECT_EQ(fake::twiSclHz(), 400000u);
  EXPECT_TRUE(contains(out, "imu: MPU-6050 at 0x68, WHO_AM_I 0x68")) << out;
  // the bias the fake IMU has, 37 -21 8 LSB at 16.4 LSB per deg/s
  EXPECT_TRUE(contains(out, "imu: gyro bias 2.26 -1.28 0.49 deg/s; roll 0.0 pitch 0.0 deg")) << out;
  EXPECT_EQ(out.find("imu: gyro bias"), out.rfind("imu: gyro bias")) << "said once\n" << out;
  EXPECT_FALSE(contains(out, "running again")) << out;
  EXPECT_TRUE(app_->imuReady());
  EXPECT_FALSE(app_->armed());
  EXPECT_TRUE(allStopped());
  EXPECT_EQ(fake::frameRateHz(), 400);
}

TEST_F(Fly, TheLoopRunsAt400FramesASecondOnTheEscFramesPhaseHook) {
  storeFourV2Motors();
  boot();
  const uint32_t frames = app_->frames();
  const uint32_t hooks = fake::phaseHookCalls();
  runFor(1000);
  EXPECT_EQ(app_->frames() - frames, 400u);
  EXPECT_EQ(fake::phaseHookCalls() - hooks, 400u);
  EXPECT_NEAR(static_cast<double>(app_->imu().readsOk()), static_cast<double>(app_->frames()) - 60, 20)
      << "a read every frame but the start-up's";
}

TEST_F(Fly, AWrongWhoAmIIsAFaultThatRefusesArmingAndIsTriedAgainEverySecond) {
  // given: another chip answers at 0x68
  imu_.attach(0x70);
  storeFourV2Motors();
  boot();
  EXPECT_TRUE(contains(fake::output(), "imu: error: WHO_AM_I is not 0x68 (not an MPU-6050?): read 0x70"))
      << fake::output();
  EXPECT_EQ(app_->imu().fault(), fly::ImuFault::kWrongId);
  runFor(2500);
  EXPECT_TRUE(contains(command("arm"), "error: arm refused: IMU fault: WHO_AM_I is not 0x68"));
  EXPECT_TRUE(allStopped());
  const uint16_t faults = app_->imu().faults();
  EXPECT_GE(faults, 3) << "tried again every second";
  EXPECT_TRUE(fake::twiWrites().empty()) << "never configured";
  // when the right chip answers (a loose module pushed back), it starts and calibrates
  fake::twiRegisters()[0x75] = 0x68;
  runFor(2500);
  EXPECT_TRUE(app_->imuReady());
  EXPECT_TRUE(contains(command("arm"), "armed:"));
}

TEST_F(Fly, NoImuOnTheBusSaysWhatToCheck) {
  fake::twiSetNack(true);
  storeFourV2Motors();
  boot();
  EXPECT_TRUE(contains(fake::output(), "imu: error: no answer at its address (wiring: SDA D20, SCL D21"))
      << fake::output();
  EXPECT_EQ(app_->imu().fault(), fly::ImuFault::kNoAnswer);
  fake::takeOutput();
  runFor(3000);
  EXPECT_GE(app_->imu().faults(), 3) << "tried again every second";
  EXPECT_FALSE(contains(fake::output(), "imu:")) << "the same fault again is not news\n" << fake::output();
  fake::twiSetNack(false);  // plugged in: at the next try (within 1 s) and its start-up (~0.13 s)
  runFor(1200);
  EXPECT_TRUE(contains(fake::output(), "imu: running again; measuring the gyro bias")) << fake::output();
}

TEST_F(Fly, AVehicleMovedDuringTheGyroCalibrationIsCalibratedOnceStill) {
  storeFourV2Motors();
  // given: rocking, 20 deg/s one way then the other every 100 ms (a steady turn would look like
  // bias: the calibration cannot tell them apart, docs/fly.md)
  bool rocking = true;
  fake::setTickHook([&](uint32_t now_ms) {
    imu_.rate_dps[0] = rocking ? ((now_ms / 100) % 2 ? 20 : -20) : 0;
    imu_.tick();
  });
  boot();
  EXPECT_TRUE(contains(fake::output(), "imu: gyro not calibrated yet (motion seen")) << fake::output();
  EXPECT_FALSE(app_->imuReady());
  EXPECT_TRUE(
      contains(command("arm"), "error: arm refused: the IMU is starting or its gyro is being calibrated"));
  rocking = false;
  runFor(1200);
  EXPECT_TRUE(app_->imuReady());
  EXPECT_TRUE(contains(fake::output(), "imu: gyro bias 2.26 -1.28 0.49 deg/s")) << fake::output();
}

TEST_F(Fly, LevelTrimsTheAccelerometersOffsetSoALevelVehicleReadsLevel) {
  storeFourV2Motors();
  // given an IMU whose zero-g offsets are 39.1 mg on x, -17.8 mg on y and 58.6 mg on z (within
  // its datasheet)
  imu_.accel_offset_lsb[0] = 160;
  imu_.accel_offset_lsb[1] = -73;
  imu_.accel_offset_lsb[2] = 240;
  bootReady();
  // then the level vehicle reads 2.2 deg nose up and 1.0 deg left side down
  EXPECT_NEAR(app_->attitude().pitch_rad * 180 / M_PI, -2.11, 0.05);
  EXPECT_NEAR(app_->attitude().roll_rad * 180 / M_PI, -0.96, 0.05);
  // when `level` runs while it stands level and still
  EXPECT_TRUE(contains(command("level"), "imu: measuring the gyro bias: keep the vehicle still"));
  runFor(1100);
  // then the trim is the offsets and the estimate reads level
  EXPECT_TRUE(contains(fake::output(), "level: accelerometer trim x 39.1 y -17.8 z 58.6 mg")) << fake::output();
  EXPECT_EQ(app_->estimator().levelTrimLsb(0), 160);
  EXPECT_EQ(app_->estimator().levelTrimLsb(1), -73);
  EXPECT_EQ(app_->estimator().levelTrimLsb(2), 240);
  EXPECT_NEAR(app_->attitude().pitch_rad * 180 / M_PI, 0.0, 0.05);
  EXPECT_NEAR(app_->attitude().roll_rad * 180 / M_PI, 0.0, 0.05);
  // and a real tilt reads as itself, through the filter's corrections (without the z trim, 10
  // deg would read 9.46)
  imu_.roll_deg = 10.0;
  runFor(3000);
  EXPECT_NEAR(app_->attitude().roll_rad * 180 / M_PI, 10.0, 0.1);
  // and a plain `calibrate` keeps the trim
  command("calibrate");
  runFor(1100);
  EXPECT_EQ(app_->estimator().levelTrimLsb(0), 160);
}

TEST_F(Fly, LevelIsRefusedWhenTheVehicleIsNotLevelOrArmed) {
  storeFourV2Motors();
  bootReady();
  // given a vehicle standing 8 deg nose down (139 mg on x)
  imu_.pitch_deg = 8.0;
  command("level");
  runFor(1100);
  // then no trim is taken, and the tilt is still seen
  EXPECT_TRUE(contains(fake::output(), "error: level refused: off level the accelerometer reads x -139.2 y 0.0 z -9.8 mg, over 100 mg"))
      << fake::output();
  EXPECT_FALSE(app_->levelTrimmed());
  EXPECT_EQ(app_->estimator().levelTrimLsb(0), 0);
  EXPECT_NEAR(app_->attitude().pitch_rad * 180 / M_PI, 8.0, 0.1);
  // and armed, `level` is refused outright
  imu_.pitch_deg = 0.0;
  runFor(3000);
  armAndSpool(1200);
  EXPECT_TRUE(contains(command("level"), "error:")) << fake::output();
  EXPECT_TRUE(app_->armed());
}

// ---------------------------------------------------------------------------------------------
// Arming

TEST_F(Fly, ArmingWaitsForTheEscsFirstTwoSecondsAtTheStopPulse) {
  storeFourV2Motors();
  boot();
  ASSERT_LT(fake::nowMs(), tc::kArmMs);
  EXPECT_TRUE(contains(command("arm"), "error: arm refused: the ESCs are still arming"));
  runFor(tc::kArmMs - fake::nowMs() + 10);
  EXPECT_TRUE(contains(command("arm"), "armed: mode force, layout x"));
}

TEST_F(Fly, ArmingIsRefusedWhenNotLevelOrMoving) {
  storeFourV2Motors();
  bootReady();
  imu_.rate_dps[0] = 8;  // tilting at 8 deg/s
  runFor(20);
  const std::string moving = command("arm");
  EXPECT_TRUE(contains(moving, "error: arm refused: moving: rates 8.0 0.0 0.0 deg/s (all below 5)"))
      << moving;
  runFor(1000);  // now at about 8.3 deg
  imu_.rate_dps[0] = 0;
  runFor(20);
  EXPECT_TRUE(contains(command("arm"), "error: arm refused: not level: roll 8.")) << fake::output();
  EXPECT_FALSE(app_->armed());
  EXPECT_TRUE(allStopped());
}

TEST_F(Fly, OnlyACompleteValidArmLineArms) {
  storeFourV2Motors();
  bootReady();
  // a line without its end: nothing
  fake::feedInput("arm");
  runFor(100);
  EXPECT_FALSE(app_->armed());
  fake::feedInput("\r\n");  // ends "arm": now it is complete
  runFor(20);
  EXPECT_TRUE(app_->armed());
  command("disarm");
  // a damaged line is rejected whole
  fake::feedInput("ar");
  fake::feedDamage();
  fake::feedInput("m\n");
  runFor(20);
  EXPECT_FALSE(app_->armed());
  EXPECT_TRUE(contains(fake::output(), "error: line damaged in transit")) << fake::output();
  // strict: a checksum or nothing
  command("strict on");
  EXPECT_TRUE(contains(command("arm"), "error: strict mode: \"arm\" needs a checksum"));
  EXPECT_FALSE(app_->armed());
  EXPECT_TRUE(contains(command("arm*2B"), "error: checksum *2B does not match"));
  EXPECT_FALSE(app_->armed());
  EXPECT_TRUE(contains(command("arm*7E"), "armed:"));  // 'a' ^ 'r' ^ 'm' = 0x7E
  EXPECT_TRUE(app_->armed());
}

TEST_F(Fly, AMotorWithoutARecordIsNeverFlownInForceModeGenericModeFliesItOnAnotherSlotsRecord) {
  storeV2Motor(0, 13.5, mvFromCounts(kCountsV1));
  storeV2Motor(1, 12.0, mvFromCounts(kCountsV1));
  storeV2Motor(2, 15.0, mvFromCounts(kCountsV1));  // slot 3 erased
  bootReady();
  const std::string refused = command("arm");
  EXPECT_TRUE(contains(refused, "error: arm refused: motor 3 is not calibrated: erased")) << refused;
  EXPECT_TRUE(contains(command("mode generic 3"), "error: slot 3 is not calibrated: erased"));
  EXPECT_TRUE(contains(command("mode generic 1"), "mode: generic (slot 1's record for every motor)"));
  EXPECT_TRUE(contains(command("arm"), "armed:"));
  // the seesaw flies motors 0 and 1 only: in force mode slot 3 does not matter
  command("disarm");
  command("mode force");
  command("layout seesaw");
  EXPECT_TRUE(contains(command("arm"), "armed:")) << fake::output();
}

TEST_F(Fly, PwmAndArduPilotModesNeedTheirSettingsBeforeArming) {
  storeFourV2Motors();
  bootReady();
  command("mode pwm");
  EXPECT_TRUE(
      contains(command("arm"), "error: arm refused: mode pwm needs its hover point: hover US MG_PER_US"));
  command("hover 1500 1440");
  EXPECT_TRUE(contains(command("arm"), "armed:"));
  command("disarm");
  command("mode ardupilot");
  EXPECT_TRUE(contains(command("arm"), "error: arm refused: mode ardupilot needs its parameters"));
  command("ap 6913 1581 9500 1315");
  EXPECT_TRUE(contains(command("arm"), "armed:"));
  EXPECT_TRUE(contains(command("mode force"), "error: armed; send disarm first"));
}

// ---------------------------------------------------------------------------------------------
// The modes' pulses, level and still (no torque: every motor gets the collective)

TEST_F(Fly, ForceModeGivesEachMotorThePulseItsOwnRecordGivesTheForce) {
  storeFourThesisMotors();
  bootReady();
  armAndSpool(1200);
  uint16_t flown[4];
  for (uint8_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(fly::gramsOf(app_->flight().force.dg[i]), 300.0f, 0.01f) << int(i);
    flown[i] = pulse(i);
  }
  EXPECT_NE(flown[0], flown[1]) << "four different motors, four different pulses";
  // the same force through the force API directly
  fw::ForceActuators reference;
  reference.loadSettings();
  reference.loadSlots(nullptr);
  for (uint8_t i = 0; i < 4; ++i) reference.setForceDg(i, 3000);
  for (int k = 0; k < 101; ++k) reference.frame();
  for (uint8_t i = 0; i < 4; ++i) EXPECT_EQ(flown[i], reference.motor(i).pwm_us) << int(i);
}

TEST_F(Fly, GenericModeGivesEveryMotorThePulseOfOneSlotsRecord) {
  storeFourV2Motors();
  bootReady();
  command("mode generic 2");
  armAndSpool(1200);
  for (uint8_t i = 1; i < 4; ++i) EXPECT_EQ(pulse(i), pulse(0)) << int(i);
  EXPECT_GT(pulse(0), 1100);
}

TEST_F(Fly, PwmModeFliesTheControllersOutputInMicrosecondsAroundTheHoverPulse) {
  storeFourV2Motors();
  bootReady();
  command("mode pwm");
  command("layout plus");
  command("hover 1500 1440");
  armAndSpool(0);  // the thrust does not apply in pwm mode
  for (uint8_t i = 0; i < 4; ++i) EXPECT_EQ(pulse(i), 1500) << int(i);
  // a 5 deg roll setpoint: motor 1 (left) up, motor 3 (right) down by kp * error / lever / slope
  command("sp 5 0");
  const double torque_nm = 0.800 * 5 * M_PI / 180;
  const double delta_us = torque_nm / (2 * 0.225) * 1000 / 9.80665 / 1.440;
  EXPECT_NEAR(pulse(1) - 1500, delta_us, 1.0);
  EXPECT_NEAR(1500 - pulse(3), delta_us, 1.0);
  EXPECT_EQ(pulse(0), 1500);
  EXPECT_EQ(pulse(2), 1500);
}

TEST_F(Fly, ArduPilotModeSendsWhatArduPilotSendsForTheForce) {
  storeFourV2Motors();
  bootReady();
  command("mode ardupilot");
  command("ap 6913 1581 9500 1315");
  command("apvolt 12600 9900");
  armAndSpool(1200);
  lab::autopilot::ArduPilotParams p;
  p.thst_expo = 0.6913;
  p.spin_min = 0.1581;
  p.spin_max = 0.95;
  p.bat_volt_max_v = 12.6;
  p.bat_volt_min_v = 9.9;
  const double vbat_v = app_->motors().batteryMv() / 1000.0;
  const int want = lab::autopilot::ardupilot::pwmForThrust(p, 300.0 / 1315.0, vbat_v);
  for (uint8_t i = 0; i < 4; ++i) EXPECT_NEAR(pulse(i), want, 1) << int(i);
}

TEST_F(Fly, TheSeesawFliesMotorsZeroAndOneAndHoldsTheOthersStopped) {
  storeFourV2Motors();
  bootReady();
  command("layout seesaw");
  armAndSpool(600);
  EXPECT_NEAR(fly::gramsOf(app_->flight().force.dg[0]), 300.0f, 0.01f);
  EXPECT_NEAR(fly::gramsOf(app_->flight().force.dg[1]), 300.0f, 0.01f);
  EXPECT_GT(pulse(0), 1100);
  EXPECT_GT(pulse(1), 1100);
  EXPECT_EQ(pulse(2), tc::kStopPwmUs);
  EXPECT_EQ(pulse(3), tc::kStopPwmUs);
}

TEST_F(Fly, TheCollectiveSpoolsUpOverOneSecondAfterArming) {
  storeFourV2Motors();
  bootReady();
  command("thrust 1200");
  command("arm");
  runFor(480);  // 20 ms of the command, then these: about half way
  const float half = fly::gramsOf(app_->flight().force.dg[0]);
  EXPECT_NEAR(half, 150.0f, 10.0f);
  runFor(600);
  EXPECT_NEAR(fly::gramsOf(app_->flight().force.dg[0]), 300.0f, 0.01f);
}

}  // namespace
