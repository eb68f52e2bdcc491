// Pins in, and what the simulator does not model: input capture (ICES, the noise canceller),
// the external interrupts beside a PWM on INT4/INT5 (level and edge sense, flags, no polling),
// the loud stop for an unmodelled timer setting.
#include <gtest/gtest.h>


#include "pin_log.hpp"
#include "sim/console.hpp"
#include "sim/timers.hpp"
#include "text_match.hpp"

namespace {

using timers_test::image;
using timers_test::PinDriver;
using timers_test::PinLog;

// The "cN VALUE" lines the capture image printed.
std::vector<long> captures(const std::string& out, int timer) {
  std::vector<long> v;
  const tc::test::Pattern line("c" + std::to_string(timer) + " (\\d+)");
  for (const tc::test::Groups& m : line.allIn(out)) v.push_back(std::stol(m[1]));
  return v;
}

TEST(TimerPins, InputCaptureTakesTheCounterAtTheChosenEdge) {
  TIMERS_REQUIRE_IMAGES();
  sim::Board board(image("timer_capture"));
  ASSERT_TRUE(board.runUntil([&] { return board.output().find("ready") != std::string::npos; },
                             sim::secondsToCycles(0.01)));
  const uint64_t t0 = board.cycle() + 1000;
  // ICP4 (D49): Timer4 at clk/8, rising edges 800 and 2400 cycles apart: 100 and 300 ticks;
  // the falling edges between are not captured
  PinDriver icp4(board, "D49");
  icp4.schedule({{t0, true}, {t0 + 400, false}, {t0 + 800, true}, {t0 + 1200, false}, {t0 + 3200, true}});
  // ICP5 (D48): Timer5 at clk/1, falling edges through the noise canceller: a 3-cycle low
  // pulse is dropped, a 5-cycle one is not; the capture comes 4 cycles after the edge
  PinDriver icp5(board, "D48");
  icp5.setNow(true);
  std::vector<long> counter_at_edge;
  icp5.on_change = [&](uint64_t when, uint64_t now) {
    const long count = board.timers().timer(5).count();  // at `now`, clk/1
    counter_at_edge.push_back(count - static_cast<long>(now - when));
  };
  icp5.schedule({{t0 + 100, false}, {t0 + 103, true}, {t0 + 2000, false}, {t0 + 2005, true},
                 {t0 + 3000, false}, {t0 + 3500, true}});
  board.runFor(0.01);  // the edges, then the lines at 115200 baud
  const std::vector<long> c4 = captures(board.output(), 4);
  ASSERT_EQ(c4.size(), 3u) << board.output();
  EXPECT_EQ(c4[1] - c4[0], 100);
  EXPECT_EQ(c4[2] - c4[1], 300);
  const std::vector<long> c5 = captures(board.output(), 5);
  ASSERT_EQ(c5.size(), 2u) << board.output();
  ASSERT_EQ(counter_at_edge.size(), 6u);
  EXPECT_EQ(c5[0], (counter_at_edge[2] + 4) % 65536);
  EXPECT_EQ(c5[1], (counter_at_edge[4] + 4) % 65536);
}

struct IntCounts {
  long int4 = -1, int2 = -1, int3 = -1, intf7 = -1;
};

IntCounts askCounts(sim::Board& board) {
  const std::size_t from = board.output().size();
  board.sendText("p");
  board.runUntil([&] { return board.output().find("intf7", from) != std::string::npos &&
                              board.output().find('\n', board.output().find("intf7", from)) != std::string::npos; },
                 sim::secondsToCycles(0.01));
  IntCounts c;
  tc::test::Groups m;
  const std::string tail = board.output().substr(from);
  if (tc::test::Pattern("int4 (\\d+) int2 (\\d+) int3 (\\d+) intf7 (\\d)").foundIn(tail, &m)) {
    c.int4 = std::stol(m[1]);
    c.int2 = std::stol(m[2]);
    c.int3 = std::stol(m[3]);
    c.intf7 = std::stol(m[4]);
  }
  return c;
}

TEST(TimerPins, ExternalInterruptsBesideAPwmOnTheirPinsWithoutPolling) {
  TIMERS_REQUIRE_IMAGES();
  sim::Board board(image("ext_int"));
  PinLog log(board, {"D2"});
  PinDriver int2(board, "D19"), int3(board, "D18"), int7(board, "PE7");
  int2.setNow(true);
  int3.setNow(true);
  int7.setNow(true);
  // given the PWM holding INT4/INT5 low for 94 % of each period, the CPU asleep
  const uint64_t sleeps0 = board.sleeps();
  board.runFor(0.010);
  // then the idle sleep is broken by events only (simavr 1.6 polled each low INT pin every
  // cycle: some 150,000 one-cycle sleeps in these 10 ms)
  EXPECT_LT(board.sleeps() - sleeps0, 2000u);
  // INT4, any edge, counts the PWM's own edges on its pin
  const std::size_t edges = log.edges("D2").size();
  IntCounts c = askCounts(board);
  EXPECT_GE(c.int4, static_cast<long>(edges));
  EXPECT_LE(c.int4, static_cast<long>(log.edges("D2").size()));
  EXPECT_GE(edges, 8u);  // two per 2.05 ms period
  // INT3, falling edge: three falls, three interrupts
  const uint64_t t = board.cycle() + 100;
  int3.schedule({{t, false}, {t + 50, true}, {t + 100, false}, {t + 150, true}, {t + 200, false}, {t + 250, true}});
  // INT2, low level: requested again after every return while the pin stays low; the handler
  // turns it off at 100
  int2.setNow(false);
  board.sendText("l");
  board.runFor(0.006);  // the firmware reads its UART when an interrupt wakes it
  int2.setNow(true);
  // INT7, falling edge, disabled: only its flag, cleared by writing a one (and by SBI)
  int7.schedule({{board.cycle() + 10, false}});
  board.runFor(0.0005);
  c = askCounts(board);
  EXPECT_EQ(c.int3, 3);
  EXPECT_EQ(c.int2, 100);
  EXPECT_EQ(c.intf7, 1);
  board.sendText("x");
  EXPECT_EQ(askCounts(board).intf7, 0);
  int7.schedule({{board.cycle() + 10, true}, {board.cycle() + 20, false}});
  board.runFor(0.0005);
  EXPECT_EQ(askCounts(board).intf7, 1);
  board.sendText("s");
  EXPECT_EQ(askCounts(board).intf7, 0);
}

// Runs the unmodelled-settings image with one command; returns the error, or "" (and `ok`).
std::string stopFor(const std::string& command, bool* ok = nullptr) {
  sim::Board board(image("timer_unmodelled"));
  board.runUntil([&] { return board.output().find("go") != std::string::npos; }, sim::secondsToCycles(0.01));
  board.sendText(command);
  try {
    board.runFor(0.002);
  } catch (const sim::BoardError& e) {
    return e.what();
  }
  if (ok) *ok = board.output().find("ok") != std::string::npos;
  return "";
}

TEST(TimerPins, WhatIsNotModelledStopsTheRunNamingTimerAndSetting) {
  TIMERS_REQUIRE_IMAGES();
  const std::string external = stopFor("x");
  EXPECT_NE(external.find("Timer1: CS12:0 = 7 clocks it from its pin T1 (PD6)"), std::string::npos) << external;
  EXPECT_NE(external.find("external clock"), std::string::npos) << external;
  const std::string async = stopFor("a");
  EXPECT_NE(async.find("Timer2: asynchronous operation (ASSR = 0x20"), std::string::npos) << async;
  const std::string reserved = stopFor("r");
  EXPECT_NE(reserved.find("Timer3: waveform generation mode 13 is reserved"), std::string::npos) << reserved;
  EXPECT_NE(reserved.find("TCCR3B = 0x19"), std::string::npos) << reserved;
  const std::string com = stopFor("b");
  EXPECT_NE(com.find("Timer0: COMB = 01 is reserved in fast PWM mode"), std::string::npos) << com;
  // a reserved mode that no timer clock edge sees is not an error
  bool ok = false;
  EXPECT_EQ(stopFor("t", &ok), "");
  EXPECT_TRUE(ok);
}

}  // namespace
