// `thrustcal board params push|pull` on the simulated board (Debian's STK500v2 bootloader in
// simavr on a pty, real avrdude, fly.elf behind it): a file goes in through the bootloader as
// the record fly's `param save` writes, fly boots with it, and it comes back out through
// `eeprom dump`; a bad file is refused with its line numbers before the board is touched.
// Wall-clock driven (the bootloader's ~1 s wait is real), label `board`.
#include <gtest/gtest.h>

#include <fstream>

#include "board/params.hpp"
#include "board_support.hpp"

namespace {

using board_test::image;
using board_test::slurp;
using board_test::SimulatedBoard;


TEST_F(SimulatedBoard, ParamsPushedAsAFileAreWhatFlyLoadsAndPullBringsThemBack) {
  if (!std::filesystem::exists(image("fly", ".hex"))) GTEST_SKIP() << "no fly image: build the AVR tree";
  // given: fly behind the bootloader, nothing saved; a file naming three parameters
  start(image("fly", ".elf"));
  const std::string dir = board_test::tempDir("params");
  const std::string in = dir + "/tuned.txt", out = dir + "/pulled.txt";
  std::ofstream(in) << "# tuned on the gimbal\nangle_kp 900\nlayout plus   # the frame\n\nlevel_x_mg -3.5\n";
  const std::string hex = image("fly", ".hex");
  // when: pushed
  const board_test::ProcessResult push =
      board_test::run({THRUSTCAL_EXE, "board", "params", "push", "--port", port, in, "--image", hex}, 120);
  // then: one copy written, verified, and fly said it loaded it
  ASSERT_EQ(push.exit_code, 0) << push.output;
  EXPECT_NE(push.output.find("3 of 34 parameters from the file, the rest kept; motor 3's slot, copy A, sequence 1"),
            std::string::npos)
      << push.output;
  EXPECT_NE(push.output.find("fly says: params: 34 loaded from the EEPROM (motor 3's slot, copy A, sequence 1)"),
            std::string::npos)
      << push.output;
  const board::ParamTableCopy t = board::readParamTable(hex);
  const board::BoardParamState s = board::paramsInImage(t, eeprom());
  ASSERT_EQ(s.how, board::BoardParamState::How::kLoaded) << s.why;
  std::vector<int32_t> want = t.defaults();
  want[tc::findParam(t.data(), t.count(), "angle_kp")] = 900;
  want[tc::findParam(t.data(), t.count(), "layout")] = 0;
  want[tc::findParam(t.data(), t.count(), "level_x_mg")] = -35;
  EXPECT_EQ(s.values, want);
  // when: pulled
  const board_test::ProcessResult pull =
      board_test::run({THRUSTCAL_EXE, "board", "params", "pull", "--port", port, out, "--image", hex}, 60);
  // then: the file holds every parameter, as `param list` prints them
  ASSERT_EQ(pull.exit_code, 0) << pull.output;
  const std::string text = slurp(out);
  EXPECT_NE(text.find("\nangle_kp 900  # mN m/rad, 0..10000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\nlevel_x_mg -3.5  # mg, -100.1..100.1\n"), std::string::npos) << text;
  EXPECT_EQ(board::parseParamFile(t, text, out, t.defaults()).values, want);
  // when: a bad file is pushed
  const std::vector<uint8_t> before = eeprom();
  const int resets_before = resets;
  std::ofstream(dir + "/bad.txt") << "angle_kp 20000\nfoo 3\n";
  const board_test::ProcessResult bad = board_test::run(
      {THRUSTCAL_EXE, "board", "params", "push", "--port", port, dir + "/bad.txt", "--image", hex}, 60);
  // then: refused with its lines, the board not even opened
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.output.find("bad.txt:1: angle_kp must be 0..10000 mN m/rad, got \"20000\""), std::string::npos)
      << bad.output;
  EXPECT_NE(bad.output.find("bad.txt:2: no parameter \"foo\""), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("2 errors; nothing written"), std::string::npos) << bad.output;
  EXPECT_EQ(resets, resets_before);
  EXPECT_EQ(eeprom(), before);
  std::cout << "[ figures ] params push " << push.wall_s << " s, pull " << pull.wall_s << " s\n";
}

}  // namespace
