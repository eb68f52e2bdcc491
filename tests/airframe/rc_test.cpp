// RC receiver input (issue 25, item 4): the header pin map, `--rc` and `--rc-script` parsing
// (a malformed row names its file:line:column), and rc_probe (tests/airframe/rc_probe) decoding
// the receiver's signal in simavr the three ways flight firmware does: PPM by input capture
// (ICP4, D49), PPM by an external interrupt (INT2, D19), PWM by pin-change interrupts on A8..A15
// (PCINT2, which simavr 1.6 lacks; sim/pin_change.hpp). Values from a script and from the live
// pty arrive within 2 us; `loss` stops the pulses; a board reset keeps the receiver going.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "air_support.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/pin_change.hpp"
#include "sim/pin_names.hpp"
#include "sim/ports.hpp"
#include "sim/rc_input.hpp"

extern "C" {
#include <simavr/sim_avr.h>
#include <simavr/sim_irq.h>
}

namespace {

using RcValues = std::array<double, 8>;

// --- pins and parsing ---

TEST(RcSpec, ReadsPpmAndPwmAndRefusesPinsTheBoardUses) {
  const auto esc = sim::boardEscPins();
  const sim::RcSpec ppm = sim::parseRcSpec("ppm:D49", &esc);
  EXPECT_EQ(ppm.signal, sim::RcSignal::kPpm);
  ASSERT_EQ(ppm.pins.size(), 1u);
  EXPECT_EQ(ppm.pins[0].arduino, 49);
  const sim::RcSpec pwm = sim::parseRcSpec("pwm:A8,A9,A10,A11", &esc);
  EXPECT_EQ(pwm.signal, sim::RcSignal::kPwm);
  EXPECT_EQ(pwm.pins.size(), 4u);
  const struct {
    const char* spec;
    const char* says;
  } bad[] = {
      {"ppm:D49,D48", "a PPM sum is one pin"},       {"sbus:D19", "write ppm:PIN"},
      {"D49", "write ppm:PIN"},                      {"ppm:D6", "D6 (PH3) carries ESC 0"},
      {"pwm:A8,D20", "carries the TWI"},             {"ppm:D0", "carries UART0"},
      {"pwm:A8,A9,A10,A11,A12,A13,A14,A15,D49", "at most 8 channels"},
      {"pwm:A8,A9,PK0", "D62 (PK0) is named twice"}, {"ppm:PE7", "PE7 is not on the Mega's headers"},
      {"ppm:D70", "pin 'D70' is not a Mega 2560 pin"}, {"pwm:A8,", "pin '' is not a Mega 2560 pin"},
  };
  for (const auto& b : bad) {
    try {
      sim::parseRcSpec(b.spec, &esc);
      ADD_FAILURE() << b.spec << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(b.says), std::string::npos) << b.spec << ": " << e.what();
    }
  }
}

TEST(RcScript, ReadsHeaderRowsCommentsAndLoss) {
  const auto rows = sim::parseRcScript(
      "# sticks for a test\n"
      "t_s, ch1, ch2, ch3, ch4\n"
      "\n"
      "0.0,1500,1500,1000,1500\r\n"
      "# arm: yaw right\n"
      "0.5,1500,1500,1000,2000\n"
      "1.25,loss\n"
      "2,1500.5,1499,1100,1500\n",
      "s.csv");
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[0].count, 4);
  EXPECT_EQ(rows[0].us[2], 1000.0);
  EXPECT_EQ(rows[1].t_s, 0.5);
  EXPECT_EQ(rows[1].us[3], 2000.0);
  EXPECT_EQ(rows[1].line, 6);
  EXPECT_TRUE(rows[2].loss);
  EXPECT_EQ(rows[2].t_s, 1.25);
  EXPECT_EQ(rows[3].us[0], 1500.5);
}

TEST(RcScript, AMalformedRowIsAnErrorWithItsFileLineAndColumn) {
  const std::string header = "t_s,ch1,ch2,ch3,ch4\n0,1500,1500,1000,1500\n";
  const struct {
    std::string text;
    const char* where;
    const char* says;
  } rows[] = {
      {header + "0.1,1500,1500,1000\n", "s.csv:3:1:", "3 values, the header has 4 channels"},
      {header + "0.1,1500,abc,1000,1500\n", "s.csv:3:10:", "ch2 'abc' is not a number"},
      {header + "0.1,1500,1500,3000,1500\n", "s.csv:3:15:", "ch3 3000 us is outside 500..2500 us"},
      {header + "0.1,1500,1500,1000,1500\n0.05,loss\n", "s.csv:4:1:", "before the previous row's"},
      {header + "-1,loss\n", "s.csv:3:1:", "not a number of simulated seconds"},
      {header + "0.1,lost\n", "s.csv:3:1:", "write T,V1,...,V4 or T,loss"},
      {"time,ch1\n", "s.csv:1:1:", "the first column is 'time'"},
      {"t_s,ch1,ch3\n", "s.csv:1:9:", "expected ch2"},
      {"# only a comment\n", "s.csv:", "no header"},
      {"t_s,ch1\n", "s.csv:1:", "no rows after the header"},
  };
  for (const auto& r : rows) {
    try {
      sim::parseRcScript(r.text, "s.csv");
      ADD_FAILURE() << "accepted:\n" << r.text;
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(r.where, 0), 0u) << what;
      EXPECT_NE(what.find(r.says), std::string::npos) << what;
    }
  }
}

// --- rc_probe in simavr ---

class RcProbe : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string(RC_PROBE_ELF).empty()) GTEST_SKIP() << "avr-gcc not found: no rc_probe image";
  }
  void start(const std::string& spec) {
    board = std::make_unique<sim::Board>(RC_PROBE_ELF);
    rc = std::make_unique<sim::RcOnBoard>(*board, sim::parseRcSpec(spec, &board->escPins()));
    con = std::make_unique<sim::Console>(*board, "");
    con->onLine([this](const std::string& line) { lines.push_back({board->timeS(), line}); });
  }
  void TearDown() override {
    con.reset();
    rc.reset();
    board.reset();
  }
  void runTo(double t_s) { board->runFor(t_s - board->timeS()); }
  // The decoder's lines `name v1 ... v8` printed within [from_s, to_s): their values ("-" = NaN).
  std::vector<RcValues> decoded(const std::string& name, double from_s, double to_s) const {
    std::vector<RcValues> out;
    for (const auto& [t, line] : lines) {
      if (t < from_s || t >= to_s || line.rfind(name + " ", 0) != 0) continue;
      std::istringstream in(line.substr(name.size()));
      RcValues v{};
      for (double& x : v) {
        std::string word;
        in >> word;
        x = word == "-" || word.empty() ? NAN : std::stod(word);
      }
      out.push_back(v);
    }
    return out;
  }
  // Every decoded frame in the window carries `want` on its first `n` channels within 2 us.
  void expectFrames(const std::string& name, double from_s, double to_s, const RcValues& want, int n,
                    std::size_t at_least) {
    const auto frames = decoded(name, from_s, to_s);
    EXPECT_GE(frames.size(), at_least) << name << " in " << from_s << ".." << to_s << " s";
    for (const RcValues& v : frames)
      for (int i = 0; i < n; ++i) EXPECT_NEAR(v[i], want[i], 2.0) << name << " ch" << i + 1;
  }
  bool printed(const std::string& text, double from_s) const {
    for (const auto& [t, line] : lines)
      if (t >= from_s && line == text) return true;
    return false;
  }
  // Edges seen on a pin (host side) from now on.
  uint64_t* countEdges(char port, uint8_t bit) {
    edge_count = 0;
    avr_irq_register_notify(board->ports().pinIrq(port, bit), &RcProbe::onEdge, &edge_count);
    return &edge_count;
  }
  static void onEdge(avr_irq_t* irq, uint32_t value, void* param) {
    if ((irq->value != 0) != ((value & 0xFF) != 0)) ++*static_cast<uint64_t*>(param);
  }

  std::unique_ptr<sim::Board> board;
  std::unique_ptr<sim::RcOnBoard> rc;
  std::unique_ptr<sim::Console> con;
  std::vector<std::pair<double, std::string>> lines;
  uint64_t edge_count = 0;
};

sim::RcScriptRow rcRow(double t_s, RcValues us, int count = 8) {
  sim::RcScriptRow r;
  r.t_s = t_s;
  r.count = count;
  std::copy(us.begin(), us.end(), r.us.begin());
  return r;
}
sim::RcScriptRow rcLossAt(double t_s) {
  sim::RcScriptRow r;
  r.t_s = t_s;
  r.loss = true;
  return r;
}

TEST_F(RcProbe, PpmFromAScriptReachesInputCaptureWithinTwoMicrosecondsAndLossStopsIt) {
  start("ppm:D49");
  const RcValues a{1500, 1500, 1000, 1500, 1100, 1900, 1234.5, 2000};
  const RcValues b{1000, 2000, 1600, 1400, 988, 2012, 1500, 1500};
  rc->play({rcRow(0.02, a), rcRow(0.25, b), rcLossAt(0.45)});
  runTo(0.60);
  // a row takes effect at the next frame (<= 22.5 ms), printed when the next sync ends it
  expectFrames("ppm-icp", 0.08, 0.25, a, 8, 6);
  expectFrames("ppm-icp", 0.31, 0.45, b, 8, 5);
  EXPECT_TRUE(decoded("ppm-icp", 0.50, 0.60).empty());
  EXPECT_TRUE(printed("lost ppm-icp", 0.45));
  EXPECT_TRUE(decoded("ppm-int", 0, 1).empty()) << "nothing drives D19";
  // no edge on the line after the loss; idle high
  uint64_t* edges = countEdges('L', 0);
  runTo(0.70);
  EXPECT_EQ(*edges, 0u);
  EXPECT_TRUE(board->avr()->data[0x109] & 1) << "PINL bit 0: the PPM line idles high";
}

TEST_F(RcProbe, PpmOnAnExternalInterruptPinIsDecodedByInt2) {
  start("ppm:D19");
  const RcValues a{1100, 1200, 1300, 1400, 1600, 1700, 1800, 1900};
  rc->play({rcRow(0.0, a)});
  runTo(0.25);
  expectFrames("ppm-int", 0.06, 0.25, a, 8, 6);
  EXPECT_TRUE(decoded("ppm-icp", 0, 1).empty());
}

TEST_F(RcProbe, PwmOnPortKReachesThePinChangeInterruptWithinTwoMicrosecondsAndLossStopsIt) {
  start("pwm:A8,A9,A10,A11,A12,A13,A14,A15");
  // simavr 1.6 would show the firmware's PORTK pull-ups over the lines held low: not here
  runTo(0.01);
  EXPECT_EQ(board->avr()->data[0x106], 0) << "PINK with the pull-ups on and every line low";
  const RcValues a{1500, 1500, 1000, 1500, 1000, 2000, 1700, 1300};
  rc->play({rcRow(0.02, a), rcRow(0.30, RcValues{1200, 1800}, 2), rcLossAt(0.50)});
  runTo(0.70);
  expectFrames("pwm", 0.09, 0.30, a, 8, 8);
  expectFrames("pwm", 0.36, 0.50, RcValues{1200, 1800, 1000, 1500, 1000, 2000, 1700, 1300}, 8, 5);
  EXPECT_TRUE(printed("lost pwm", 0.50));
  EXPECT_TRUE(decoded("pwm", 0.55, 0.70).empty());
  const uint64_t requests = board->pinChange().requests(2);
  runTo(0.80);
  EXPECT_EQ(board->pinChange().requests(2), requests) << "no pin changes after the loss";
  EXPECT_EQ(board->avr()->data[0x106], 0) << "every PWM line low";
}

TEST_F(RcProbe, PwmOnFewerPinsLeavesTheOthersQuiet) {
  start("pwm:A8,A9,A10,A11");
  rc->play({rcRow(0.0, RcValues{1100, 1300, 1500, 1700}, 4)});
  runTo(0.2);
  const auto frames = decoded("pwm", 0.06, 0.2);
  ASSERT_GE(frames.size(), 5u);
  for (const RcValues& v : frames) {
    EXPECT_NEAR(v[3], 1700, 2.0);
    EXPECT_TRUE(std::isnan(v[4]) && std::isnan(v[7])) << "A12..A15 carry no pulse";
  }
}

TEST_F(RcProbe, ThePinChangeFlagIsSetWithTheInterruptOffClearedByAOneAndRaisedWhenEnabled) {
  start("pwm:A8");
  rc->play({rcRow(0.0, RcValues{1500}, 1)});
  runTo(0.05);
  con->send("pcif");
  EXPECT_EQ(con->expect("^pcif .*", 0.3).at(0), "pcif set 1 cleared 0 isr 1");
}

TEST_F(RcProbe, LiveLinesOnThePtyArriveWithinTwoMicroseconds) {
  start("ppm:D49");
  const std::string path = rc->openPty();
  ASSERT_EQ(path.rfind("/dev/pts/", 0), 0u) << path;
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  ASSERT_GE(fd, 0) << path;
  const std::string typed = "ch 1500 1500 1000 1500 1300\rbogus\r";
  ASSERT_EQ(::write(fd, typed.data(), typed.size()), static_cast<ssize_t>(typed.size()));
  runTo(0.25);
  expectFrames("ppm-icp", 0.07, 0.25, RcValues{1500, 1500, 1000, 1500, 1300, 1500, 1500, 1500}, 8, 6);
  const std::string more = "ch 1800,1200\rloss\r";
  ASSERT_EQ(::write(fd, more.data(), more.size()), static_cast<ssize_t>(more.size()));
  runTo(0.40);
  EXPECT_TRUE(printed("lost ppm-icp", 0.25));
  char buf[2048] = {};
  const ssize_t n = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  ASSERT_GT(n, 0);
  const std::string replies(buf, static_cast<std::size_t>(n));
  EXPECT_NE(replies.find("ok t="), std::string::npos) << replies;
  EXPECT_NE(replies.find(": ch 1500 1500 1000 1500 1300 from the next frame"), std::string::npos) << replies;
  EXPECT_NE(replies.find("error: 'bogus' is not a command"), std::string::npos) << replies;
  EXPECT_NE(replies.find("no signal from the next frame"), std::string::npos) << replies;
  EXPECT_EQ(rc->applied().size(), 3u);
}

TEST_F(RcProbe, TheReceiverGoesOnThroughABoardReset) {
  start("ppm:D49");
  const RcValues a{1400, 1600, 1000, 1500, 1500, 1500, 1500, 1500};
  rc->play({rcRow(0.0, a)});
  runTo(0.15);
  board->reset(sim::ResetKind::kExternal);
  const double t_reset = board->timeS();
  runTo(0.40);
  EXPECT_TRUE(printed("rc_probe ready", t_reset));
  expectFrames("ppm-icp", t_reset + 0.06, 0.40, a, 8, 6);
}

TEST(RcCommand, SaysWhatToWriteAndKeepsTheRestOfTheChannels) {
  if (std::string(RC_PROBE_ELF).empty()) GTEST_SKIP();
  sim::Board board(RC_PROBE_ELF);
  sim::RcOnBoard rc(board, sim::parseRcSpec("pwm:A8,A9,A10", nullptr));
  EXPECT_NE(rc.command("ch 1500 x").find("error: 'x' is not a number of microseconds"), std::string::npos);
  EXPECT_NE(rc.command("ch 1500 3000").find("error: ch2 3000 us is outside 500..2500 us"), std::string::npos);
  EXPECT_NE(rc.command("ch").find("error: no values"), std::string::npos);
  EXPECT_NE(rc.command("ch 1500 1500 1500 1500 1500 1500 1500 1500 1500").find("more than 8 values"), std::string::npos);
  EXPECT_NE(rc.command("fly").find("error: 'fly' is not a command; commands: ch V1"), std::string::npos);
  EXPECT_TRUE(rc.applied().empty()) << "a refused line changes nothing";
  EXPECT_NE(rc.command("status").find("no signal, ch 1500 1500 1500"), std::string::npos) << rc.command("status");
  rc.command("ch 1100 1200 1300");
  rc.command("  ch 1900  ");
  EXPECT_NE(rc.command("status").find("signal on, ch 1900 1200 1300"), std::string::npos) << rc.command("status");
}

// --- the command line ---

TEST(RcCli, SimRunPlaysTheScriptAndRefusesAMalformedRowWithItsLine) {
  if (std::string(RC_PROBE_ELF).empty()) GTEST_SKIP();
  const std::string good = std::string(AIR_TEST_TMP) + "/rc_good.csv";
  const std::string bad = std::string(AIR_TEST_TMP) + "/rc_bad.csv";
  std::ofstream(good) << "t_s,ch1,ch2,ch3,ch4\n0,1500,1500,1000,1500\n0.1,1500,1500,1000,2000\n";
  std::ofstream(bad) << "# header next\nt_s,ch1,ch2,ch3,ch4\n0,1500,1500,1000\n";
  int status = 0;
  const std::string out = air::shell(fmt::format("{} sim run --elf {} --duration 0.2 --rc pwm:A8,A9,A10,A11 "
                                                 "--rc-script {}",
                                                 THRUSTCAL_BIN, RC_PROBE_ELF, good),
                                     status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("pwm 1500.0 1500.0 1000.0 2000.0 - - - -"), std::string::npos) << out;
  EXPECT_NE(out.find("rc: PWM on D62 (PK0), D63 (PK1), D64 (PK2), D65 (PK3), 2 changes applied"), std::string::npos)
      << out;
  const std::string err = air::shell(fmt::format("{} sim run --elf {} --duration 0.2 --rc pwm:A8 --rc-script {}",
                                                 THRUSTCAL_BIN, RC_PROBE_ELF, bad),
                                     status);
  EXPECT_NE(status, 0);
  EXPECT_NE(err.find(bad + ":3:1: 3 values, the header has 4 channels"), std::string::npos) << err;
  const std::string no_rc =
      air::shell(fmt::format("{} sim run --elf {} --duration 0.1 --rc-script {}", THRUSTCAL_BIN, RC_PROBE_ELF, good),
                 status);
  EXPECT_NE(status, 0);
  EXPECT_NE(no_rc.find("--rc-script needs a receiver: add --rc ppm:PIN"), std::string::npos) << no_rc;
}

}  // namespace
