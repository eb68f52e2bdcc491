// The simavr harness wired to a probe program (tests/sim/probe/probe.c): ESC pulse widths from
// compare-output edges, ADC millivolts, UART pacing and expect(), EEPROM in and out, speed.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "sim/board.hpp"
#include "sim/console.hpp"
#include "hex/intel_hex.hpp"
#include "sim/pty_bridge.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>

namespace {

class ProbeBoard : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string(SIM_PROBE_ELF).empty()) GTEST_SKIP() << "avr-gcc not found: no probe image";
    board = std::make_unique<sim::Board>(SIM_PROBE_ELF);
    console = std::make_unique<sim::Console>(*board, "p> ");
    console->waitPrompt(0.1);
  }
  std::unique_ptr<sim::Board> board;
  std::unique_ptr<sim::Console> console;
};

struct PulseCase {
  int channel;
  int set_us;
};

void PrintTo(const PulseCase& c, std::ostream* os) { *os << "pwm " << c.channel << " " << c.set_us; }

class ProbePulses : public ProbeBoard, public ::testing::WithParamInterface<PulseCase> {};

TEST_P(ProbePulses, EscPulseWidthIsMeasuredFromPinEdgesWithinOneTick) {
  // given
  const auto c = GetParam();
  console->command(fmt::format("pwm {} {}", c.channel, c.set_us));
  // when: a few 50 Hz frames pass
  board->runFor(0.1);
  // then: the probe sets OCR = 2 * us - 1, so the pin is high OCR + 1 ticks of 0.5 us
  EXPECT_NEAR(board->escPulseUs(c.channel), c.set_us, 0.1);
  EXPECT_NEAR(board->escPin(c.channel).last_period_us, 20000.5, 1.0);
}

INSTANTIATE_TEST_SUITE_P(Table, ProbePulses,
                         ::testing::Values(PulseCase{0, 1000}, PulseCase{1, 1234}, PulseCase{2, 1680},
                                           PulseCase{3, 2000}),
                         [](const ::testing::TestParamInfo<PulseCase>& info) {
                           return fmt::format("esc{}_{}us", info.param.channel, info.param.set_us);
                         });

TEST_F(ProbeBoard, PulseListenersHearEveryFrame) {
  int pulses = 0;
  board->addPulseListener([&](int ch, double, double) { pulses += ch == 0; });
  board->runFor(1.0);
  EXPECT_NEAR(pulses, 50, 1);
}

TEST_F(ProbeBoard, AdcReadsTheInjectedMillivoltsScaledBy1023) {
  board->setAdcSource([](int channel) { return channel == 0 ? 2500.0 : 1234.0; });
  auto a0 = console->command("adc 0");
  auto a1 = console->command("adc 1");
  ASSERT_EQ(a0.size(), 1u);
  EXPECT_EQ(a0[0], "adc 0 511");  // floor(2500 * 1023 / 5000)
  EXPECT_EQ(a1[0], "adc 1 252");  // floor(1234 * 1023 / 5000)
}

TEST_F(ProbeBoard, ExpectReturnsRegexGroups) {
  board->runFor(0.25);
  console->send("ms");
  auto g = console->expect(R"(^ms (\d+)$)", 0.1);
  ASSERT_EQ(g.size(), 2u);
  EXPECT_NEAR(std::stod(g[1]), 250, 2);
}

TEST_F(ProbeBoard, ExpectTimeoutShowsTheConsoleTail) {
  console->command("er 7");
  try {
    console->expect("never printed", 0.05);
    FAIL();
  } catch (const sim::ExpectTimeout& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("/never printed/ within 0.05 s"), std::string::npos) << what;
    EXPECT_NE(what.find("| ee 7 255"), std::string::npos) << what;
  }
}

TEST_F(ProbeBoard, LongInputIsPacedSoNoByteIsLost) {
  // given: 10 commands queued at once (160 bytes, far more than simavr's 64-byte FIFO)
  std::string many;
  for (int i = 0; i < 10; ++i) many += fmt::format("ee {} {}\r", 100 + i, i + 1);
  board->sendText(many);
  // when
  board->runFor(0.1);
  // then: every byte arrived
  const auto image = board->eeprom();
  for (int i = 0; i < 10; ++i) EXPECT_EQ(image[100 + i], i + 1) << i;
}

TEST_F(ProbeBoard, EepromImageGoesInAndOutThroughIntelHex) {
  // given: an image with a pattern, loaded the way --eeprom FILE does
  std::vector<uint8_t> image(sim::kEepromBytes, 0xFF);
  image[4095] = 0x5A;
  board->setEeprom(hex::parseIntelHex(hex::formatIntelHex(image), sim::kEepromBytes));
  // when the firmware reads and writes
  auto r = console->command("er 4095");
  console->command("ee 3 200");
  // then
  EXPECT_EQ(r.at(0), "ee 4095 90");
  const auto out = board->eeprom();
  EXPECT_EQ(out[3], 200);
  EXPECT_EQ(out[4095], 0x5A);
  EXPECT_EQ(out[0], 0xFF);
}

TEST_F(ProbeBoard, TickHookRunsEveryMillisecondOfSimulatedTime) {
  int ticks = 0;
  double last_t = 0;
  board->setTickHook([&](double t) { ++ticks; last_t = t; });
  const double t0 = board->timeS();
  board->runFor(0.5);
  EXPECT_NEAR(ticks, 500, 1);
  EXPECT_NEAR(last_t, t0 + 0.5, 0.0011);
}

TEST_F(ProbeBoard, StoppedFirmwareIsReportedNotHung) {
  console->send("halt");
  EXPECT_THROW(board->runFor(0.1), sim::BoardError);
}

TEST_F(ProbeBoard, PseudoTerminalCarriesKeystrokesInAndOutputOut) {
  // given: the board on a pty, opened the way screen/picocom would
  sim::PtyBridge pty(*board);
  ASSERT_EQ(pty.path().rfind("/dev/pts/", 0), 0u) << pty.path();
  const int fd = ::open(pty.path().c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  ASSERT_GE(fd, 0);
  // when: a person types a command
  ASSERT_EQ(::write(fd, "er 5\r", 5), 5);
  std::atomic<bool> stop{false};
  pty.run(0, 0.05, stop);
  // then: the echo, the answer and the next prompt come back
  std::string got;
  char buf[256];
  for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;) got.append(buf, static_cast<std::size_t>(n));
  ::close(fd);
  EXPECT_NE(got.find("er 5\r\nee 5 255\r\np> "), std::string::npos) << got;
}

TEST_F(ProbeBoard, PseudoTerminalPacesSimulatedTimeToTheWallClock) {
  sim::PtyBridge pty(*board);
  std::atomic<bool> stop{false};
  const auto t0 = std::chrono::steady_clock::now();
  pty.run(10.0, 1.0, stop);  // 1 s simulated at 10x real time
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(wall, 0.095);  // never faster than asked (sleeps only; an upper bound would be flaky)
}

TEST(Board, MissingImageSaysWhatToDo) {
  try {
    sim::Board b("/nonexistent/gather_store.elf");
    FAIL();
  } catch (const sim::BoardError& e) {
    EXPECT_NE(std::string(e.what()).find("build it first"), std::string::npos);
  }
}

TEST(Board, AFileThatIsNeitherElfNorHexSaysBoth) {
  // given: a ".elf" that is text (a truncated download, a wrong file saved under the name)
  const std::string path = ::testing::TempDir() + "not_an_image.elf";
  std::ofstream(path) << "<html>404 Not Found</html>\n";
  try {
    sim::Board b(path);
    FAIL() << "a text file was loaded as firmware";
  } catch (const sim::BoardError& e) {
    const std::string what = e.what();
    // then: the error names both formats, what is wrong as HEX, and what to give instead
    EXPECT_NE(what.find("neither an AVR ELF file"), std::string::npos) << what;
    EXPECT_NE(what.find(":1: record does not start with ':'"), std::string::npos) << what;
    EXPECT_NE(what.find("avr-objcopy -O ihex"), std::string::npos) << what;
  }
  std::remove(path.c_str());
}

}  // namespace
