// read_run's `help` is rendered from its command table; the manual's copies of it (the
// "rr> help" blocks of docs/read_run.md and docs/console.md) must be exactly that text, so a
// command, a range or a help line changed in the table fails here until the docs follow.
// Also: the pure decisions of run_rules.hpp, checked without a console.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "hal/fake.hpp"
#include "read_run_app.hpp"
#include "run_rules.hpp"

namespace {

std::string renderedHelp() {
  hal::fake::reset();
  rr::ReadRunApp::printHelp();
  std::string out = hal::fake::takeOutput();
  std::string lf;
  for (char c : out) {
    if (c != '\r') lf += c;
  }
  return lf;
}

// The lines between "rr> help" and the next "rr> " prompt in a fenced block of `doc`.
std::string docsHelpBlock(const std::string& doc) {
  std::ifstream in(std::string(THRUSTCAL_SOURCE_DIR) + "/" + doc);
  EXPECT_TRUE(in) << doc;
  std::stringstream text;
  text << in.rdbuf();
  const std::string all = text.str();
  const std::string start = "\nrr> help\n";
  const std::size_t from = all.find(start);
  if (from == std::string::npos) return "(no \"rr> help\" block in " + doc + ")";
  const std::size_t body = from + start.size();
  const std::size_t to = all.find("\nrr> ", body - 1);
  if (to == std::string::npos) return "(the \"rr> help\" block in " + doc + " has no closing prompt)";
  return all.substr(body, to + 1 - body);
}

TEST(ReadRunHelp, ComesFromTheTableAndListsEveryCommandWithItsRange) {
  const std::string help = renderedHelp();
  for (const char* row : {"help ", "f G ", "f N G ", "stop ", "status ", "liftoff G [RAMP_MS] [HOLD_MS]",
                          "stream on|off ", "rate HZ ", "eeprom crc|dump ", "divider ",
                          "divider R1_OHM R2_OHM", "strict on|off "}) {
    EXPECT_NE(("\n" + help).find(std::string("\n") + row), std::string::npos) << row << "\n" << help;
  }
  EXPECT_NE(help.find("(G 0..5000)"), std::string::npos) << help;
  EXPECT_NE(help.find("(N 0..3, G 0..5000)"), std::string::npos) << help;
  EXPECT_NE(help.find("(HZ 50..400)"), std::string::npos) << help;
  EXPECT_NE(help.find(" " + std::to_string(tc::kFailsafeMs) + " ms without a line"), std::string::npos);
  EXPECT_NE(help.find("at most " + std::to_string(fw::kLineMax) + " characters"), std::string::npos);
}

TEST(ReadRunHelp, TheManualShowsExactlyWhatHelpPrints) {
  const std::string help = renderedHelp();
  for (const char* doc : {"docs/read_run.md", "docs/console.md"}) {
    EXPECT_EQ(docsHelpBlock(doc), help) << doc << ": paste the output of `help` (this text)";
  }
}

TEST(RunRules, LiftoffRampsLinearlyInDecigramsHoldsThenStops) {
  using rr::LiftoffPhase;
  struct Case {
    uint32_t elapsed_ms;
    LiftoffPhase phase;
    uint16_t force_dg;
  };
  const Case cases[] = {{0, LiftoffPhase::kRamp, 0},        {500, LiftoffPhase::kRamp, 750},
                        {1, LiftoffPhase::kRamp, 1},        {1999, LiftoffPhase::kRamp, 2998},
                        {2000, LiftoffPhase::kHold, 3000}, {6999, LiftoffPhase::kHold, 3000},
                        {7000, LiftoffPhase::kDone, 0}};
  for (const Case& c : cases) {
    const rr::LiftoffStep step = rr::liftoffStep(c.elapsed_ms, 300, 2000, 5000);
    EXPECT_EQ(step.phase, c.phase) << c.elapsed_ms;
    EXPECT_EQ(step.force_dg, c.force_dg) << c.elapsed_ms;
  }
  EXPECT_EQ(rr::liftoffStep(0, 300, 0, 1000).phase, LiftoffPhase::kHold) << "no ramp: hold at once";
  EXPECT_EQ(rr::liftoffStep(0, 300, 0, 0).phase, LiftoffPhase::kDone);
}

TEST(RunRules, TheLinkIsLostAfterTheFailsafeTimeEvenAcrossTheClockWrap) {
  EXPECT_FALSE(rr::linkLost(1000 + tc::kFailsafeMs - 1, 1000));
  EXPECT_TRUE(rr::linkLost(1000 + tc::kFailsafeMs, 1000));
  EXPECT_FALSE(rr::linkLost(10, 0xFFFFFFF0u));  // 26 ms after, past the 32-bit wrap
  EXPECT_TRUE(rr::linkLost(tc::kFailsafeMs, 0xFFFFFFF0u));
}

TEST(RunRules, TheBusFilterKeepsItsTimeConstantAcrossFrameRates) {
  const struct {
    uint16_t hz;
    uint8_t shift;
  } cases[] = {{50, 3}, {99, 3}, {100, 4}, {199, 4}, {200, 5}, {399, 5}, {400, 6}};
  for (const auto& c : cases) EXPECT_EQ(fw::filterShiftFor(c.hz), c.shift) << c.hz;
}

TEST(RunRules, TheMiddleTwoReadingsIgnoreOneSpikeEitherWayAndClampToTheAdcRange) {
  const uint16_t steady[4] = {700, 700, 700, 700};
  EXPECT_EQ(fw::middleTwoCounts(steady, 1023), 1400);
  const uint16_t spikes[4] = {0, 701, 1023, 699};
  EXPECT_EQ(fw::middleTwoCounts(spikes, 1023), 1400);
  const uint16_t beyond[4] = {2000, 2000, 2000, 2000};
  EXPECT_EQ(fw::middleTwoCounts(beyond, 1023), 2046);
}

}  // namespace
