// read_run and the records it must not fly (plausibility), the battery divider setting, and
// the wider ranges of model v2: 1S..6S packs and forces up to 5 kg.
#include <cstring>
#include <vector>

#include "read_run_fixture.hpp"
#include "thrustcal/board_settings.hpp"
#include "thrustcal/eeprom_store.hpp"
#include "thrustcal/model_v2_curve.hpp"

namespace rr_test {
namespace {

struct FakeStorage {
  static uint8_t readByte(uint16_t addr) { return fake::eeprom()[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) { fake::eeprom()[addr] = value; }
};

std::string lineStartingWith(const std::string& text, const std::string& prefix) {
  for (const auto& l : lines(text))
    if (l.rfind(prefix, 0) == 0) return l;
  return {};
}

// A v2 model for F = k * drive^2 at rest_mv, start 1050 us, reaching max_g at 1990 us.
tc::ModelV2 curveModel(double max_g, uint16_t rest_mv) {
  const double start = 1050.0;
  const double top = (1990.0 - start) * rest_mv / 1000.0;  // us*V
  std::vector<double> drive, force;
  for (int i = 1; i <= 200; ++i) {
    const double d = top * i / 200.0;
    drive.push_back(d);
    force.push_back(max_g * (d / top) * (d / top));
  }
  tc::ModelV2 m;
  EXPECT_TRUE(tc::modelV2FromCurve(m, start, drive.data(), force.data(), 200, rest_mv));
  return m;
}

void putV2(uint8_t slot, const tc::ModelV2& m) {  // serialized with a right CRC, copy A
  uint8_t image[tc::kRecordV2Bytes];
  tc::serializeModelV2(m, 1, image);
  std::memcpy(fake::eeprom() + tc::copyAddressV2(slot, 0), image, sizeof image);
}

uint16_t countsFor(uint16_t mv, uint16_t full_scale_mv) {
  return static_cast<uint16_t>((static_cast<uint32_t>(mv) * 1023u + full_scale_mv / 2) / full_scale_mv);
}

}  // namespace

TEST_F(ReadRun, RecordsThatCannotBeRightAreRefusedWithTheRuleTheyBreak) {
  // given: good motors 0 and 3; slot 1 a thesis record that puts 1 g at 2500 us, slot 2 a v2
  // model whose drive knots are all 0xFFFF (both with right CRCs: issue 8's examples)
  storeMotor(0, {13.5, true, 0});
  storeMotor(3, {14.0, true, 0});
  auto bad = makeCalibration({12.0, true, 0});
  bad->first.pwm_at_1g_us = 2500;
  tc::writeRecord<hal::Eeprom>(1, *bad);
  tc::ModelV2 flat = fitV2Model(13.5, mvFromCounts(kCountsV1));
  for (uint8_t k = 0; k < flat.knots; ++k) flat.drive_512usmv[k] = 0xFFFF;
  putV2(2, flat);
  // when
  boot();
  const std::string report = fake::output();
  const std::string status = command("status");
  const std::string one = command("f 1 300");
  // then: both refused at start, with the rule; status says it again; commands refused
  EXPECT_EQ(lineStartingWith(report, "motor 1:"),
            "motor 1: not calibrated: implausible: pulse outside the ESC range (curve 1: 2500 us; allowed "
            "1000..2000 us) - refusing to arm; recalibrate it with gather_store");
  EXPECT_EQ(lineStartingWith(report, "motor 2:"),
            "motor 2: not calibrated: v2 record, both copies bad (copy A implausible values, copy B erased (never calibrated)): "
            "implausible: flat curve (force without drive) (0 %; at least 25 %) - refusing to arm; "
            "recalibrate it with gather_store");
  EXPECT_EQ(calibrated_, 2);
  EXPECT_TRUE(contains(status, "motor 1: not calibrated: implausible: pulse outside the ESC range")) << status;
  EXPECT_TRUE(contains(one, "error: motor 1 is not calibrated: implausible:")) << one;
  command("f 300");
  runFor(200, true);
  EXPECT_EQ(pulse(1), 1000);
  EXPECT_EQ(pulse(2), 1000);
  EXPECT_GT(pulse(0), 1300);
}

TEST_F(ReadRun, TheDividerIsAStoredSettingAndTheCalibrationIsLoadedAgainstIt) {
  // given: a 6S model (rests at 24.9 V) in slot 0 and the thesis divider
  const tc::ModelV2 six_s = curveModel(4800.0, 24900);
  ASSERT_TRUE(six_s.isPresent());
  ASSERT_TRUE(tc::writeModelV2<hal::Eeprom>(0, six_s, [] {
                tc::RecordLimits l;
                l.monitor_full_scale_mv = 27727;
                return l;
              }()).status == tc::WriteV2Status::kWritten);
  fake::setAdcCounts(hal::kAdcBattery, 1023);  // the thesis divider clips a 6S pack
  boot();
  // then: the thesis divider cannot have measured 24.9 V: refused
  EXPECT_TRUE(contains(fake::output(), "battery monitor: divider 100000/47000 ohm, full scale 15.638 V (thesis default)"))
      << fake::output();
  EXPECT_EQ(lineStartingWith(fake::output(), "motor 0:"),
            "motor 0: not calibrated: v2 record, both copies bad (copy A implausible values, copy B erased (never calibrated)): "
            "implausible: voltage outside the pack and monitor range (24.900 V; allowed 3.000..15.638 V) - "
            "refusing to arm; recalibrate it with gather_store");
  // when: the divider on A1 is set to 100k/22k (27.727 V)
  fake::setAdcCounts(hal::kAdcBattery, countsFor(24900, 27727));
  const std::string set = command("divider 100000 22000");
  // then: stored, the calibration loaded again, motor 0 armed
  EXPECT_TRUE(contains(set, "divider 100000/22000 ohm, full scale 27.727 V, stored (motor 3's slot, copy A)")) << set;
  EXPECT_TRUE(contains(set, "motor 0: ok, model v2")) << set;
  EXPECT_TRUE(app_->motor(0).isArmable());
  // and it flies 4.5 kg at the bus voltage read through the new divider
  const std::string cmd = command("f 0 4500");
  EXPECT_FALSE(contains(cmd, "error")) << cmd;
  runFor(3000, true);
  const uint16_t bus_mv = app_->busFilter().mv;
  EXPECT_NEAR(bus_mv, 24900, 30);
  tc::BusVoltageFilter bus;
  bus.reset(bus_mv);
  tc::ModelV2 loaded;
  tc::RecordLimits limits;
  limits.monitor_full_scale_mv = 27727;
  ASSERT_EQ(tc::readModelV2<FakeStorage>(0, loaded, limits).status, tc::DecodeStatus::kOk);
  EXPECT_NEAR(pulse(0), tc::forceToPwmV2(loaded, 45000, bus).pwm_us, 1);
  EXPECT_GT(pulse(0), 1800);
  EXPECT_TRUE(contains(command("f 0 5001"), "error: G must be a whole number 0..5000, got \"5001\"")) << "above 5 kg";
  // and after a reboot the divider comes from the EEPROM
  command("stop");
  boot();
  EXPECT_TRUE(contains(fake::output(), "battery monitor: divider 100000/22000 ohm, full scale 27.727 V")) << fake::output();
  EXPECT_EQ(calibrated_, 1);
}

TEST_F(ReadRun, TheDividerCommandRefusesWhatCannotBeADividerAndChangesNothing) {
  storeFourMotors();
  boot();
  const std::vector<uint8_t> before(fake::eeprom(), fake::eeprom() + hal::Eeprom::kSize);
  const struct {
    const char* line;
    const char* error;
  } rows[] = {
      {"divider 100000 0", "error: divider 100000/0 ohm gives a full scale outside 5..60 V or R2 below 100 ohm"},
      {"divider 1000000 10000", "error: divider 1000000/10000 ohm gives a full scale outside 5..60 V"},
      {"divider 100k 47k", "error: R1_OHM must be a whole number 0..10000000, got \"100k\""},
      {"divider 100000 22000", "error: no room for the setting: all four slots hold thesis (v1) records"},
  };
  for (const auto& r : rows) {
    SCOPED_TRACE(r.line);
    const std::string out = command(r.line);
    EXPECT_TRUE(contains(out, r.error)) << out;
    EXPECT_EQ(std::vector<uint8_t>(fake::eeprom(), fake::eeprom() + hal::Eeprom::kSize), before);
  }
  EXPECT_TRUE(contains(command("divider"), "divider 100000/47000 ohm, full scale 15.638 V (thesis default)"));
}

TEST_F(ReadRun, AOneCellFiveGramMotorFliesItsModelV2) {
  // given: a 6 g motor on a 1S pack (4.1 V), monitored without a divider (R1 = 0: 5 V scale)
  const tc::ModelV2 tiny = curveModel(6.0, 4100);
  ASSERT_TRUE(tiny.isPresent());
  EXPECT_EQ(tiny.q16_inverse, 1);
  tc::BoardSettings direct;
  direct.divider_top_ohm = 0;
  direct.divider_bottom_ohm = 10000;
  ASSERT_EQ(tc::storeSettings<FakeStorage>(direct).status, tc::SettingsWriteStatus::kWritten);
  ASSERT_EQ(tc::writeModelV2<FakeStorage>(1, tiny, direct.recordLimits()).status, tc::WriteV2Status::kWritten);
  fake::setAdcCounts(hal::kAdcBattery, countsFor(4100, 5000));
  // when
  boot();
  command("f 1 5");
  runFor(3000, true);
  // then
  EXPECT_TRUE(app_->motor(1).fliesV2()) << fake::output();
  tc::BusVoltageFilter bus;
  bus.reset(app_->busFilter().mv);
  EXPECT_NEAR(app_->busFilter().mv, 4100, 10);
  EXPECT_NEAR(pulse(1), tc::forceToPwmV2(tiny, 50, bus).pwm_us, 1);
  EXPECT_GT(pulse(1), 1500);
}

}  // namespace rr_test
