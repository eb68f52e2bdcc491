// read_run (thesis "Read and Run") against the fake HAL: the 500 ms failsafe, the lift-off
// sequence and its aborts, strict mode, bad input, the frame rate and the stream (the same
// fixture as test_read_run.cpp, read_run_fixture.hpp).
#include <gtest/gtest.h>


#include "read_run_fixture.hpp"
#include "text_match.hpp"

namespace {

using namespace rr_test;
namespace fake = hal::fake;

// ---------------------------------------------------------------------------------------------
// Failsafe

TEST_F(ReadRun, FailsafeStopsAllMotors500MsAfterTheLastCommandButNotAt490Ms) {
  // given
  storeFourMotors();
  boot();
  fake::feedInput("f 300\n");
  const uint32_t sent_ms = fake::nowMs();

  // when / then: still running at 490 ms
  runFor(490);
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_GT(pulse(m), 1400) << "motor " << int(m);
  EXPECT_FALSE(contains(fake::output(), "failsafe"));

  // when / then: stopped at 500 ms
  runFor(sent_ms + 500 - fake::nowMs());
  EXPECT_EQ(fake::nowMs(), sent_ms + 500);
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), 1000) << "motor " << int(m);
  EXPECT_TRUE(contains(fake::output(), "failsafe: no command for 500 ms, motors stopped"));
  EXPECT_FALSE(app_->isRunning());
  EXPECT_EQ(app_->failsafeTrips(), 1u);

  // and the motors stay stopped afterwards
  runFor(1000);
  EXPECT_EQ(pulse(0), 1000);
  EXPECT_EQ(app_->failsafeTrips(), 1u);
}

TEST_F(ReadRun, AnyCompleteLineKeepsTheMotorsRunning) {
  const char* keep_alives[] = {"\n", "\r", "status\n", "bogus\n", "f 300\n"};
  for (const char* line : keep_alives) {
    SCOPED_TRACE(testing::PrintToString(line));
    // given
    fake::reset();
    fake::setTimeLimitMs(120000);
    fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
    storeFourMotors();
    boot();
    fake::feedInput("f 300\n");

    // when: the line every 400 ms for 3 s
    for (int i = 0; i < 8; ++i) {
      runFor(400);
      fake::feedInput(line);
    }
    runFor(10);

    // then
    EXPECT_EQ(app_->failsafeTrips(), 0u);
    EXPECT_GT(pulse(0), 1400);
  }
}

TEST_F(ReadRun, PartialLineIsNotAKeepAlive) {
  // given
  storeFourMotors();
  boot();
  fake::feedInput("f 300\n");
  const uint32_t sent_ms = fake::nowMs();

  // when: a half-typed command at 300 ms, never finished
  runFor(300);
  fake::feedInput("sta");
  runFor(sent_ms + 500 - fake::nowMs());

  // then
  EXPECT_EQ(app_->failsafeTrips(), 1u);
  EXPECT_EQ(pulse(0), 1000);
}

TEST_F(ReadRun, StoppedMotorsNeverTripTheFailsafe) {
  // given
  storeFourMotors();
  boot();

  // when
  runFor(3000);

  // then
  EXPECT_EQ(app_->failsafeTrips(), 0u);
  EXPECT_FALSE(contains(fake::output(), "failsafe:"));
}

// ---------------------------------------------------------------------------------------------
// Lift-off sequence

TEST_F(ReadRun, LiftoffRampsAllFourMotorsThenHoldsThenStops) {
  // given
  storeFourMotors();
  boot();
  std::vector<uint16_t> pwm0;  // motor 0's pulse at every simulated ms after the command
  std::vector<uint16_t> pwm3;
  fake::setTickHook([&](uint32_t) {
    pwm0.push_back(fake::pulseUs(0));
    pwm3.push_back(fake::pulseUs(3));
  });

  // when: 300 g, 1000 ms ramp, 2000 ms hold, then only keep-alive empty lines for 3.5 s
  fake::feedInput("liftoff 300 1000 2000\n");
  runFor(3500, true);

  // then
  const std::string out = fake::output();
  auto cal0 = storedCalibration(0);
  auto cal3 = storedCalibration(3);
  ASSERT_GE(pwm0.size(), 3400u);
  for (size_t t = 1; t < 1000; ++t) ASSERT_GE(pwm0[t], pwm0[t - 1]) << "ramp goes up, t " << t;
  EXPECT_LE(pwm0[5], cal0->first.pwmForGrams(10)) << "the ramp starts near 0 g";
  EXPECT_NEAR(pwm0[500], cal0->first.pwmForGrams(150), 15) << "half way: half the force";
  for (size_t t = 1030; t < 2990; t += 10) {
    ASSERT_EQ(pwm0[t], cal0->first.pwmForGrams(300)) << "hold, t " << t;
    ASSERT_EQ(pwm3[t], cal3->first.pwmForGrams(300)) << "hold, t " << t;
  }
  for (size_t t = 3030; t < pwm0.size(); ++t) ASSERT_EQ(pwm0[t], 1000) << "stopped, t " << t;
  EXPECT_TRUE(contains(out, "# liftoff: ramp 0 -> 300 g in 1000 ms, hold 2000 ms")) << out;
  EXPECT_TRUE(contains(out, "# hold 300 g for 2000 ms")) << out;
  EXPECT_TRUE(contains(out, "# liftoff done: motors stopped")) << out;
  // the frames run on the ESC frame's phase (100 us after its edge at 50 Hz): the notes come from
  // the first frame at or after each half second
  EXPECT_TRUE(contains(out, "# t 0.501 s ramp 150 g, pwm ")) << out;
  EXPECT_TRUE(contains(out, "# t 2.001 s hold 300 g, pwm ")) << out;
  EXPECT_EQ(app_->failsafeTrips(), 0u) << "the sequence is the command source";
  EXPECT_EQ(app_->mode(), rr::Mode::kReady);
}

TEST_F(ReadRun, AnyKeyAbortsTheLiftoffAndStopsTheMotorsAtOnce) {
  // given: a lift-off in its hold phase
  storeFourMotors();
  boot();
  fake::feedInput("liftoff 300 500 5000\n");
  runFor(1500, true);
  ASSERT_GT(pulse(0), 1400);

  // when: one key, no newline
  fake::feedInput("x");
  app_->runOnce();

  // then
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), 1000) << "motor " << int(m);
  EXPECT_TRUE(contains(fake::output(), "# liftoff aborted by input: motors stopped"));
  EXPECT_EQ(app_->mode(), rr::Mode::kReady);
  runFor(6000);
  EXPECT_EQ(pulse(0), 1000) << "the sequence does not resume";
  EXPECT_FALSE(contains(fake::output(), "# liftoff done"));
}

TEST_F(ReadRun, LiftoffStopsWhenNoLineEndArrivesFor500Ms) {
  // given: a lift-off kept alive for a second
  storeFourMotors();
  boot();
  fake::feedInput("liftoff 300 500 5000\n");
  runFor(1000, true);
  ASSERT_GT(pulse(0), 1400);

  // when: the link goes quiet
  const uint32_t quiet_ms = fake::nowMs();
  uint32_t stopped_ms = 0;
  fake::setTickHook([&](uint32_t now) {
    if (stopped_ms == 0 && fake::pulseUs(0) == 1000) stopped_ms = now;
  });
  runFor(1000);

  // then: every motor stops 500 ms after the last line end (+ one 20 ms frame)
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), 1000) << "motor " << int(m);
  EXPECT_GE(stopped_ms - quiet_ms, 480u);
  EXPECT_LE(stopped_ms - quiet_ms, 521u);
  EXPECT_TRUE(contains(fake::output(), "# liftoff stopped: no line end for 500 ms")) << fake::output();
  EXPECT_EQ(app_->mode(), rr::Mode::kReady);
  EXPECT_EQ(app_->failsafeTrips(), 1u);
}

TEST_F(ReadRun, TheRestOfTheLineThatAbortedALiftoffIsNotACommand) {
  // given
  storeFourMotors();
  boot();
  fake::feedInput("liftoff 300 500 5000\n");
  runFor(1000, true);
  // when: "xf 2 450" arrives
  fake::feedInput("xf 2 450\n");
  runFor(500, true);
  // then
  for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), 1000) << "motor " << int(m);
  EXPECT_TRUE(contains(fake::output(), "error: ignored the rest of the line whose first key aborted"))
      << fake::output();
}

TEST_F(ReadRun, StrictModeRefusesSpinningWithoutAChecksumButAlwaysAllowsStopping) {
  storeFourMotors();
  boot();
  command("strict on");
  EXPECT_TRUE(contains(command("f 200"), "error: strict mode")) << fake::output();
  EXPECT_EQ(app_->motor(0).force_dg, 0);
  EXPECT_TRUE(contains(command("liftoff 200"), "error: strict mode"));
  EXPECT_EQ(app_->mode(), rr::Mode::kReady);
  command("f 200*74");  // XOR of "f 200"
  EXPECT_EQ(app_->motor(0).force_dg, 2000);
  EXPECT_FALSE(contains(command("f 2 0"), "error:")) << "stopping one motor needs no checksum";
  EXPECT_EQ(app_->motor(2).force_dg, 0);
  EXPECT_EQ(app_->motor(1).force_dg, 2000);
  command("f 0");
  EXPECT_EQ(app_->motor(0).force_dg, 0);
  EXPECT_TRUE(contains(command("divider 100000 22000"), "error: strict mode")) << "writes the EEPROM";
  EXPECT_FALSE(contains(command("divider"), "error:")) << "showing it writes nothing";
}

TEST_F(ReadRun, LiftoffIsRefusedWhileMotorsRun) {
  // given
  storeFourMotors();
  boot();
  command("f 200");
  const uint16_t before = pulse(0);

  // when
  const std::string out = command("liftoff 300");

  // then
  EXPECT_TRUE(contains(out, "error: motors are running; send stop first")) << out;
  EXPECT_EQ(app_->mode(), rr::Mode::kReady);
  EXPECT_EQ(pulse(0), before);
}

// ---------------------------------------------------------------------------------------------
// Bad input

TEST_F(ReadRun, BadInputGetsOneErrorLineAndChangesNothing) {
  const char* bad_lines[] = {
      "f",           "f 5001",       "f -1",          "f 4 100",     "f 1 2 3",
      "f abc",       "f 1 x",        "liftoff",       "liftoff 0",   "liftoff 300 70000",
      "liftoff 9 1 2 3", "rate 49",  "rate 401",      "rate",        "rate fast",
      "stream maybe", "stream",      "xyz",           "F 100",
      "divider 100000", "divider 100000 0", "divider 1 2 3", "divider 100000 22000",  // running
      "eeprom", "eeprom read", "eeprom crc 1", "eeprom dump all", "eeprom CRC", "eeprom2 crc",
      "strict", "strict maybe", "stop now", "status 1", "help me",
      "0123456789012345678901234567890123456789012345678901234567890",
  };
  // given: motors running at 200 g
  storeFourMotors();
  boot();
  command("f 200");
  uint16_t before[rr::kMotors];
  for (uint8_t m = 0; m < rr::kMotors; ++m) before[m] = pulse(m);

  for (const char* bad : bad_lines) {
    SCOPED_TRACE(bad);
    // when
    const std::string out = command(bad);

    // then: echo, exactly one "error: " line, the prompt; nothing else moved
    const std::vector<std::string> got = lines(out);
    ASSERT_EQ(got.size(), 3u) << out;
    EXPECT_EQ(got[1].rfind("error: ", 0), 0u) << out;
    EXPECT_EQ(got[2], "rr> ");
    for (uint8_t m = 0; m < rr::kMotors; ++m) EXPECT_EQ(pulse(m), before[m]);
    EXPECT_EQ(app_->motor(0).force_dg, 2000);
    EXPECT_EQ(fake::frameRateHz(), 50);
    EXPECT_EQ(app_->mode(), rr::Mode::kReady);
    EXPECT_FALSE(app_->isStreaming());
  }
}

TEST_F(ReadRun, HelpListsEveryCommand) {
  storeFourMotors();
  boot();
  const std::string out = command("help");
  for (const char* verb : {"f G", "f N G", "stop", "status", "liftoff G", "stream on|off", "rate HZ"}) {
    EXPECT_TRUE(contains(out, verb)) << verb << "\n" << out;
  }
}

// ---------------------------------------------------------------------------------------------
// Frame rate and stream

TEST_F(ReadRun, RateChangesTheEscFrameRateAndOneControlFrameRunsOnEachEscFrame) {
  struct Case {
    uint16_t hz;
  };
  for (const Case c : {Case{400}, Case{100}, Case{50}}) {
    SCOPED_TRACE(c.hz);
    // given
    fake::reset();
    fake::setTimeLimitMs(120000);
    fake::setAdcCounts(hal::kAdcBattery, kCountsV1);
    storeFourMotors();
    boot();

    // when
    const std::string out = command("rate " + std::to_string(c.hz));
    const uint32_t conversions_before = fake::adcConversions();
    const uint32_t hooks_before = fake::phaseHookCalls();
    const uint32_t writes_before = fake::escWriteAlls();
    runFor(1000);

    // then: the ESC timer runs at the new rate and every ESC frame (its phase hook) is one
    // control frame: the battery sampled once, the four pulses written once, none skipped
    EXPECT_TRUE(contains(out, "frame rate " + std::to_string(c.hz) + " Hz")) << out;
    EXPECT_EQ(fake::frameRateHz(), c.hz);
    const uint32_t frames = (fake::adcConversions() - conversions_before) /
                            fw::BatteryInput::kSamplesPerFrame;
    EXPECT_NEAR(static_cast<double>(frames), c.hz, 1.0);
    EXPECT_NEAR(static_cast<double>(fake::phaseHookCalls() - hooks_before), c.hz, 1.0);
    EXPECT_EQ(fake::escWriteAlls() - writes_before, fake::phaseHookCalls() - hooks_before);
    EXPECT_EQ(app_->framesSkipped(), 0);
  }
}

TEST_F(ReadRun, RateIsRefusedWhileMotorsRun) {
  storeFourMotors();
  boot();
  command("f 100");
  const std::string out = command("rate 400");
  EXPECT_TRUE(contains(out, "error: motors are running; send stop first")) << out;
  EXPECT_EQ(fake::frameRateHz(), 50);
}

TEST_F(ReadRun, StreamPrintsTenCsvLinesPerSecondWithThePulsesAndTheBattery) {
  // given
  storeFourMotors();
  boot();
  command("f 300");

  // when
  const std::string on = command("stream on");
  fake::takeOutput();
  runFor(1000, true);
  const std::string streamed = fake::takeOutput();
  command("stream off");
  runFor(500, true);

  // then
  EXPECT_TRUE(contains(on, "t_s,motor0_pwm_us,motor1_pwm_us,motor2_pwm_us,motor3_pwm_us,vbat_v"))
      << on;
  const tc::test::Pattern row(R"((\d+\.\d{3}),(\d+),(\d+),(\d+),(\d+),(\d+\.\d{3}))");
  for (const std::string& line : lines(on)) {  // the first row must not follow a prompt
    if (line.empty() || line == "stream on" || line.rfind("t_s,", 0) == 0) continue;
    EXPECT_TRUE(row.matches(line)) << "not a clean CSV row: " << line;
  }
  int rows = 0;
  for (const std::string& line : lines(streamed)) {
    if (line.empty()) continue;  // the keep-alive newlines' echo
    tc::test::Groups m;
    ASSERT_TRUE(row.matches(line, &m)) << "not a clean CSV row: " << line;
    ++rows;
    EXPECT_EQ(std::stoi(m[2]), pulse(0));
    EXPECT_EQ(std::stoi(m[5]), pulse(3));
    EXPECT_EQ(m[6], volts(mvFromCounts(kCountsV1)));
  }
  EXPECT_EQ(rows, 10) << streamed;
  EXPECT_FALSE(app_->isStreaming());
  const std::string after = fake::takeOutput();
  EXPECT_FALSE(row.foundIn(after)) << after;
}

}  // namespace
