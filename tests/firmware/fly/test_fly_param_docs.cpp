// fly's parameter table as the host tools see it (tools/board: `thrustcal board params`):
// docs/fly.md's table is the one the table gives, the host writes a parameter file's lines as
// `param list` prints them, and the table read out of fly.hex is the one compiled here.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "board/params.hpp"
#include "fly_fixture.hpp"
#include "params.hpp"

namespace {

using fly_test::Fly;
namespace fake = hal::fake;

board::ParamTableCopy compiled() {
  return board::copyParamTable(fly::kParamRows, fly::kParamCount, fly::kParamLayout, "fly (host build)");
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(FlyParamDocs, TheManualsTableIsTheOneTheTableGives) {
  const std::string path = std::string(THRUSTCAL_SOURCE_DIR) + "/docs/fly.md";
  const std::string doc = readFile(path);
  const std::string want = board::withParamDocsTable(doc, board::paramDocsTable(compiled()), path);
  EXPECT_EQ(doc, want) << "docs/fly.md: run thrustcal board params table --docs docs/fly.md";
}

TEST(FlyParamDocs, TheTableInFlyHexIsTheOneCompiledHere) {
  const std::string hex = board::defaultFlyHex();
  if (!std::filesystem::exists(hex)) GTEST_SKIP() << "no " << hex << ": build the AVR tree";
  const board::ParamTableCopy avr = board::readParamTable(hex);
  const board::ParamTableCopy host = compiled();
  ASSERT_EQ(avr.layout, host.layout);
  ASSERT_EQ(avr.rows.size(), host.rows.size());
  for (std::size_t i = 0; i < host.rows.size(); ++i) {
    const tc::ParamDef &a = avr.rows[i], &h = host.rows[i];
    EXPECT_STREQ(a.name, h.name);
    EXPECT_STREQ(a.unit, h.unit);
    EXPECT_STREQ(a.help, h.help);
    EXPECT_EQ(a.words == nullptr, h.words == nullptr);
    if (a.words && h.words) {
      EXPECT_STREQ(a.words, h.words);
    }
    EXPECT_EQ(a.min, h.min) << h.name;
    EXPECT_EQ(a.max, h.max) << h.name;
    EXPECT_EQ(a.def, h.def) << h.name;
    EXPECT_EQ(a.bytes, h.bytes) << h.name;
    EXPECT_EQ(a.decimals, h.decimals) << h.name;
    EXPECT_EQ(a.flags, h.flags) << h.name;
    EXPECT_EQ(a.group, h.group) << h.name;
  }
}

TEST_F(Fly, AParameterFileHoldsTheLinesParamListPrintsAndReadsBackToTheSameValues) {
  bootReady();
  command("param set angle_kp 900");
  command("param set level_x_mg -3.5");
  command("param set layout seesaw");
  std::string listed;
  for (char c : command("param list"))
    if (c != '\r') listed += c;
  fly::ParamValues v;
  fly::Params::capture(*app_, v);
  const board::ParamTableCopy t = compiled();
  const std::vector<int32_t> values(v, v + fly::kParamCount);
  std::string file = board::formatParamFile(t, values, {});
  // `param list` marks unsaved values after the range; a file has none of that
  std::string plain;
  std::istringstream in(listed);
  for (std::string l; std::getline(in, l);) {
    if (l.rfind("fly> ", 0) == 0 || l.empty() || l == "param list") continue;  // prompt, echo
    plain += l.substr(0, l.find("; unsaved")) + "\n";
  }
  EXPECT_EQ(plain, file);
  const board::ParamFile back = board::parseParamFile(t, plain, "param list", t.defaults());
  EXPECT_EQ(back.values, values);
  EXPECT_EQ(back.givenCount(), t.rows.size());
}

TEST(FlyParamFile, EveryBadLineIsNamedWithItsNumberAndNothingIsTaken) {
  const board::ParamTableCopy t = compiled();
  const std::string text =
      "# a comment\n"
      "angle_kp 20000\n"
      "foo 1\n"
      "layout plus   # trailing comment\n"
      "layout x\n"
      "angle_kd\n"
      "level_x_mg 1.25\n"
      "hover_us 900\n";
  try {
    board::parseParamFile(t, text, "bad.txt", t.defaults());
    FAIL() << "a bad file was taken";
  } catch (const board::ParamError& e) {
    const std::string what = e.what();
    for (const char* says : {"bad.txt:2: angle_kp must be 0..10000 mN m/rad, got \"20000\"",
                             "bad.txt:3: no parameter \"foo\" in fly (host build)",
                             "bad.txt:5: layout given again (first on line 4)",
                             "bad.txt:6: expected NAME VALUE, got \"angle_kd\"",
                             "bad.txt:7: level_x_mg takes a number with at most 1 decimals, -100.1..100.1 mg, got \"1.25\"",
                             "bad.txt:8: hover_us must be 0 (off) or 1001..2000 us, got \"900\"",
                             "6 errors; nothing written"})
      EXPECT_NE(what.find(says), std::string::npos) << says << "\n" << what;
  }
}

TEST(FlyParamFile, NamesItLeavesOutKeepTheBoardsValuesAndRulesSpanBoth) {
  const board::ParamTableCopy t = compiled();
  std::vector<int32_t> board_values = t.defaults();
  board_values[fly::kParamAngleKd] = 200;
  board_values[fly::kParamApVoltMax] = 12600;
  const board::ParamFile f = board::parseParamFile(t, "angle_kp 900\n", "ok.txt", board_values);
  EXPECT_EQ(f.values[fly::kParamAngleKp], 900);
  EXPECT_EQ(f.values[fly::kParamAngleKd], 200) << "kept from the board";
  EXPECT_EQ(f.givenCount(), 1u);
  try {
    board::parseParamFile(t, "\n\nap_volt_min_mv 13000\n", "rule.txt", board_values);
    FAIL() << "a minimum above the board's maximum was taken";
  } catch (const board::ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("rule.txt:3: ap_volt_min_mv 13000 must be below ap_volt_max_mv 12600 "
                                         "unless that is 0"),
              std::string::npos)
        << e.what();
  }
}

TEST(FlyParamFile, TheRecordStoredInAnImageIsWhatFlyReads) {
  const board::ParamTableCopy t = compiled();
  std::vector<uint8_t> eeprom(4096, 0xFF);
  EXPECT_EQ(board::paramsInImage(t, eeprom).how, board::BoardParamState::How::kNone);
  std::vector<int32_t> v = t.defaults();
  v[fly::kParamAngleKp] = 950;
  const tc::ParamsWrite w = board::storeParamsInImage(t, v, eeprom);
  ASSERT_EQ(w.status, tc::ParamsWriteStatus::kWritten);
  EXPECT_EQ(board::storeParamsInImage(t, v, eeprom).status, tc::ParamsWriteStatus::kUnchanged);
  const board::BoardParamState s = board::paramsInImage(t, eeprom);
  EXPECT_EQ(s.how, board::BoardParamState::How::kLoaded);
  EXPECT_EQ(s.values, v);
  EXPECT_EQ(s.why, "motor 3's slot, copy A, sequence 1");
}

}  // namespace
