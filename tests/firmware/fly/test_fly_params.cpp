// fly's saved parameters (firmware/fly/params*.cpp) on the fake HAL: the table's defaults are
// what fly starts with, `param list|get|set|save|load|defaults` as a user meets them, the
// record over a reset, what fly says and flies when the saved record is of another layout,
// cannot be right, or has no room, and what may change while armed.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "fly_fixture.hpp"
#include "params.hpp"
#include "thrustcal/crc16.hpp"
#include "thrustcal/param_store.hpp"

namespace {

using fly_test::Fly;
using records_test::contains;
namespace fake = hal::fake;

struct FakeEeprom {
  static uint8_t readByte(uint16_t a) { return hal::Eeprom::readByte(a); }
  static void updateByte(uint16_t a, uint8_t v) { hal::Eeprom::updateByte(a, v); }
};

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) {
    if (!l.empty() && l.back() == '\r') l.pop_back();
    if (!l.empty() && l.rfind("fly> ", 0) != 0) out.push_back(l);
  }
  return out;
}

class FlyParams : public Fly {
 protected:
  // bootReady(), returning what fly said while it booted.
  std::string bootSaying() {
    boot();
    const std::string said = fake::takeOutput();
    runFor(tc::kArmMs + 10 - fake::nowMs());
    fake::takeOutput();
    return said;
  }
  // The reply to one command line, its echo left out.
  std::vector<std::string> reply(const std::string& line) {
    std::vector<std::string> out = lines(command(line));
    if (!out.empty() && out[0] == line) out.erase(out.begin());
    return out;
  }
  std::vector<int32_t> flying() const {
    fly::ParamValues v;
    fly::Params::capture(*app_, v);
    return std::vector<int32_t>(v, v + fly::kParamCount);
  }
  // A record written as another tool would, bypassing fly's checks.
  static void putRecord(const fly::ParamValues& v, uint8_t layout) {
    tc::ParamsRecord r;
    r.layout = layout;
    r.length = tc::paramPayloadBytes(fly::kParamRows, fly::kParamCount);
    tc::encodeParams(fly::kParamRows, fly::kParamCount, v, r.payload);
    ASSERT_EQ(tc::writeParams<FakeEeprom>(r).status, tc::ParamsWriteStatus::kWritten);
  }
  static void defaults(fly::ParamValues& v) { tc::defaultParams(fly::kParamRows, fly::kParamCount, v); }
};

TEST_F(FlyParams, TheTablesDefaultsAreWhatFlyStartsWithAndNoneSavedIsSaid) {
  const std::string said = bootSaying();
  fly::ParamValues want;
  defaults(want);
  const std::vector<int32_t> got = flying();
  for (uint8_t i = 0; i < fly::kParamCount; ++i)
    EXPECT_EQ(got[i], want[i]) << tc::paramRow(fly::kParamRows, i).name;
  EXPECT_TRUE(contains(said, "params: none saved: the defaults")) << said;
  EXPECT_TRUE(contains(command("status"), "params: the defaults, none saved"));
}

// Rows added, removed, reordered or resized change the record: kParamLayout must be raised.
TEST(FlyParamTable, ItsLayoutVersionIsPinnedToItsRows) {
  uint16_t crc = 0xFFFF;
  for (uint8_t i = 0; i < fly::kParamCount; ++i) {
    const tc::ParamDef d = tc::paramRow(fly::kParamRows, i);
    for (const char* p = d.name; *p != '\0'; ++p) crc = tc::crc16Update(crc, static_cast<uint8_t>(*p));
    crc = tc::crc16Update(crc, d.bytes);
    crc = tc::crc16Update(crc, d.min < 0 ? 1 : 0);
  }
  EXPECT_EQ(fly::kParamLayout, 1);
  EXPECT_EQ(crc, 0x2D61) << "the rows changed: raise kParamLayout (params.hpp) and pin the new "
                            "fingerprint here, 0x"
                         << std::hex << crc;
  EXPECT_LE(tc::paramPayloadBytes(fly::kParamRows, fly::kParamCount), tc::kParamPayloadMax);
  EXPECT_EQ(fly::kParamTable.rows, fly::kParamCount);
  EXPECT_EQ(fly::kParamTable.row, fly::kParamRows);
  fly::ParamValues v;
  tc::defaultParams(fly::kParamRows, fly::kParamCount, v);
  EXPECT_TRUE(tc::checkParams(fly::kParamRows, fly::kParamCount, v).ok()) << "every default is allowed";
}

TEST_F(FlyParams, ListShowsOneRowPerParameterNameFirstValueSecondThenUnitAndRange) {
  bootReady();
  const std::vector<std::string> rows = reply("param list");
  ASSERT_EQ(rows.size(), fly::kParamCount) << fake::output();
  for (uint8_t i = 0; i < fly::kParamCount; ++i) {
    std::istringstream in(rows[i]);
    std::string name, value, hash;
    in >> name >> value >> hash;
    EXPECT_EQ(name, tc::paramRow(fly::kParamRows, i).name) << rows[i];
    EXPECT_EQ(hash, "#") << rows[i];
  }
  EXPECT_EQ(rows[fly::kParamAngleKp], "angle_kp 800  # mN m/rad, 0..10000");
  EXPECT_EQ(rows[fly::kParamLayoutWord], "layout x  # plus|x|seesaw");
  EXPECT_EQ(rows[fly::kParamHoverUs], "hover_us 0  # us, 0 (off) or 1001..2000");
  EXPECT_EQ(rows[fly::kParamApExpo], "ap_expo 0.6500  # -1.0000..1.0000");
  EXPECT_EQ(rows[fly::kParamLevelX], "level_x_mg 0.0  # mg, -100.1..100.1");
  EXPECT_EQ(reply("param get angle_kd")[0],
            "angle_kd 146  # mN m s/rad, 0..10000, default 146: angle mode, roll and pitch: torque per rad/s of "
            "body rate (the thesis's Kd 0.4: 146)");
}

TEST_F(FlyParams, SetChangesWhatFliesAndSaveKeepsItOverAReset) {
  bootReady();
  // when: set in RAM
  EXPECT_EQ(reply("param set angle_kp 900")[0], "angle_kp 900  # mN m/rad, 0..10000; unsaved (reset gives 800)");
  for (const char* line : {"param set layout plus", "param set mode pwm", "param set hover_us 1480",
                           "param set hover_mg_per_us 1440", "param set level_x_mg 39.1", "param set ap_expo 0.6913",
                           "param set yaw_arm_um 15100", "param set crash_deg 30"}) {
    const std::string out = command(line);
    EXPECT_FALSE(contains(out, "error")) << line << ": " << out;
  }
  // then: flying now, and said unsaved
  EXPECT_FLOAT_EQ(app_->controller().settings().angle.kp_nm_per_rad, 0.9f);
  EXPECT_EQ(app_->mixer().layout(), fly::Layout::kPlus);
  EXPECT_EQ(app_->output().mode(), fly::OutputMode::kPwm);
  EXPECT_EQ(app_->estimator().levelTrimLsb(0), 160) << "39.1 mg at 4096 LSB/g";
  EXPECT_EQ(app_->settings().crash_deg, 30);
  EXPECT_TRUE(contains(command("status"), "params: 9 unsaved (param list marks them; param save keeps them)"));
  // when: saved, then a reset
  EXPECT_TRUE(contains(command("param save"), "param: saved 34 parameters (motor 3's slot, copy A, sequence 1)"))
      << fake::output();
  EXPECT_TRUE(contains(command("param save"), "param: nothing to save: the EEPROM holds these values"));
  const std::vector<int32_t> before = flying();
  const std::string said = bootSaying();
  // then: the same values fly, and fly said where they came from
  EXPECT_TRUE(contains(said, "params: 34 loaded from the EEPROM (motor 3's slot, copy A, sequence 1)")) << said;
  const std::vector<int32_t> after = flying();
  for (uint8_t i = 0; i < fly::kParamCount; ++i)
    EXPECT_EQ(after[i], before[i]) << tc::paramRow(fly::kParamRows, i).name;
  EXPECT_EQ(app_->output().mode(), fly::OutputMode::kPwm);
  EXPECT_EQ(app_->estimator().levelTrimLsb(0), 160);
  EXPECT_TRUE(contains(command("status"), "params: as saved (motor 3's slot, copy A, sequence 1)"));
  // when: changed, then `param load` takes the saved ones back; `param defaults` the table's
  command("param set angle_kp 1000");
  command("param load");
  EXPECT_FLOAT_EQ(app_->controller().settings().angle.kp_nm_per_rad, 0.9f);
  EXPECT_TRUE(contains(command("param defaults"), "param: the defaults (not saved: param save keeps them)"));
  EXPECT_FLOAT_EQ(app_->controller().settings().angle.kp_nm_per_rad, 0.8f);
  EXPECT_EQ(app_->output().mode(), fly::OutputMode::kForce);
}

TEST_F(FlyParams, TheSettingCommandsAndParamSetChangeTheSameThing) {
  bootReady();
  command("gains 700 10 120");
  command("ap 6913 1581 9500 1315");
  EXPECT_EQ(reply("param get angle_kp")[0].substr(0, 13), "angle_kp 700 ");
  EXPECT_TRUE(contains(command("param get ap_full_g"), "ap_full_g 1315  # g"));
  command("param set angle_kd 200");
  EXPECT_FLOAT_EQ(app_->controller().settings().angle.kd_nm_s_per_rad, 0.2f);
  EXPECT_TRUE(contains(command("param list"), "angle_ki 10  # mN m/(rad s), 0..10000; unsaved (reset gives 0)"));
}

struct Refusal {
  const char* line;
  const char* says;
};

TEST_F(FlyParams, SetRefusesWhatIsNotAValueOfTheRowAndChangesNothing) {
  bootReady();
  const Refusal cases[] = {
      {"param set rp_kq 900", "error: no parameter \"rp_kq\"; param list shows them"},
      {"param set angle_kp 20000", "error: angle_kp must be 0..10000 mN m/rad, got \"20000\"; nothing changed"},
      {"param set angle_kp 8.5", "error: angle_kp takes a whole number 0..10000 mN m/rad, got \"8.5\"; nothing changed"},
      {"param set level_x_mg 1.25",
       "error: level_x_mg takes a number with at most 1 decimals, -100.1..100.1 mg, got \"1.25\"; nothing changed"},
      {"param set layout h", "error: layout is one of plus|x|seesaw, got \"h\"; nothing changed"},
      {"param set hover_us 900", "error: hover_us must be 0 (off) or 1001..2000 us, got \"900\"; nothing changed"},
      {"param set ap_pwm_max_us 900",
       "error: ap_pwm_min_us 1000 must be below ap_pwm_max_us 900 unless that is 0; nothing changed"},
      {"param set mode generic", "error: mode generic not taken: slot 0 is not calibrated"},
      {"param get", "error: usage: param list | param save|load|defaults | param get NAME | param set NAME VALUE"},
  };
  const std::vector<int32_t> before = flying();
  for (const Refusal& c : cases) {
    const std::string out = command(c.line);
    EXPECT_TRUE(contains(out, c.says)) << c.line << "\n" << out;
  }
  const std::vector<int32_t> after = flying();
  for (uint8_t i = 0; i < fly::kParamCount; ++i) EXPECT_EQ(after[i], before[i]) << static_cast<int>(i);
}

TEST_F(FlyParams, TheReceiverTheSticksAndEachFlightModesGainsAreSavedToo) {
  bootReady();
  // given: the receiver set by its commands, the rest by param set
  command("rc ppm");
  command("rcmap TAER");
  command("rates 40 300 150");
  EXPECT_EQ(reply("param get rc_map")[0].substr(0, 12), "rc_map TAER ");
  for (const char* line : {"param set rc_mode_channel 0", "param set flight_mode rate", "param set rate_kp 200",
                           "param set rate_ki 50", "param set rc_channels 6"}) {
    const std::string out = command(line);
    EXPECT_FALSE(contains(out, "error")) << line << ": " << out;
  }
  EXPECT_TRUE(contains(command("param set rc_channels 9"),
                       "error: rc_channels must be 4..8, got \"9\"; nothing changed"));
  EXPECT_TRUE(contains(command("param list"), "rc_protocol ppm  # off|ppm|pwm; unsaved (reset gives off)"));
  // when: saved, and the board reset
  command("param save");
  bootSaying();
  // then: they fly again
  EXPECT_EQ(app_->rcSettings().protocol, fly::RcProtocol::kPpm);
  EXPECT_EQ(std::string(app_->rcSettings().map), "TAER");
  EXPECT_EQ(app_->rcSettings().mode_channel, 0xFF) << "no mode switch";
  EXPECT_EQ(app_->rcSettings().pwm_channels, 6);
  EXPECT_EQ(app_->rcSettings().default_mode, fly::FlightMode::kRate);
  EXPECT_EQ(app_->stickCommand().settings().max_angle_deg, 40);
  EXPECT_EQ(app_->stickCommand().settings().max_rate_dps, 300);
  EXPECT_EQ(app_->stickCommand().settings().max_yaw_rate_dps, 150);
  EXPECT_FLOAT_EQ(app_->controller().settings().rate.kp_nm_s_per_rad, 0.2f);
  EXPECT_FLOAT_EQ(app_->controller().settings().rate.ki_nm_per_rad, 0.05f);
  EXPECT_TRUE(contains(command("status"), "params: as saved"));
}

TEST_F(FlyParams, ArmedOnlyTheCrashLimitChangesAndNothingIsSavedOrLoaded) {
  storeFourV2Motors();
  bootReady();
  armAndSpool(1200);
  EXPECT_TRUE(contains(command("param set angle_kp 900"),
                       "error: armed: angle_kp could make the motors jump; disarm first (crash_deg may change armed)"));
  EXPECT_FLOAT_EQ(app_->controller().settings().angle.kp_nm_per_rad, 0.8f);
  EXPECT_TRUE(contains(command("param set crash_deg 60"), "crash_deg 60  # deg, 10..90; unsaved (reset gives 45)"));
  EXPECT_EQ(app_->settings().crash_deg, 60);
  for (const char* line : {"param save", "param load", "param defaults", "eeprom crc", "gains 900 0 146", "yaw 200 0",
                           "fmode rate"})
    EXPECT_TRUE(contains(command(line), "error: armed; send disarm first")) << line;
  EXPECT_TRUE(app_->armed());
  EXPECT_TRUE(contains(command("status"), "params: 1 unsaved")) << "arming with unsaved changes is allowed";
}

TEST_F(FlyParams, ASavedRecordOfAnotherLayoutFliesTheDefaultsAndSaysSo) {
  fly::ParamValues v;
  defaults(v);
  v[fly::kParamAngleKp] = 900;
  putRecord(v, fly::kParamLayout + 1);
  std::string said = bootSaying();
  EXPECT_TRUE(contains(said, "params: saved by a fly with parameter layout 2 (this one has 1): the "
                                       "defaults; set them again and param save (or thrustcal board params push)"))
      << said;
  EXPECT_FLOAT_EQ(app_->controller().settings().angle.kp_nm_per_rad, 0.8f);
  // and saving writes this layout over it
  command("param set angle_kp 900");
  command("param save");
  said = bootSaying();
  EXPECT_TRUE(contains(said, "params: 34 loaded")) << said;
}

TEST_F(FlyParams, ASavedRecordThatCannotBeRightIsNeverFlown) {
  fly::ParamValues v;
  defaults(v);
  v[fly::kParamAngleKp] = 20000;
  putRecord(v, fly::kParamLayout);
  std::string said = bootSaying();
  EXPECT_TRUE(contains(said, "params: the saved copy cannot be right (angle_kp 20000; allowed 0..10000): "
                                       "the defaults"))
      << said;
  EXPECT_FLOAT_EQ(app_->controller().settings().angle.kp_nm_per_rad, 0.8f);
  defaults(v);
  v[fly::kParamApVoltMin] = 12600;
  v[fly::kParamApVoltMax] = 12000;
  putRecord(v, fly::kParamLayout);
  said = bootSaying();
  EXPECT_TRUE(contains(said, "(ap_volt_min_mv 12600 not below ap_volt_max_mv 12000)")) << said;
}

TEST_F(FlyParams, WithFourThesisRecordsThereIsNoRoomAndTheDefaultsFly) {
  storeFourThesisMotors();
  std::string said = bootSaying();
  EXPECT_TRUE(contains(said, "params: none, and no room to save any: all four slots hold thesis (v1) "
                                       "records, which fill the EEPROM; the defaults"))
      << said;
  command("param set angle_kp 900");
  EXPECT_TRUE(contains(command("param save"), "error: no room: all four slots hold thesis (v1) records"));
}

TEST_F(FlyParams, ASavedGenericModeWhoseSlotLostItsRecordFliesForceAndSaysSo) {
  storeFourV2Motors();
  bootReady();
  command("param set generic_slot 2");
  command("param set mode generic");
  ASSERT_EQ(app_->output().mode(), fly::OutputMode::kGeneric);
  command("param save");
  hal::Eeprom::updateByte(tc::slotAddress(2), 0xFF);  // slot 2's copies erased
  hal::Eeprom::updateByte(tc::slotAddress(2) + tc::kRecordV2CopyOffset, 0xFF);
  std::string said = bootSaying();
  EXPECT_TRUE(contains(said, "error: mode generic not taken: slot 2 is not calibrated")) << said;
  EXPECT_EQ(app_->output().mode(), fly::OutputMode::kForce);
}

TEST_F(FlyParams, EepromCrcAndDumpAnswerAsTheOtherImagesDo) {
  bootReady();
  EXPECT_TRUE(contains(command("eeprom crc"), "eeprom crc slot0 ")) << fake::output();
  EXPECT_TRUE(contains(command("eeprom dump"), ":00000001FF"));
}

}  // namespace
