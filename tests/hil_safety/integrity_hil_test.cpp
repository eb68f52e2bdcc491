// Issue 8, item 3 (docs/console.md): command integrity on the real images in simavr. A line
// damaged by a receive overflow, a framing error or the rest of an aborting line is rejected
// whole with one error line and never executed as something else; the checksum and strict
// mode; what keeps the failsafe alive; a lift-off stops on loss of link; gather_store executes
// every line of a burst that fits its buffers.
#include <gtest/gtest.h>

#include <algorithm>

#include "safety_support.hpp"
#include "sim/rigs.hpp"

namespace {

using safety::contains;
using safety::withSum;

int countOf(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = 0; (p = text.find(what, p)) != std::string::npos; p += what.size()) ++n;
  return n;
}

// The PWM read_run sends motor 1 for 37 g in steady state, from its own status line.
int pwmFor37g(safety::ReadRunBoard& rr) {
  rr.con.command("f 1 37");
  rr.keepAliveFor(0.3);
  const int pwm = static_cast<int>(std::lround(rr.board.escPulseUs(1)));
  rr.con.command("stop");
  rr.board.runFor(0.1);
  return pwm;
}

TEST(Integrity, ABurstOf300IdenticalLinesNeverRunsAnythingElse) {
  HIL_REQUIRE_IMAGE("read_run");
  // given: motors stopped; what "f 1 37" gives motor 1
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  const int pwm37 = pwmFor37g(rr);
  ASSERT_GT(pwm37, 1050);
  const double t0 = rr.board.timeS();
  // when: 300 "f 1 37" at once (2100 bytes: the replies are longer, the receive ring overflows)
  std::string burst;
  for (int i = 0; i < 300; ++i) burst += "f 1 37\r";
  rr.board.sendText(burst);
  rr.board.runFor(0.5);
  rr.keepAliveFor(0.5);
  // then: only motor 1 ever moved, never above its 37 g pulse ("f 1 377", "f 17", "f 1" did
  // not happen); the overflow was reported, one error line per damaged line
  const double t1 = rr.board.timeS();
  for (int ch : {0, 2, 3}) EXPECT_LE(rr.log.widestBetween(t0, t1, ch), 1000.6) << "motor " << ch << " moved";
  EXPECT_LE(rr.log.widestBetween(t0, t1, 1), pwm37 + 1.0);
  const std::string out = rr.board.output();
  const int damaged = countOf(out, "error: line damaged in transit");
  EXPECT_GT(damaged, 0) << "a 2100-byte burst overflows the 64-byte receive ring";
  EXPECT_EQ(countOf(out, "error: "), damaged) << "no other error: nothing was misread";
  std::printf("300 lines: %d rejected as damaged, the rest executed\n", damaged);
}

TEST(Integrity, TheRestOfAKeyThatAbortsALiftoffIsNeverExecuted) {
  HIL_REQUIRE_IMAGE("read_run");
  // given: a lift-off in its hold phase, kept alive
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  rr.con.send("liftoff 300 500 5000");
  rr.keepAliveFor(1.0);
  ASSERT_GT(rr.board.escPulseUs(2), 1200.0);
  // when: "xf 2 450" (the x aborts)
  rr.con.send("xf 2 450");
  rr.board.runFor(0.05);
  const double t_abort = rr.board.timeS();
  rr.keepAliveFor(1.0);
  // then: stopped, and motor 2 did not start again
  const std::string out = rr.board.output();
  EXPECT_TRUE(contains(out, "# liftoff aborted by input: motors stopped")) << rr.con.tail();
  EXPECT_TRUE(contains(out, "error: ignored the rest of the line whose first key aborted"))
      << rr.con.tail();
  EXPECT_LE(rr.log.widestBetween(t_abort, rr.board.timeS()), 1000.6);
}

TEST(Integrity, TheRestOfAKeyThatAbortsASweepIsNeverExecuted) {
  HIL_REQUIRE_IMAGE("gather_store");
  // given: slot 0 calibrated, a sweep running on it
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = sim::motorForSeed("kv1100_9x4.7", 11, 0.03);
  sim::BenchRig rig(hil::imagePath("gather_store"), params, 0);
  const std::vector<uint8_t> eeprom = safety::calibratedEeprom();
  rig.board.setEeprom(eeprom);
  sim::Console con(rig.board, "gs> ");
  con.waitPrompt(10.0);
  con.command("tare", 5);
  con.send("sweep");
  ASSERT_TRUE(rig.board.runUntil([&] { return rig.board.escPulseUs(0) > 1100.0; },
                                 sim::secondsToCycles(30)));
  // when: "xerase" (the x aborts)
  con.send("xerase");
  rig.board.runFor(0.5);
  con.command("status", 5);
  // then
  const std::string out = rig.board.output();
  EXPECT_TRUE(contains(out, "# aborted: key pressed")) << con.tail();
  EXPECT_TRUE(contains(out, "error: ignored the rest of the line whose first key aborted (5"))
      << con.tail();
  EXPECT_FALSE(contains(out, "erased motor")) << con.tail();
  EXPECT_EQ(rig.board.eeprom(), eeprom) << "slot 0 was erased";
}

TEST(Integrity, ALineWithAFramingErrorIsRejectedWhole) {
  HIL_REQUIRE_IMAGE("read_run");
  // given
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  const double t0 = rr.board.timeS();
  // when: "f 1 37" whose "3" arrives garbled
  rr.board.sendText("f 1 ");
  rr.board.sendFramingError('3');
  rr.board.sendText("7\r");
  const auto reply = rr.con.waitPrompt(1.0);
  rr.keepAliveFor(0.5);
  // then
  EXPECT_TRUE(contains(::testing::PrintToString(reply), "error: line damaged in transit"))
      << rr.con.tail();
  EXPECT_LE(rr.log.widestBetween(t0, rr.board.timeS()), 1000.6) << "f 1 7 ran";
  EXPECT_TRUE(contains(rr.con.command("status").back(), "1 lines rejected"));
}

TEST(Integrity, StrictModeNeedsAValidChecksumToSpinAMotor) {
  HIL_REQUIRE_IMAGE("read_run");
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  rr.con.command("strict on");
  const auto plain = rr.con.command("f 200");
  const auto wrong = rr.con.command("f 200*75");
  rr.keepAliveFor(0.2);
  EXPECT_LE(rr.board.escPulseUs(0), 1000.6);
  EXPECT_TRUE(contains(::testing::PrintToString(plain), "error: strict mode")) << rr.con.tail();
  EXPECT_TRUE(contains(::testing::PrintToString(wrong), "error: checksum *75")) << rr.con.tail();
  // with the checksum it runs; stopping never needs one
  rr.con.command(withSum("f 200"));
  for (int i = 0; i < 4; ++i) {  // strict keep-alive: a checksummed empty line
    rr.con.send("*00");
    rr.board.runFor(0.2);
  }
  EXPECT_GT(rr.board.escPulseUs(0), 1100.0);
  rr.con.command("f 0");
  rr.board.runFor(0.1);
  EXPECT_LE(rr.board.escPulseUs(0), 1000.6);
}

struct KeepAliveCase {
  const char* name;
  bool strict;
  std::string line;  // sent every 100 ms
  bool keeps_alive;
};

void PrintTo(const KeepAliveCase& c, std::ostream* os) { *os << c.name; }

class KeepAlive : public ::testing::TestWithParam<KeepAliveCase> {};

TEST_P(KeepAlive, OnlyACompleteValidLineKeepsTheMotorsRunning) {
  HIL_REQUIRE_IMAGE("read_run");
  // given
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  const KeepAliveCase& c = GetParam();
  if (c.strict) rr.con.command("strict on");
  rr.con.command(withSum("f 200"));
  // when: the line every 100 ms for 1.5 s
  for (int i = 0; i < 15; ++i) {
    rr.board.sendText(c.line);
    rr.board.runFor(0.1);
  }
  // then
  const bool tripped = contains(rr.board.output(), "failsafe: no command for 500 ms");
  EXPECT_EQ(!tripped, c.keeps_alive) << rr.con.tail();
  EXPECT_EQ(rr.board.escPulseUs(0) > 1100.0, c.keeps_alive);
}

INSTANTIATE_TEST_SUITE_P(
    Table, KeepAlive,
    ::testing::Values(KeepAliveCase{"EmptyLine", false, "\r", true},
                      KeepAliveCase{"RefusedCommand", false, "bogus\r", true},
                      KeepAliveCase{"BytesWithoutLineEnd", false, "ab", false},
                      KeepAliveCase{"NoiseLine", false, "\x01\x9b\r", false},
                      KeepAliveCase{"DamagedChecksum", false, "f 200*00\r", false},
                      KeepAliveCase{"StrictEmptyLine", true, "\r", false},
                      KeepAliveCase{"StrictChecksummedEmptyLine", true, "*00\r", true}),
    [](const ::testing::TestParamInfo<KeepAliveCase>& info) { return info.param.name; });

TEST(Integrity, ALiftoffStopsWhenTheLinkGoesQuietAndRunsToItsEndWhileKeptAlive) {
  HIL_REQUIRE_IMAGE("read_run");
  // given / when: no input after the command
  {
    safety::ReadRunBoard rr(safety::calibratedEeprom());
    rr.con.send("liftoff 300 1000 3000");
    rr.board.runFor(0.05);
    const double t_cmd = rr.board.timeS();
    rr.board.runFor(2.0);
    // then: stopped 500 ms after the command
    EXPECT_TRUE(contains(rr.board.output(), "# liftoff stopped: no line end for 500 ms"))
        << rr.con.tail();
    const double t_stop = rr.log.lastWiderThan(1000.6);
    EXPECT_LE(t_stop - t_cmd, 0.5 + 0.040);
    EXPECT_EQ(rr.board.output().find("# liftoff done"), std::string::npos);
  }
  // kept alive by empty lines every 200 ms: it runs its course
  {
    safety::ReadRunBoard rr(safety::calibratedEeprom());
    rr.con.send("liftoff 300 1000 3000");
    rr.keepAliveFor(4.5);
    EXPECT_TRUE(contains(rr.board.output(), "# liftoff done: motors stopped")) << rr.con.tail();
    EXPECT_EQ(rr.board.output().find("# liftoff stopped"), std::string::npos);
  }
}

TEST(Integrity, GatherStoreExecutesEveryLineOfASetupBurst) {
  HIL_REQUIRE_IMAGE("gather_store");
  // given
  sim::Board board(hil::imagePath("gather_store"));
  board.setAdcSource([](int ch) { return ch == 1 ? safety::batteryPinMv() : 2000.0; });
  sim::Console con(board, "gs> ");
  con.waitPrompt(10.0);
  // when: a host sends its whole setup at once (90 bytes; the replies are ~6 times longer:
  // what does not fit the transmit ring waits in the receive ring)
  const std::vector<std::string> lines = {"motor 2",  "plate 55", "range 1040 1700",
                                          "step 20",  "motor 3",  "plate 60",
                                          "step 10",  "range 1040 1800", "settle 120"};
  std::string burst;
  for (const auto& l : lines) burst += l + "\r";
  const std::size_t from = board.output().size();
  board.sendText(burst);
  board.runFor(1.0);
  // then: every line answered, none rejected, the last settings hold
  const std::string out = board.output().substr(from);
  EXPECT_EQ(countOf(out, "gs> "), static_cast<int>(lines.size())) << out;
  EXPECT_EQ(countOf(out, "error"), 0) << out;
  con.expect("^settle 120 ms per step", 1.0);
  con.waitPrompt(1.0);
  const auto status = con.command("status", 5);
  ASSERT_FALSE(status.empty());
  EXPECT_TRUE(contains(status[0], "motor 3")) << status[0] << "\n" << out;
  EXPECT_TRUE(contains(status[0], "plate 60 g, range 1040..1800 us, step 10 us, settle 120 ms"))
      << status[0];
}

// sim::waitAnswer, which the console fuzz and sim::drainConsole wait with: read_run answers an
// empty line (its keep-alive) with the line end's echo and nothing more, a command with its
// prompt; gather_store answers an empty line with a prompt.
TEST(Integrity, AnEmptyLineGetsReadRunsEchoAloneAndGatherStoresPrompt) {
  HIL_REQUIRE_IMAGE("read_run");
  HIL_REQUIRE_IMAGE("gather_store");
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  std::size_t mark = rr.board.output().size();
  rr.con.send("");
  EXPECT_EQ(sim::waitAnswer(rr.con, mark, 0.02, 1.0), sim::Answer::kEchoOnly) << rr.con.tail();
  EXPECT_EQ(rr.board.output().substr(mark), "\r\n");
  mark = rr.board.output().size();
  rr.con.send("status");
  EXPECT_EQ(sim::waitAnswer(rr.con, mark, 0.02, 1.0), sim::Answer::kPrompt) << rr.con.tail();

  sim::Board gs(hil::imagePath("gather_store"));
  gs.setEeprom(safety::calibratedEeprom());
  sim::Console con(gs, "gs> ");
  con.waitPrompt(10.0);
  mark = gs.output().size();
  con.send("");
  EXPECT_EQ(sim::waitAnswer(con, mark, 0.02, 1.0), sim::Answer::kPrompt) << con.tail();
}

// A drain while read_run streams its rows (no prompt ever comes for an empty line then) ends
// once two empty lines were echoed, instead of waiting out five 2 s prompt time-outs, and leaves
// the console answering.
TEST(Integrity, ADrainWhileReadRunStreamsEndsWithinASimulatedSecond) {
  HIL_REQUIRE_IMAGE("read_run");
  safety::ReadRunBoard rr(safety::calibratedEeprom());
  rr.con.send("stream on");
  rr.board.runFor(0.5);
  const double t0 = rr.board.timeS();
  sim::drainConsole(rr.con, 0.1);
  EXPECT_LT(rr.board.timeS() - t0, 1.0) << rr.con.tail();
  const auto reply = rr.con.command("stream off", 2.0);
  EXPECT_TRUE(contains(::testing::PrintToString(reply), "# stream off")) << rr.con.tail();
}

}  // namespace
