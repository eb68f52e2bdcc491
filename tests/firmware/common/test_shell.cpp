// The table-driven shell: matching rows by name and argument count, range and word checks,
// one error line per refusal, strict mode, help generated from the table.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hal/fake.hpp"
#include "shell.hpp"

namespace {

struct Calls {
  std::vector<std::string> log;
};

std::string describe(const char* what, const fw::ArgValues& args) {
  std::string s = what;
  for (uint8_t i = 0; i < args.count; ++i) s += " " + std::to_string(args[i]);
  return s;
}

void runForceAll(Calls& c, const fw::ArgValues& a) { c.log.push_back(describe("all", a)); }
void runForceOne(Calls& c, const fw::ArgValues& a) { c.log.push_back(describe("one", a)); }
void runStream(Calls& c, const fw::ArgValues& a) { c.log.push_back(describe("stream", a)); }
void runLiftoff(Calls& c, const fw::ArgValues& a) { c.log.push_back(describe("liftoff", a)); }
void runHelp(Calls& c, const fw::ArgValues& a) { c.log.push_back(describe("help", a)); }
void runSettleAuto(Calls& c, const fw::ArgValues& a) { c.log.push_back(describe("auto", a)); }
void runSettleMs(Calls& c, const fw::ArgValues& a) { c.log.push_back(describe("settle", a)); }

const fw::ArgSpec kG[] = {{"G", nullptr, 0, 500}};
const fw::ArgSpec kNG[] = {{"N", nullptr, 0, 3}, {"G", nullptr, 0, 500}};
const fw::ArgSpec kOnOff[] = {{"", "on|off", 0, 0}};
const fw::ArgSpec kLiftoff[] = {
    {"G", nullptr, 1, 500}, {"RAMP_MS", nullptr, 0, 60000}, {"HOLD_MS", nullptr, 0, 60000}};
const fw::ArgSpec kAuto[] = {{"", "auto", 0, 0}};
const fw::ArgSpec kMs[] = {{"MS", nullptr, 0, 10000}};

const fw::Command<Calls> kTable[] = {
    {{"help", nullptr, 0, 0, 0, "this list"}, runHelp},
    {{"f", kG, 1, 1, fw::kCmdGuarded, "all motors to G grams"}, runForceAll},
    {{"f", kNG, 2, 2, fw::kCmdGuarded, "motor N to G grams"}, runForceOne},
    {{"stream", kOnOff, 1, 1, 0, "CSV lines, 10 per second"}, runStream},
    {{"liftoff", kLiftoff, 1, 3, fw::kCmdGuarded, "ramp, hold, stop;\nany key aborts"},
     runLiftoff},
    {{"settle", kAuto, 1, 1, 0, "settle by measurement"}, runSettleAuto},
    {{"settle", kMs, 1, 1, 0, "wait per step"}, runSettleMs},
};

class Shell : public ::testing::Test {
 protected:
  void SetUp() override { hal::fake::reset(); }
  void TearDown() override { hal::fake::reset(); }

  // Runs one line; returns what the shell printed.
  std::string run(const std::string& line, fw::LineContext context = {}) {
    char buffer[64];
    snprintf(buffer, sizeof buffer, "%s", line.c_str());
    hal::fake::takeOutput();
    last_ = fw::dispatch(calls_, kTable, buffer, context);
    return hal::fake::takeOutput();
  }

  Calls calls_;
  fw::ShellResult last_ = fw::ShellResult::kEmpty;
};

struct Row {
  const char* line;
  const char* call;    // the handler call expected, "" for none
  const char* output;  // exactly what is printed
};

TEST_F(Shell, RunsTheRowWhoseArgumentsFitAndRefusesEverythingElseWithOneErrorLine) {
  const Row rows[] = {
      {"f 300", "all 300", ""},
      {"f 2 450", "one 2 450", ""},
      {"  f   1  0 ", "one 1 0", ""},
      {"f 501", "", "error: G must be a whole number 0..500, got \"501\"\r\n"},
      {"f 4 10", "", "error: N must be a whole number 0..3, got \"4\"\r\n"},
      {"f", "", "error: usage: f G | f N G\r\n"},
      {"f 1 2 3", "", "error: usage: f G | f N G\r\n"},
      {"f 1x", "", "error: G must be a whole number 0..500, got \"1x\"\r\n"},
      {"stream on", "stream 0", ""},
      {"stream off", "stream 1", ""},
      {"stream of", "", "error: expected on|off, got \"of\"\r\n"},
      {"liftoff 300", "liftoff 300", ""},
      {"liftoff 300 1000 2000", "liftoff 300 1000 2000", ""},
      {"liftoff 0", "", "error: G must be a whole number 1..500, got \"0\"\r\n"},
      {"settle auto", "auto 0", ""},
      {"settle 250", "settle 250", ""},
      {"settle fast", "", "error: usage: settle auto | settle MS\r\n"},
      {"help", "help", ""},
      {"help me", "", "error: usage: help\r\n"},
      {"fly 300", "", "error: unknown command \"fly\"; type help for the list\r\n"},
      {"F 300", "", "error: unknown command \"F\"; type help for the list\r\n"},
  };
  for (const Row& row : rows) {
    calls_.log.clear();
    const std::string out = run(row.line);
    EXPECT_EQ(out, row.output) << row.line;
    const std::string call = calls_.log.empty() ? "" : calls_.log.front();
    EXPECT_EQ(call, row.call) << row.line;
    EXPECT_LE(calls_.log.size(), 1u) << row.line;
    EXPECT_EQ(last_, *row.call ? fw::ShellResult::kRan : fw::ShellResult::kRejected) << row.line;
  }
}

TEST_F(Shell, EmptyLineRunsNothingAndSaysNothing) {
  EXPECT_EQ(run("   "), "");
  EXPECT_EQ(last_, fw::ShellResult::kEmpty);
  EXPECT_TRUE(calls_.log.empty());
}

TEST_F(Shell, StrictModeRefusesGuardedCommandsWithoutAChecksumOnly) {
  fw::LineContext strict;
  strict.strict = true;
  EXPECT_EQ(run("f 300", strict),
            "error: strict mode: \"f\" needs a checksum: end the line with *hh (XOR of its "
            "bytes)\r\n");
  EXPECT_TRUE(calls_.log.empty());
  EXPECT_EQ(run("stream on", strict), "");  // not guarded
  strict.checksummed = true;
  EXPECT_EQ(run("f 300", strict), "");
  ASSERT_EQ(calls_.log.size(), 2u);
  EXPECT_EQ(calls_.log[1], "all 300");
}

TEST_F(Shell, HelpIsGeneratedFromTheTableWithUsageAndRanges) {
  hal::fake::takeOutput();
  fw::printHelp(kTable);
  EXPECT_EQ(hal::fake::takeOutput(),
            "help           this list\r\n"
            "f G            all motors to G grams (G 0..500)\r\n"
            "f N G          motor N to G grams (N 0..3, G 0..500)\r\n"
            "stream on|off  CSV lines, 10 per second\r\n"
            "liftoff G [RAMP_MS] [HOLD_MS]  ramp, hold, stop;\r\n"
            "               any key aborts (G 1..500, RAMP_MS 0..60000, HOLD_MS 0..60000)\r\n"
            "settle auto    settle by measurement\r\n"
            "settle MS      wait per step (MS 0..10000)\r\n");
}

}  // namespace

namespace {

const fw::Command<Calls> kStopTable[] = {
    {{"f", kG, 1, 1, fw::kCmdGuarded | fw::kCmdZeroIsStop, "all motors to G grams"}, runForceAll},
    {{"f", kNG, 2, 2, fw::kCmdGuarded | fw::kCmdZeroIsStop, "motor N to G grams"}, runForceOne},
};

TEST(ShellZeroIsStop, AGuardedRowWhoseLastArgumentIsZeroNeedsNoChecksum) {
  hal::fake::reset();
  Calls calls;
  fw::LineContext strict;
  strict.strict = true;
  const struct {
    const char* line;
    bool runs;
  } rows[] = {{"f 0", true}, {"f 2 0", true}, {"f 1", false}, {"f 0 300", false}};
  for (const auto& row : rows) {
    char buffer[32];
    snprintf(buffer, sizeof buffer, "%s", row.line);
    calls.log.clear();
    hal::fake::takeOutput();
    const fw::ShellResult result = fw::dispatch(calls, kStopTable, buffer, strict);
    EXPECT_EQ(result, row.runs ? fw::ShellResult::kRan : fw::ShellResult::kRejected) << row.line;
    EXPECT_EQ(calls.log.size(), row.runs ? 1u : 0u) << row.line;
    if (!row.runs) {
      EXPECT_NE(hal::fake::takeOutput().find("error: strict mode"), std::string::npos) << row.line;
    }
  }
  hal::fake::reset();
}

// fw::kArgText: a token taken as typed (fly's `param set NAME VALUE`), checked by the handler.
void runSet(Calls& c, const fw::ArgValues& a) {
  c.log.push_back(std::string("set ") + a.text[1] + " " + a.text[2] + " " + std::to_string(a.count));
}
const fw::ArgSpec kSet[] = {{"set", "set", 0, 0}, {"NAME", fw::kArgText, 0, 0}, {"VALUE", fw::kArgText, 0, 0}};
const fw::Command<Calls> kTextTable[] = {{{"param", kSet, 3, 3, 0, "a value by name"}, runSet}};

TEST(ShellText, AnArgumentTakenAsTypedReachesTheHandlerAndShowsItsNameInUsageAndHelp) {
  hal::fake::reset();
  Calls calls;
  char line[] = "param set level_x_mg -39.1";
  EXPECT_EQ(fw::dispatch(calls, kTextTable, line, fw::LineContext()), fw::ShellResult::kRan);
  ASSERT_EQ(calls.log.size(), 1u);
  EXPECT_EQ(calls.log[0], "set level_x_mg -39.1 3");
  char short_line[] = "param set x";
  hal::fake::takeOutput();
  EXPECT_EQ(fw::dispatch(calls, kTextTable, short_line, fw::LineContext()), fw::ShellResult::kRejected);
  EXPECT_EQ(hal::fake::takeOutput(), "error: usage: param set NAME VALUE\r\n");
  fw::printHelp(kTextTable);
  EXPECT_EQ(hal::fake::takeOutput(), "param set NAME VALUE  a value by name\r\n");
}

}  // namespace
