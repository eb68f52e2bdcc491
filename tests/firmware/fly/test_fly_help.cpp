// fly's `help` is rendered from its command table; docs/fly.md's copy of it (the "fly> help"
// block) must be exactly that text, so a command, a range or a help line changed in the table
// fails here until the manual follows.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "fly_app.hpp"
#include "hal/fake.hpp"

namespace {

std::string renderedHelp() {
  hal::fake::reset();
  fly::FlyApp::printHelp();
  std::string lf;
  for (char c : hal::fake::takeOutput()) {
    if (c != '\r') lf += c;
  }
  return lf;
}

// The lines between "fly> help" and the next "fly> " prompt in docs/fly.md.
std::string docsHelpBlock() {
  std::ifstream in(std::string(THRUSTCAL_SOURCE_DIR) + "/docs/fly.md");
  EXPECT_TRUE(in) << "docs/fly.md";
  std::stringstream text;
  text << in.rdbuf();
  const std::string all = text.str();
  const std::string start = "\nfly> help\n";
  const std::size_t from = all.find(start);
  if (from == std::string::npos) return "(no \"fly> help\" block in docs/fly.md)";
  const std::size_t body = from + start.size();
  const std::size_t to = all.find("\nfly> ", body - 1);
  if (to == std::string::npos) return "(the \"fly> help\" block in docs/fly.md has no closing prompt)";
  return all.substr(body, to + 1 - body);
}

TEST(FlyHelp, ComesFromTheTableAndListsEveryCommandWithItsRange) {
  const std::string help = "\n" + renderedHelp();
  for (const char* row :
       {"help ", "arm ", "disarm ", "sp ROLL_DEG PITCH_DEG ", "thrust G ", "gains KP KI KD ", "yaw KP KI ",
        "mode force|generic|pwm|ardupilot [N]", "layout plus|x|seesaw ", "airframe ARM_MM YAW_ARM_UM",
        "hover US MG_PER_US", "ap EXPO_E4 SPIN_MIN_E4 SPIN_MAX_E4 FULL_G", "apvolt VMAX_MV VMIN_MV",
        "appwm MIN_US MAX_US", "crash DEG ", "calibrate ", "stream on|off ", "status ", "strict on|off ",
        "rc off|ppm|pwm [N]", "rcmap AETR|TAER|AERT|EATR|ERTA ", "rates ANGLE_DEG RATE_DPS YAW_DPS",
        "fmode angle|rate "}) {
    EXPECT_NE(help.find(std::string("\n") + row), std::string::npos) << row << help;
  }
  EXPECT_NE(help.find("(ROLL_DEG -30..30, PITCH_DEG -30..30)"), std::string::npos) << help;
  EXPECT_NE(help.find("(DEG 10..90)"), std::string::npos) << help;
  EXPECT_NE(help.find(" " + std::to_string(tc::kFailsafeMs) + " ms"), std::string::npos) << help;
  EXPECT_NE(help.find(" " + std::to_string(fly::kRcLossMs) + " ms without a valid"), std::string::npos) << help;
}

TEST(FlyHelp, TheManualShowsExactlyWhatHelpPrints) {
  EXPECT_EQ(docsHelpBlock(), renderedHelp()) << "docs/fly.md: paste the output of `help` (this text)";
}

}  // namespace
