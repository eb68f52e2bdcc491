// read_run (thesis "Read and Run") against the fake HAL: start-up report, arming, the
// Force-PWM path per frame (option 2.1 and sag offsets), commands. The failsafe, lift-off, bad
// input, rate and stream: test_read_run_failsafe.cpp.
//
// Seam: the test links read_run_app + fw_common + core + the fake HAL. Calibration records are
// built from a simple plant with tc::CurveBuilder and written into the fake EEPROM with
// tc::writeRecord<hal::Eeprom>, exactly as gather_store would store them (read_run_fixture.hpp).
// Model v2 slots: test_read_run_v2.cpp.
#include <gtest/gtest.h>


#include "read_run_fixture.hpp"

namespace {

using namespace rr_test;
namespace fake = hal::fake;

// ---------------------------------------------------------------------------------------------
// Start-up

TEST_F(ReadRun, StartUpReportsEveryCalibratedSlotWithItsVoltagesAndMaxForce) {
  // given: two good motors (one without a second curve), one corrupt, one erased
  storeMotor(0, {13.5, true, 0});
  storeMotor(1, {13.5, false, 0});
  storeMotor(2, {13.5, true, 0});
  fake::eeprom()[tc::slotAddress(2) + 100] ^= 0x01;  // one flipped bit in the first curve

  // when
  boot();

  // then
  const std::string out = fake::output();
  EXPECT_EQ(calibrated_, 2);
  const std::string v1 = volts(mvFromCounts(kCountsV1));
  const std::string v2 = volts(mvFromCounts(kCountsV2));
  EXPECT_TRUE(contains(out, "motor 0: ok, V1 " + v1 + " V, V2 " + v2 + " V, max 500 g")) << out;
  EXPECT_TRUE(contains(out, "motor 1: ok, V1 " + v1 + " V, V2 none (single curve")) << out;
  EXPECT_TRUE(contains(out, "motor 2: not calibrated: corrupt (CRC mismatch) - refusing to arm; "
                            "recalibrate it with gather_store"))
      << out;
  EXPECT_TRUE(contains(out, "motor 3: not calibrated: erased")) << out;
  EXPECT_TRUE(contains(out, "calibrated motors: 2 of 4")) << out;
  EXPECT_EQ(app_->motor(2).record, tc::DecodeStatus::kBadCrc);
  EXPECT_EQ(app_->motor(3).record, tc::DecodeStatus::kErased);
}

TEST_F(ReadRun, StartUpReadsEepromButNeverWritesIt) {
  // given
  storeFourMotors();
  fake::resetEepromWrites();

  // when
  boot();
  command("f 300");

  // then
  EXPECT_EQ(fake::eepromWrites(), 0u);
}

TEST_F(ReadRun, StartUpWithNothingCalibratedWarnsAndRefusesEveryForce) {
  // given: an erased EEPROM
  boot();
  EXPECT_TRUE(contains(fake::output(), "warning: no motor is calibrated")) << fake::output();

  // when
  const std::string out = command("f 100");

  // then
  EXPECT_TRUE(contains(out, "error: no motor is calibrated; calibrate them with gather_store"))
      << out;
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), 1000) << "motor " << int(m);
}

struct BadSlotCase {
  const char* name;
  void (*damage)(uint8_t* slot_bytes);
  const char* reason;
};

const BadSlotCase kBadSlots[] = {
    {"flipped curve byte", [](uint8_t* b) { b[300] ^= 0x40; }, "corrupt (CRC mismatch)"},
    {"flipped CRC byte", [](uint8_t* b) { b[tc::kRecordCrcOffset] ^= 0x01; }, "corrupt (CRC mismatch)"},
    {"unknown layout version", [](uint8_t* b) { b[0] = 7; }, "unknown layout version"},
    {"erased", [](uint8_t* b) { b[0] = 0xFF; }, "erased (never calibrated)"},
};

TEST_F(ReadRun, MissingOrCorruptSlotIsNeverArmedAndEveryCommandToItIsRefused) {
  for (const BadSlotCase& bad : kBadSlots) {
    SCOPED_TRACE(bad.name);
    // given: four good motors, then slot 2 damaged
    fake::reset();
    fake::setTimeLimitMs(120000);
    fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
    storeFourMotors();
    bad.damage(fake::eeprom() + tc::slotAddress(2));
    boot();
    EXPECT_TRUE(contains(fake::output(), std::string("motor 2: not calibrated: ") + bad.reason))
        << fake::output();

    // when: motor 2 alone, then all motors
    const std::string one = command("f 2 300");
    const std::string all = command("f 300");
    const std::string lift = command("liftoff 200");

    // then: motor 2 stays at 1000 us, the others run, each refusal is one clear line
    EXPECT_TRUE(contains(one, "error: motor 2 is not calibrated: " + std::string(bad.reason) +
                                  "; it stays at 1000 us - recalibrate it with gather_store"))
        << one;
    EXPECT_TRUE(contains(all, "warning: motor 2 not calibrated")) << all;
    EXPECT_TRUE(contains(lift, "error: liftoff needs all four motors calibrated; motor 2 is not "
                               "calibrated"))
        << lift;
    EXPECT_EQ(pulse(2), 1000);
    EXPECT_EQ(app_->motor(2).force_dg, 0);
    EXPECT_GT(pulse(0), 1400);
    EXPECT_GT(pulse(3), 1400);
    EXPECT_EQ(app_->mode(), rr::Mode::kReady);  // liftoff did not start
  }
}

// ---------------------------------------------------------------------------------------------
// Arming

TEST_F(ReadRun, ArmingHoldsEveryEscAt1000UsForTwoSecondsAndIgnoresEarlyInput) {
  // given: four calibrated motors, and a command typed while arming
  storeFourMotors();
  fake::feedInputAt(500, "f 300\n");
  uint16_t max_pulse_us = 0;
  uint16_t min_pulse_us = 0xFFFF;
  uint32_t armed_at_ms = 0;
  fake::setTickHook([&](uint32_t now_ms) {
    if (armed_at_ms == 0 && contains(fake::output(), "armed\r\n")) armed_at_ms = now_ms;
    if (armed_at_ms != 0) return;
    for (uint8_t m = 0; m < rr::kMotors; ++m) {
      max_pulse_us = std::max(max_pulse_us, fake::pulseUs(m));
      min_pulse_us = std::min(min_pulse_us, fake::pulseUs(m));
    }
  });

  // when
  boot();
  const uint32_t arm_end_ms = fake::nowMs();
  runFor(200, true);

  // then
  EXPECT_GE(arm_end_ms, 2000u);
  EXPECT_LE(arm_end_ms, 2002u);
  EXPECT_GE(armed_at_ms, 2000u);
  EXPECT_EQ(max_pulse_us, 1000);
  EXPECT_EQ(min_pulse_us, 1000);
  EXPECT_TRUE(contains(fake::output(), "arming...")) << fake::output();
  EXPECT_TRUE(contains(fake::output(), "input received while arming was ignored"));
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), 1000) << "motor " << int(m);
  EXPECT_EQ(fake::frameRateHz(), 50);
}

// ---------------------------------------------------------------------------------------------
// Force commands

TEST_F(ReadRun, ForceForAllMotorsGivesEachMotorThePwmOfItsOwnCurve) {
  // given: four different motors, battery at the first curve's voltage
  storeFourMotors();
  const double k[rr::kMotors] = {13.5, 12.0, 15.0, 14.0};
  boot();

  // when
  command("f 300");

  // then: each pulse is the motor's own curve value and its plant makes ~300 g with it
  const uint16_t v1_mv = mvFromCounts(kCountsV1);
  for (uint8_t m = 0; m < rr::kMotors; ++m) {
    SCOPED_TRACE(m);
    auto cal = storedCalibration(m);
    EXPECT_EQ(pulse(m), cal->first.pwmForGrams(300));
    EXPECT_NEAR(plantForceG(k[m], pulse(m), v1_mv), 300.0, 6.0);
    EXPECT_EQ(app_->motor(m).force_dg, 3000);
  }
  EXPECT_NE(pulse(1), pulse(2));  // different motors, different pulses, same force
}

TEST_F(ReadRun, ForceForOneMotorLeavesTheOthersStopped) {
  // given
  storeFourMotors();
  boot();

  // when
  const std::string out = command("f 1 250");

  // then
  EXPECT_FALSE(contains(out, "error")) << out;
  EXPECT_EQ(pulse(1), storedCalibration(1)->first.pwmForGrams(250));
  EXPECT_EQ(pulse(0), 1000);
  EXPECT_EQ(pulse(2), 1000);
  EXPECT_EQ(pulse(3), 1000);
}

TEST_F(ReadRun, EepromCommandsAreRefusedWhileAMotorRunsAndAnsweredOnceStopped) {
  // given: a motor running
  storeFourMotors();
  boot();
  command("f 1 250");
  ASSERT_GT(pulse(1), 1000);
  // when / then: refused, the motor keeps its force (no output burst while it flies)
  for (const char* line : {"eeprom crc", "eeprom dump"}) {
    const std::string out = command(line);
    EXPECT_TRUE(contains(out, "error: eeprom: motors are running; send stop first")) << out;
    EXPECT_FALSE(contains(out, "eeprom crc slot0")) << out;
    EXPECT_FALSE(contains(out, ":10000000")) << out;
    EXPECT_EQ(pulse(1), storedCalibration(1)->first.pwmForGrams(250));
  }
  // stopped: answered
  command("stop");
  EXPECT_TRUE(contains(command("eeprom crc"), "eeprom crc slot0 ")) ;
  const std::string dump = command("eeprom dump");
  EXPECT_TRUE(contains(dump, ":10000000")) << dump.substr(0, 200);
  EXPECT_TRUE(contains(dump, ":00000001FF\r\nrr> ")) << dump.substr(dump.size() - 100);
}

TEST_F(ReadRun, StopSendsEveryEscTo1000UsAtOnce) {
  // given
  storeFourMotors();
  boot();
  command("f 300");
  ASSERT_GT(pulse(0), 1400);

  // when: stop, observed before the next frame
  fake::feedInput("stop\n");
  app_->runOnce();

  // then
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), 1000) << "motor " << int(m);
  EXPECT_FALSE(app_->isRunning());
}

TEST_F(ReadRun, StatusShowsForcePwmFlagsInWordsAndBothBatteryVoltages) {
  // given: a weak motor 2 (saturates at 300 g) and a single-curve motor 3
  storeMotor(0, {13.5, true, 0});
  storeMotor(1, {13.5, true, 0});
  storeMotor(2, {2.0, true, 0});
  storeMotor(3, {13.5, false, 0});
  boot();
  command("f 300");

  // when
  const std::string out = command("status");

  // then
  const std::string v1 = volts(mvFromCounts(kCountsV1));
  const std::string pwm0 = std::to_string(pulse(0));
  EXPECT_TRUE(contains(out, "motor 0: 300.0 g, " + pwm0 + " us, battery " + v1 +
                                " V compensated, flags: none"))
      << out;
  EXPECT_TRUE(contains(out, "motor 2: 300.0 g, " + std::to_string(pulse(2)) + " us")) << out;
  EXPECT_TRUE(contains(out, "flags: saturated")) << out;
  EXPECT_TRUE(contains(out, "flags: single curve")) << out;
  EXPECT_TRUE(contains(out, "battery " + v1 + " V raw (median of 101), frame rate 50 Hz, running"))
      << out;
  EXPECT_TRUE(contains(out, "rr> ")) << out;
}

// ---------------------------------------------------------------------------------------------
// Battery: option 2.1 and the sag offsets

struct VoltageCase {
  uint16_t counts;
  const char* what;
};

TEST_F(ReadRun, Option21InterpolatesBetweenTheTwoCurvesAsTheBatteryVoltageChanges) {
  // given
  storeFourMotors();
  boot();
  auto cal = storedCalibration(0);
  const uint16_t force_g = 300;
  const uint16_t c1 = cal->first.pwmForGrams(force_g);
  const uint16_t c2 = cal->second.pwmForGrams(force_g);
  ASSERT_GT(c1, c2 + 30) << "the plant needs less PWM at the higher voltage";
  command("f 300");

  const VoltageCase cases[] = {
      {kCountsV1, "at V1: the first curve"},
      {kCountsV2, "at V2: the second curve"},
      {780, "between: interpolated"},
      {700, "below V1: extrapolated"},
      {850, "above V2: extrapolated"},
  };
  uint16_t previous_pwm = 0;
  for (const VoltageCase& c : cases) {
    SCOPED_TRACE(c.what);
    // when: the battery reading changes and the median follows
    fake::setAdcCounts(hal::kAdcBattery, c.counts);
    runFor(1000, true);

    // then
    const uint16_t vbat_mv = mvFromCounts(c.counts);
    EXPECT_EQ(app_->batteryMv(), vbat_mv);
    EXPECT_NEAR(pulse(0), option21PwmUs(*cal, force_g, vbat_mv), 1.0);
    EXPECT_NE(pulse(0), previous_pwm);
    previous_pwm = pulse(0);
  }
  fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
  runFor(1000, true);
  EXPECT_EQ(pulse(0), c1);
  fake::setAdcCounts(hal::kAdcBattery, kCountsV2);
  runFor(1000, true);
  EXPECT_EQ(pulse(0), c2);
}

TEST_F(ReadRun, SagOffsetOfTheLastPwmIsAddedToTheBatteryReading) {
  // given: motors 0 and 1 identical except for motor 0's sag table (50 mV per 40 us bin)
  storeMotor(0, {13.5, true, 50});
  storeMotor(1, {13.5, true, 0});
  storeMotor(2, {13.5, true, 0});
  storeMotor(3, {13.5, true, 0});
  const uint16_t read_counts = kCountsV1 - 39;  // the monitor reads ~0.6 V low under load
  fake::setAdcCounts(hal::kAdcBattery, read_counts);
  boot();

  // when
  command("f 300");
  runFor(500, true);

  // then: motor 0 is driven as if the battery were read + offset of its PWM's bin
  auto cal = storedCalibration(0);
  const uint16_t read_mv = mvFromCounts(read_counts);
  const int16_t offset_mv = cal->sag.offsetFor(pulse(0));
  EXPECT_NEAR(offset_mv, 600, 10) << "pwm " << pulse(0) << " is near the centre of the last bin";
  EXPECT_EQ(app_->motor(0).vbat_mv, read_mv + offset_mv);
  EXPECT_EQ(app_->motor(1).vbat_mv, read_mv);
  EXPECT_NEAR(pulse(0), option21PwmUs(*cal, 300, read_mv + offset_mv), 1.0);
  EXPECT_NEAR(pulse(1), option21PwmUs(*cal, 300, read_mv), 1.0);
  EXPECT_LT(pulse(0) + 10, pulse(1)) << "without the offset the motor would get more PWM";
  // and the compensated voltage is what status shows for that motor
  const std::string out = command("status");
  EXPECT_TRUE(contains(out, "battery " + volts(read_mv + offset_mv) + " V compensated")) << out;
}

}  // namespace
