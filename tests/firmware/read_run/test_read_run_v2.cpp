// read_run with model v2 slots, against the fake HAL: the layout of each slot picks the model
// it flies (thesis option 2.1 for v1, model v2 for v2), the v2 bus voltage filter, saturation
// at low voltage with the headroom in status, and the two-copy v2 record (one copy corrupt:
// the other flies; both corrupt: the motor is never armed).
//
// Seam: as test_read_run.cpp. v2 records are fitted with tc::ModelV2Fitter from a sweep of the
// plant (thrust follows the effective motor voltage) and written with tc::writeModelV2 into
// hal::fake::eeprom(), as gather_store stores them.
#include <gtest/gtest.h>

#include <string>

#include "read_run_fixture.hpp"

namespace {

using namespace rr_test;
namespace fake = hal::fake;


// The filters (bus voltage, seen force) are first order with ~150 ms time constant: 2 s
// (13 time constants) brings them to the exact input, whatever the step.
constexpr uint32_t kSettleMs = 2000;

// Byte offsets inside one v2 copy (record_v2.hpp's layout table).
constexpr uint16_t kV2StartOffset = 6;  // ESC start threshold, covered by the CRC
constexpr uint16_t kV2CrcOffset = tc::kRecordV2CrcOffset;

void flipCopyByte(uint8_t slot, uint8_t copy, uint16_t offset) {
  fake::eeprom()[tc::copyAddressV2(slot, copy) + offset] ^= 0x10;
}

std::string lineStartingWith(const std::string& text, const std::string& start) {
  for (const std::string& line : lines(text)) {
    if (line.rfind(start, 0) == 0) return line;
  }
  return "";
}

// "1080.0": the start threshold as the start-up report prints it (1/16 us -> 0.1 us).
std::string startText(const tc::ModelV2& model) {
  const unsigned tenths = (static_cast<unsigned>(model.start_q4_us) * 10u + 8u) >> 4;
  return std::to_string(tenths / 10u) + "." + std::to_string(tenths % 10u);
}

// The plant's force at full throttle (2000 us) at a bus voltage: what headroom must show.
double plantMaxG(double k, uint16_t vbat_mv) { return plantForceG(k, 2000, vbat_mv); }

class ReadRunV2 : public ReadRun {
 protected:
  void storeFourV2Motors() {
    for (uint8_t m = 0; m < rr::kMotors; ++m) storeV2Motor(m, kPlantK[m], mvFromCounts(kCountsV1));
  }

  // Runs the loop until exactly `frames` more ESC frames have run (each samples the battery
  // kBatterySamplesPerFrame times, and nothing else converts).
  void runFrames(uint32_t frames) {
    const uint32_t target = fake::adcConversions() + frames * fw::BatteryInput::kSamplesPerFrame;
    while (fake::adcConversions() < target) {
      hal::Clock::sleepUntilInterrupt();
      app_->runOnce();
    }
  }

  uint16_t expectedV2Pwm(uint8_t slot, uint16_t force_g) const {
    return tc::forceToPwmV2(storedV2Model(slot), static_cast<uint16_t>(force_g * 10),
                            app_->busFilter())
        .pwm_us;
  }
};

// ---------------------------------------------------------------------------------------------
// Loading and flying v2

TEST_F(ReadRunV2, V2RecordIsFlownWithModelV2AtTheFilteredBusVoltage) {
  // given: four v2 motors fitted at the battery voltage of the test
  storeFourV2Motors();
  const uint16_t vbat_mv = mvFromCounts(kCountsV1);
  fake::resetEepromWrites();

  // when
  boot();
  command("f 300");
  runFor(kSettleMs, true);

  // then: every pulse is model v2's at the filtered voltage, and the plant makes 300 g with it
  EXPECT_EQ(calibrated_, 4);
  EXPECT_EQ(app_->busFilter().mv, vbat_mv);
  for (uint8_t m = 0; m < rr::kMotors; ++m) {
    SCOPED_TRACE(int(m));
    EXPECT_TRUE(app_->motor(m).fliesV2());
    EXPECT_EQ(app_->motor(m).layout, tc::SlotLayout::kModelV2);
    EXPECT_EQ(app_->sagFilter().seen_q4, app_->sagFilter().last_q4) << "steady: no sag step predicted";
    EXPECT_EQ(pulse(m), expectedV2Pwm(m, 300));
    EXPECT_NEAR(plantForceG(kPlantK[m], pulse(m), vbat_mv), 300.0, 300.0 * 0.02);
    EXPECT_EQ(app_->motor(m).flags, 0);
    EXPECT_EQ(app_->motor(m).vbat_mv, vbat_mv);
  }
  EXPECT_NE(pulse(0), pulse(3));  // different motors, different pulses, same force
  EXPECT_EQ(fake::eepromWrites(), 0u);
}

TEST_F(ReadRunV2, StartUpSaysEachV2MotorFliesModelV2WithItsStartAndMaxForce) {
  // given
  storeFourV2Motors();

  // when
  boot();

  // then
  const std::string out = fake::output();
  for (uint8_t m = 0; m < rr::kMotors; ++m) {
    SCOPED_TRACE(int(m));
    const tc::ModelV2 model = storedV2Model(m);
    const uint16_t max_g = tc::headroomDg(model, model.rest_mv) / 10;
    const std::string expected = "motor " + std::to_string(m) +
                                 ": ok, model v2 (effective voltage), start " + startText(model) +
                                 " us, max " + std::to_string(max_g) + " g at " +
                                 volts(mvFromCounts(kCountsV1)) + " V";
    EXPECT_EQ(lineStartingWith(out, "motor " + std::to_string(m) + ":"), expected) << out;
    // the fit found the plant's start threshold and its full-throttle force
    EXPECT_NEAR(model.start_q4_us / 16.0, 1080.0, 1.0);
    EXPECT_NEAR(max_g, plantMaxG(kPlantK[m], mvFromCounts(kCountsV1)), 0.01 * max_g + 1.0);
  }
  EXPECT_TRUE(contains(out, "calibrated motors: 4 of 4")) << out;
}

struct V2VoltageCase {
  uint16_t counts;
  const char* what;
};

TEST_F(ReadRunV2, V2HoldsTheForceAtVoltagesAwayFromItsCalibrationVoltage) {
  // given: motors fitted at 11.3 V, running at 300 g
  storeFourV2Motors();
  boot();
  command("f 300");
  const V2VoltageCase cases[] = {
      {650, "9.9 V, below the sweep"},  {700, "10.7 V"},
      {kCountsV1, "11.3 V, the sweep's voltage"},
      {800, "12.2 V"},                  {822, "12.6 V, full pack"},
  };
  for (const V2VoltageCase& c : cases) {
    SCOPED_TRACE(c.what);
    // when
    fake::setAdcCounts(hal::kAdcBattery, c.counts);
    runFor(kSettleMs, true);

    // then
    const uint16_t vbat_mv = mvFromCounts(c.counts);
    EXPECT_EQ(app_->busFilter().mv, vbat_mv);
    for (uint8_t m = 0; m < rr::kMotors; ++m) {
      SCOPED_TRACE(int(m));
      EXPECT_EQ(pulse(m), expectedV2Pwm(m, 300));
      EXPECT_NEAR(plantForceG(kPlantK[m], pulse(m), vbat_mv), 300.0, 300.0 * 0.02);
    }
  }
}

TEST_F(ReadRunV2, BusFilterRunsEveryFrameAndSettlesOnTheNewVoltage) {
  // given: running at 300 g at 11.3 V
  storeFourV2Motors();
  boot();
  command("f 300");
  runFor(kSettleMs, true);
  const uint16_t old_mv = app_->busFilter().mv;
  const uint16_t old_pwm = pulse(0);

  // when: the reading steps to 12.5 V; one frame, then a second
  fake::setAdcCounts(hal::kAdcBattery, 820);
  const uint16_t new_mv = mvFromCounts(820);
  runFrames(1);
  const uint16_t one_frame_mv = app_->busFilter().mv;
  const uint16_t one_frame_pwm = pulse(0);
  runFrames(1);
  const uint16_t two_frames_mv = app_->busFilter().mv;
  runFor(kSettleMs, true);

  // then: 1/8 of the step per frame (50 Hz), the PWM follows, and the filter settles exactly
  EXPECT_NEAR(one_frame_mv, old_mv + (new_mv - old_mv) / 8.0, 1.0);
  EXPECT_NEAR(two_frames_mv, old_mv + (new_mv - old_mv) * (1.0 - 49.0 / 64.0), 1.0);
  EXPECT_LT(one_frame_pwm, old_pwm);
  EXPECT_GT(one_frame_pwm, pulse(0));
  EXPECT_EQ(app_->busFilter().mv, new_mv);
  EXPECT_EQ(pulse(0), expectedV2Pwm(0, 300));
}

TEST_F(ReadRunV2, CommandStepPredictsTheBenchSagOfAllMotorsUntilTheFilteredVoltageShowsIt) {
  // given: motors whose bench sweep saw the monitor drop 60 mV per 100 g, at rest
  for (uint8_t m = 0; m < rr::kMotors; ++m)
    storeV2Motor(m, kPlantK[m], mvFromCounts(kCountsV1), 60.0);
  boot();
  const tc::ModelV2 model = storedV2Model(0);
  ASSERT_GT(model.sag_10mv[model.knots / 2], 0) << "the model holds the bench sag";

  // when: 300 g from rest on all four, two frames, then until the filters settle
  fake::feedInput("f 300\n");
  runFrames(1);
  const uint16_t first_pwm = pulse(0);
  runFrames(1);
  const uint16_t second_pwm = pulse(0);
  runFor(kSettleMs, true);

  // then: the step's frame flies the plain model at the reading (the prediction is one frame
  // late); the next expects the drop of all four motors' 300 g on the one pack (~4 x 180 mV);
  // once the filters settle, the plain model at the reading flies again
  EXPECT_EQ(first_pwm, tc::forceToPwmV2(model, 3000, app_->busFilter()).pwm_us);
  const uint16_t steady_pwm = expectedV2Pwm(0, 300);
  EXPECT_EQ(first_pwm, steady_pwm);
  EXPECT_EQ(pulse(0), steady_pwm);
  EXPECT_EQ(app_->sagFilter().seen_q4, app_->sagFilter().last_q4);
  const double predicted_us = (steady_pwm - model.start_q4_us / 16.0) * 4 * 180.0 /
                              (mvFromCounts(kCountsV1) - 4 * 180.0);
  EXPECT_NEAR(second_pwm - steady_pwm, predicted_us, 3.0);
}

struct RateCase {
  uint16_t hz;
  uint16_t divisor;  // filter constant 1/divisor per frame: ~150 ms at every rate
};

TEST_F(ReadRunV2, BusFilterKeepsItsTimeConstantAtEveryFrameRate) {
  const RateCase cases[] = {{400, 64}, {200, 32}, {100, 16}, {50, 8}};
  // given
  storeFourV2Motors();
  boot();
  for (const RateCase& c : cases) {
    SCOPED_TRACE(c.hz);
    // when
    command("rate " + std::to_string(c.hz));
    command("f 300");
    const std::string status = command("status");
    command("stop");

    // then
    EXPECT_EQ(1u << app_->busFilter().shift, c.divisor);
    EXPECT_TRUE(contains(status, "(v2 motors: 1/" + std::to_string(c.divisor) + " per frame)"))
        << status;
    EXPECT_EQ(app_->busFilter().mv, mvFromCounts(kCountsV1)) << "re-seeded at its value";
  }
}

TEST_F(ReadRunV2, InsaneBatteryReadingKeepsTheLastGoodVoltageAndIsFlagged) {
  // given: running at 300 g
  storeFourV2Motors();
  boot();
  command("f 300");
  runFor(kSettleMs, true);
  const uint16_t good_pwm = pulse(0);

  // when: the monitor reads 1.5 V (wire off)
  fake::setAdcCounts(hal::kAdcBattery, 100);
  runFor(500, true);
  const std::string out = command("status");

  // then: the last good voltage flies on, and status says the reading is bad
  EXPECT_EQ(app_->busFilter().mv, mvFromCounts(kCountsV1));
  EXPECT_EQ(pulse(0), good_pwm);
  EXPECT_NE(app_->motor(0).flags & tc::kVoltageInvalid, 0);
  EXPECT_TRUE(contains(lineStartingWith(out, "motor 0:"), "flags: battery voltage invalid")) << out;

  // and a good reading clears the flag
  fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
  runFor(200, true);
  EXPECT_EQ(app_->motor(0).flags, 0);
}

// ---------------------------------------------------------------------------------------------
// A mix of layouts

TEST_F(ReadRunV2, MixOfV1AndV2SlotsFliesEachWithItsOwnModel) {
  // given: slots 0 and 2 thesis records, slots 1 and 3 v2 records
  storeMotor(0, {13.5, true, 0});
  storeV2Motor(1, kPlantK[1], mvFromCounts(kCountsV1));
  storeMotor(2, {15.0, true, 0});
  storeV2Motor(3, kPlantK[3], mvFromCounts(kCountsV1));

  // when
  boot();
  const std::string out = fake::output();
  command("f 300");
  runFor(kSettleMs, true);
  const std::string status = command("status");

  // then: the report names each motor's model
  const std::string v1 = volts(mvFromCounts(kCountsV1));
  const std::string v2 = volts(mvFromCounts(kCountsV2));
  EXPECT_TRUE(contains(out, "motor 0: ok, V1 " + v1 + " V, V2 " + v2 +
                                " V, max 500 g, model v1 (thesis option 2.1)"))
      << out;
  EXPECT_TRUE(contains(out, "motor 1: ok, model v2 (effective voltage), start ")) << out;
  EXPECT_TRUE(contains(out, "motor 2: ok, V1 ")) << out;
  EXPECT_TRUE(contains(out, "motor 3: ok, model v2 (effective voltage), start ")) << out;
  EXPECT_EQ(app_->motor(0).layout, tc::SlotLayout::kThesisV1);
  EXPECT_EQ(app_->motor(1).layout, tc::SlotLayout::kModelV2);

  // and each flies its own: option 2.1 at the first curve's voltage is the first curve
  EXPECT_EQ(pulse(0), storedCalibration(0)->first.pwmForGrams(300));
  EXPECT_EQ(pulse(2), storedCalibration(2)->first.pwmForGrams(300));
  EXPECT_EQ(pulse(1), expectedV2Pwm(1, 300));
  EXPECT_EQ(pulse(3), expectedV2Pwm(3, 300));
  EXPECT_NEAR(plantForceG(kPlantK[1], pulse(1), mvFromCounts(kCountsV1)), 300.0, 6.0);

  // and status shows the v1 battery compensated, the v2 battery filtered with the headroom
  const uint16_t headroom1_g = tc::headroomDg(storedV2Model(1), mvFromCounts(kCountsV1)) / 10;
  EXPECT_EQ(lineStartingWith(status, "motor 0:"),
            "motor 0: 300.0 g, " + std::to_string(pulse(0)) + " us, battery " + v1 +
                " V compensated, flags: none");
  EXPECT_EQ(lineStartingWith(status, "motor 1:"),
            "motor 1: 300.0 g, " + std::to_string(pulse(1)) + " us, battery " + v1 +
                " V filtered, headroom " + std::to_string(headroom1_g) + " g, flags: none");
  EXPECT_TRUE(contains(status, "bus filter " + v1 + " V (v2 motors: 1/8 per frame)")) << status;
}

// ---------------------------------------------------------------------------------------------
// Saturation and headroom

struct SaturationCase {
  uint16_t counts;
  uint16_t force_g;
  bool saturated;
  const char* what;
};

TEST_F(ReadRunV2, ForceBeyondWhatThePresentVoltageReachesSaturatesAndStatusShowsTheHeadroom) {
  const SaturationCase cases[] = {
      {kCountsV1, 450, false, "11.3 V reaches 450 g"},
      {560, 300, false, "8.6 V still reaches 300 g"},
      {560, 450, true, "8.6 V tops out near 370 g"},
      {600, 450, true, "9.2 V tops out near 430 g"},
      {650, 450, false, "9.9 V reaches 450 g again"},
  };
  // given: v2 motors fitted at 11.3 V
  storeFourV2Motors();
  boot();
  for (const SaturationCase& c : cases) {
    SCOPED_TRACE(c.what);
    // when
    fake::setAdcCounts(hal::kAdcBattery, c.counts);
    command("f 0 " + std::to_string(c.force_g));
    runFor(kSettleMs, true);
    const std::string status = lineStartingWith(command("status"), "motor 0:");

    // then: the headroom is the plant's force at full throttle at this voltage
    const uint16_t vbat_mv = mvFromCounts(c.counts);
    const uint16_t headroom_g = tc::headroomDg(storedV2Model(0), vbat_mv) / 10;
    EXPECT_NEAR(headroom_g, plantMaxG(kPlantK[0], vbat_mv), 0.015 * headroom_g + 1.0);
    EXPECT_TRUE(contains(status, "headroom " + std::to_string(headroom_g) + " g")) << status;
    EXPECT_EQ(headroom_g < c.force_g, c.saturated);
    if (c.saturated) {
      EXPECT_EQ(pulse(0), 2000);
      EXPECT_NE(app_->motor(0).flags & tc::kSaturated, 0);
      EXPECT_TRUE(contains(status, "flags: saturated")) << status;
    } else {
      EXPECT_LT(pulse(0), 2000);
      EXPECT_EQ(app_->motor(0).flags, 0);
      EXPECT_TRUE(contains(status, "flags: none")) << status;
      EXPECT_NEAR(plantForceG(kPlantK[0], pulse(0), vbat_mv), c.force_g, c.force_g * 0.02);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The two copies

struct BothCopiesBadCase {
  const char* name;
  uint8_t writes;           // v2 records written into slot 2 (1: copy A only, 2: A and B)
  uint16_t offset;          // byte flipped in every written copy
  const char* reasons;      // as the report words them
};

TEST_F(ReadRunV2, V2SlotWithBothCopiesCorruptIsNeverArmed) {
  const BothCopiesBadCase cases[] = {
      {"both copies' start threshold flipped", 2, kV2StartOffset,
       "copy A corrupt (CRC mismatch), copy B corrupt (CRC mismatch)"},
      {"both copies' CRC flipped", 2, kV2CrcOffset,
       "copy A corrupt (CRC mismatch), copy B corrupt (CRC mismatch)"},
      {"the only copy corrupt, the other never written", 1, kV2StartOffset,
       "copy A corrupt (CRC mismatch), copy B erased (never calibrated)"},
  };
  for (const BothCopiesBadCase& c : cases) {
    SCOPED_TRACE(c.name);
    // given: v2 motors; slot 2's copies damaged
    fake::reset();
    fake::setTimeLimitMs(120000);
    fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
    storeV2Motor(0, kPlantK[0], mvFromCounts(kCountsV1));
    storeV2Motor(1, kPlantK[1], mvFromCounts(kCountsV1));
    storeV2Motor(3, kPlantK[3], mvFromCounts(kCountsV1));
    for (uint8_t w = 0; w < c.writes; ++w) {
      storeV2Motor(2, kPlantK[2] + w, mvFromCounts(kCountsV1));  // a different model each time
    }
    for (uint8_t w = 0; w < c.writes; ++w) flipCopyByte(2, w, c.offset);

    // when
    boot();
    const std::string report = fake::output();
    const std::string one = command("f 2 300");
    const std::string all = command("f 300");

    // then
    const std::string reason = "not calibrated: v2 record, both copies bad (" +
                               std::string(c.reasons) + ")";
    EXPECT_EQ(lineStartingWith(report, "motor 2:"),
              "motor 2: " + reason + " - refusing to arm; recalibrate it with gather_store");
    EXPECT_EQ(calibrated_, 3);
    EXPECT_EQ(app_->motor(2).layout, tc::SlotLayout::kModelV2);
    EXPECT_FALSE(app_->motor(2).isArmable());
    EXPECT_TRUE(contains(one, "error: motor 2 is " + reason + "; it stays at 1000 us")) << one;
    EXPECT_TRUE(contains(all, "warning: motor 2 " + reason + "; held at 1000 us")) << all;
    EXPECT_EQ(pulse(2), 1000);
    EXPECT_EQ(app_->motor(2).force_dg, 0);
    EXPECT_EQ(pulse(0), expectedV2Pwm(0, 300));
  }
}

struct OneCopyBadCase {
  const char* name;
  uint8_t damaged;  // copy flipped
  uint8_t flown;    // copy that must fly
};

TEST_F(ReadRunV2, V2SlotWithOneCopyCorruptArmsAndFliesTheOtherCopy) {
  const OneCopyBadCase cases[] = {
      {"newest copy (B) corrupt: the older A flies", 1, 0},
      {"older copy (A) corrupt: the newest B flies", 0, 1},
  };
  for (const OneCopyBadCase& c : cases) {
    SCOPED_TRACE(c.name);
    // given: slot 1 written twice (copy A: plant k 5.5, then copy B: plant k 7.5), one damaged
    fake::reset();
    fake::setTimeLimitMs(120000);
    fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
    storeFourV2Motors();
    const double k_copy[2] = {kPlantK[1], 7.5};
    const tc::ModelV2 copy_a = storedV2Model(1);
    const tc::ModelV2 copy_b = storeV2Motor(1, k_copy[1], mvFromCounts(kCountsV1));
    ASSERT_NE(copy_b.drive_512usmv[10], copy_a.drive_512usmv[10]) << "two different models";
    flipCopyByte(1, c.damaged, kV2StartOffset);

    // when
    boot();
    const std::string report = fake::output();
    command("f 300");
    runFor(kSettleMs, true);

    // then: armed, flying the intact copy's model, and the report warns about the other
    EXPECT_EQ(calibrated_, 4);
    EXPECT_TRUE(app_->motor(1).fliesV2());
    EXPECT_EQ(app_->motor(1).v2_copy, c.flown);
    EXPECT_EQ(pulse(1), expectedV2Pwm(1, 300));
    EXPECT_NEAR(plantForceG(k_copy[c.flown], pulse(1), mvFromCounts(kCountsV1)), 300.0, 6.0);
    const std::string copy_name[2] = {"copy A", "copy B"};
    EXPECT_TRUE(contains(lineStartingWith(report, "motor 1:"),
                         "; warning: " + copy_name[c.damaged] + " corrupt (CRC mismatch), flying " +
                             copy_name[c.flown] + " - recalibrate to restore the spare copy"))
        << report;
  }
}

}  // namespace
