// Any ESC pins (issue 25 item 2): Mega pin names, Board::setEscPins, the airframe's esc_pins and
// `--esc-pins` on the command line. Pulses are timed from the pins' edges, whatever drives them.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <string>

#include "pin_log.hpp"
#include "sim/airframe.hpp"
#include "sim/console.hpp"
#include "sim/pin_names.hpp"

namespace {

using timers_test::image;

TEST(EscPins, MegaPinNamesAndTheirErrors) {
  EXPECT_EQ(sim::megaPinName(sim::parseMegaPin("D3")), "D3 (PE5)");
  EXPECT_EQ(sim::megaPinName(sim::parseMegaPin("a8")), "D62 (PK0)");
  EXPECT_EQ(sim::megaPinName(sim::parseMegaPin("PE7")), "PE7");  // not on a header
  EXPECT_EQ(sim::megaPinName(sim::parseMegaPin("ph3")), "D6 (PH3)");
  for (const char* bad : {"D70", "A16", "PI3", "PE8", "E5", "", "D-1", "D0x"}) {
    try {
      sim::parseMegaPin(bad);
      ADD_FAILURE() << bad << " was taken";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("D0..D69, A0..A15"), std::string::npos) << e.what();
    }
  }
  const auto pins = sim::parseEscPins("D3,D5,D6,D2");
  EXPECT_EQ(pins[0].port, 'E');
  EXPECT_EQ(pins[0].bit, 5);
  EXPECT_EQ(pins[3].arduino, 2);
  auto error = [](const std::string& list) {
    try {
      sim::parseEscPins(list);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error("D3,D5,D6,PE5"),
            "--esc-pins D3,D5,D6,PE5: D3 (PE5) is named twice (ESC 0 and ESC 3); each motor needs its own pin");
  EXPECT_NE(error("D3,D5,D6").find("name 4 pins, ESC 0..3"), std::string::npos);
  EXPECT_NE(error("D3,D5,D6,D2,D7").find("name 4 pins, ESC 0..3"), std::string::npos);
  EXPECT_NE(error("D3,D5,D6,D99").find("pin 'D99' is not a Mega 2560 pin"), std::string::npos);
  // the board table is the default
  const auto table = sim::boardEscPins();
  EXPECT_EQ(table[0].arduino, hal::kEscPins[0].arduino_pin);
  EXPECT_EQ(table[3].arduino, hal::kEscPins[3].arduino_pin);
}

TEST(EscPins, PulsesOnTimerOutputsInAnyModeAndOnAPortPinTheFirmwareToggles) {
  TIMERS_REQUIRE_IMAGES();
  // given MultiWii's motor timer (phase-correct, ICR TOP) on D5 D2 D3, and Timer4 mode 11 on D7
  sim::Board board(image("timer_phase_correct"));
  board.setEscPins(sim::parseEscPins("D5,D2,D3,D7"));
  board.runFor(0.01);
  // then: each width to the cycle (2 OCRnx ticks at clk/1 or clk/8)
  EXPECT_DOUBLE_EQ(board.escPulseUs(0), 1000.0);
  EXPECT_DOUBLE_EQ(board.escPulseUs(1), 500.0);
  EXPECT_DOUBLE_EQ(board.escPulseUs(2), 250.0);
  EXPECT_DOUBLE_EQ(board.escPulseUs(3), 250.0);
  EXPECT_DOUBLE_EQ(board.escPin(0).last_period_us, 32766 / 16.0);
  // a pin the firmware toggles in an interrupt handler (PINA write): timed the same way
  sim::Board soft(image("timer_ctc"));
  soft.setEscPins(sim::parseEscPins("D22,D11,D13,D10"));
  soft.runFor(0.01);
  // 256 ticks at clk/64, give or take the interrupt's latency (a cycle or two, 0.0625 us each)
  EXPECT_NEAR(soft.escPulseUs(0, 0.01), 1024.0, 0.13);
  EXPECT_DOUBLE_EQ(soft.escPulseUs(1), 500.0);
  // two channels on one pin are refused
  const hal::MegaPin d22 = sim::parseMegaPin("D22"), d11 = sim::parseMegaPin("D11");
  EXPECT_THROW(soft.setEscPins({d22, d11, d22, d11}), std::invalid_argument);
}

TEST(EscPins, TheAirframeFliesOnTheNamedPins) {
  TIMERS_REQUIRE_IMAGES();
  sim::AirframeOptions o;
  o.imu = false;
  o.esc_pins = sim::parseEscPins("D5,D2,D3,D7");
  sim::AirframeRig rig(image("timer_phase_correct"), o);
  rig.run(0.05);
  EXPECT_DOUBLE_EQ(rig.board().escPulseUs(0), 1000.0);
  EXPECT_NE(rig.describe().find("ESC pins D5 (PE3) D2 (PE4) D3 (PE5) D7 (PH4)"), std::string::npos)
      << rig.describe();
}

TEST(EscPins, CommandLineRefusesAPinNamedTwice) {
  TIMERS_REQUIRE_IMAGES();
  const std::string cmd = std::string(THRUSTCAL_BIN) + " sim run --elf " + image("timer_ctc") +
                          " --duration 0.01 --esc-pins D2,D6,D3,D2 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) out += buf;
  const int status = pclose(p);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("D2 (PE4) is named twice (ESC 0 and ESC 3)"), std::string::npos) << out;
}

}  // namespace

namespace {

// read_run's `rate` (hal::Esc::setFrameRate) on the chip-true timers: the frames go on at the
// new rate with no gap. Writing TCNTn = TOP in mode 14 would miss TOP (the datasheet's warning)
// and leave every ESC without a pulse for some 30 ms.
TEST(EscPins, ReadRunChangesItsFrameRateWithoutAGap) {
  const std::string elf = READ_RUN_ELF;
  if (elf.empty() || !std::ifstream(elf).good()) GTEST_SKIP() << "no read_run image at '" << elf << "'";
  sim::Board board(elf);
  timers_test::PinLog log(board, {"D6", "D11"});
  sim::Console console(board, "rr> ");
  console.waitPrompt(3.0);
  for (const int hz : {400, 50}) {
    const auto lines = console.command("rate " + std::to_string(hz), 0.5);
    board.runFor(0.1);
    const double frame_cycles = 16e6 / hz;
    for (const char* pin : {"D6", "D11"}) {
      const auto periods = log.periods(pin);
      ASSERT_FALSE(periods.empty()) << pin;
      EXPECT_NEAR(periods.back(), frame_cycles, 1) << pin << " at " << hz << " Hz";
    }
  }
  // no frame longer than the slowest one (50 Hz) and every pulse the 1000 us stop pulse
  for (const char* pin : {"D6", "D11"}) {
    for (int64_t p : log.periods(pin)) EXPECT_LE(p, 320000) << pin;
    for (int64_t h : log.highs(pin)) EXPECT_EQ(h, 16000) << pin;
  }
}

}  // namespace
