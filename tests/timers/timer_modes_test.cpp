// The simulated ATmega2560's timers against the datasheet, one image per mode family
// (tests/timers/firmware): every pulse width and period measured on the pins, in cycles, is the
// datasheet's formula (normal/CTC: f = f_clk / (2 N (1 + TOP)) when toggling; fast PWM:
// f_clk / (N (1 + TOP)), high OCRnx + 1 ticks; phase correct and phase and frequency correct:
// f_clk / (2 N TOP), high 2 OCRnx ticks). A few simulated milliseconds each.
#include <gtest/gtest.h>

#include "pin_log.hpp"
#include "sim/console.hpp"

namespace {

using timers_test::image;
using timers_test::last;
using timers_test::PinLog;
using V = std::vector<int64_t>;

TEST(TimerModes, NormalAndCtcToggleClearSetAndForce) {
  TIMERS_REQUIRE_IMAGES();
  sim::Board board(image("timer_ctc"));
  PinLog log(board, {"D11", "D12", "D5", "D10", "D13", "D22", "D46", "D45"});
  board.runFor(0.008);
  // Timer1 mode 4, clk/8, OCR1A = 999: toggles every 8 * 1000 cycles
  EXPECT_EQ(last(log.intervals("D11"), 4), (V{8000, 8000, 8000, 8000}));
  // OC1B (OCR1B = 499) toggles 500 ticks after each OC1A toggle
  const auto& a = log.edges("D11");
  const auto& b = log.edges("D12");
  ASSERT_GE(a.size(), 3u);
  ASSERT_GE(b.size(), 3u);
  EXPECT_EQ((b.back().cycle - a.back().cycle) % 8000, 4000u);
  // Timer3 mode 12 (TOP = ICR3 = 199), clk/1; Timer2 mode 2 (OCR2A = 99), clk/32
  EXPECT_EQ(last(log.intervals("D5"), 3), (V{200, 200, 200}));
  EXPECT_EQ(last(log.intervals("D10"), 3), (V{3200, 3200, 3200}));
  // Timer0 normal, clk/64: OC0A toggles once per 256 ticks, as the overflow interrupt does
  // with a port pin, 127 ticks (from OCR0A = 128 to MAX) and the interrupt's latency later; the
  // latency varies by a cycle or two with the instruction the interrupt waits for
  EXPECT_EQ(last(log.intervals("D13"), 3), (V{16384, 16384, 16384}));
  for (int64_t interval : last(log.intervals("D22"), 3)) EXPECT_NEAR(interval, 16384, 2);
  const uint64_t handler = log.edges("D22").back().cycle;
  uint64_t match = 0;
  for (const auto& e : log.edges("D13"))
    if (e.cycle < handler) match = e.cycle;
  EXPECT_GE(handler - match, 127u * 64 + 5);  // the vector (5 cycles) and the handler's prologue
  EXPECT_LE(handler - match, 127u * 64 + 60);
  // Timer5 normal, clk/1: OC5A set at its match (1001 ticks), OC5B forced high before the
  // start, then cleared at its match (3001 ticks): 2000 cycles after OC5A rose
  ASSERT_EQ(log.edges("D46").size(), 1u);
  EXPECT_TRUE(log.edges("D46")[0].level);
  ASSERT_EQ(log.edges("D45").size(), 2u);
  EXPECT_TRUE(log.edges("D45")[0].level);
  EXPECT_EQ(log.edges("D45")[1].cycle - log.edges("D46")[0].cycle, 2000u);
}

TEST(TimerModes, FastPwmWithEveryTopAndOutputMode) {
  TIMERS_REQUIRE_IMAGES();
  sim::Board board(image("timer_fast_pwm"));
  PinLog log(board, {"D6", "D7", "D8", "D11", "D12", "D5", "D45", "D4", "D9", "D10"});
  board.runFor(0.008);
  // Timer4 mode 14, ICR4 = 3999, clk/8: a 32,000-cycle frame
  EXPECT_EQ(last(log.periods("D6"), 2), (V{32000, 32000}));
  EXPECT_EQ(last(log.highs("D6"), 2), (V{8000, 8000}));        // OCR4A 999: 1000 ticks
  EXPECT_EQ(last(log.highs("D7"), 2), (V{20000, 20000}));      // inverted, OCR4B 1499: low 1500 ticks
  EXPECT_EQ(last(log.highs("D8"), 2), (V{8, 8}));              // OCR4C 0: one tick
  // Timer1 mode 15, OCR1A = 999, clk/1: OC1A toggles at TOP (50 %), OC1B 250 ticks of 1000
  EXPECT_EQ(last(log.periods("D11"), 3), (V{2000, 2000, 2000}));
  EXPECT_EQ(last(log.highs("D11"), 3), (V{1000, 1000, 1000}));
  EXPECT_EQ(last(log.periods("D12"), 3), (V{1000, 1000, 1000}));
  EXPECT_EQ(last(log.highs("D12"), 3), (V{250, 250, 250}));
  // fixed TOPs: Timer3 8 bit at clk/64, Timer5 10 bit at clk/1, Timer0 8 bit at clk/64
  EXPECT_EQ(last(log.periods("D5"), 2), (V{16384, 16384}));
  EXPECT_EQ(last(log.highs("D5"), 2), (V{8192, 8192}));
  EXPECT_EQ(last(log.periods("D45"), 3), (V{1024, 1024, 1024}));
  EXPECT_EQ(last(log.highs("D45"), 3), (V{512, 512, 512}));
  EXPECT_EQ(last(log.periods("D4"), 2), (V{16384, 16384}));
  EXPECT_EQ(last(log.highs("D4"), 2), (V{4096, 4096}));
  // Timer2 mode 7, OCR2A = 199, clk/8; OC2A connected but its pin an input: silent
  EXPECT_EQ(last(log.periods("D9"), 3), (V{1600, 1600, 1600}));
  EXPECT_EQ(last(log.highs("D9"), 3), (V{400, 400, 400}));
  EXPECT_TRUE(log.edges("D10").empty());
  // every pulse, not only the last ones: the LED writes to PORTB and PORTH cut none
  for (const char* pin : {"D11", "D12", "D6", "D7", "D8", "D9"}) {
    const V h = log.highs(pin);
    ASSERT_GE(h.size(), 2u) << pin;
    for (std::size_t i = 1; i < h.size(); ++i) EXPECT_EQ(h[i], h.back()) << pin << " pulse " << i;
  }
}

TEST(TimerModes, PhaseCorrectWithEveryTopTheExtremesAndToggle) {
  TIMERS_REQUIRE_IMAGES();
  sim::Board board(image("timer_phase_correct"));
  PinLog log(board, {"D5", "D2", "D3", "D46", "D45", "D44", "D6", "D7", "D11", "D13", "D4", "D9"});
  board.runFor(0.007);
  // Timer3 mode 10 as MultiWii's motors: ICR3 = 16383, clk/1: 2 * 16383 cycles
  EXPECT_EQ(last(log.periods("D5"), 2), (V{32766, 32766}));
  EXPECT_EQ(last(log.highs("D5"), 2), (V{16000, 16000}));  // 1000 us
  EXPECT_EQ(last(log.highs("D2"), 2), (V{8000, 8000}));
  EXPECT_EQ(last(log.highs("D3"), 2), (V{4000, 4000}));
  // Timer5 mode 10, ICR5 = 1000, clk/8: OCR = BOTTOM low, OCR = TOP high, inverted 300
  EXPECT_TRUE(log.edges("D46").empty());
  ASSERT_EQ(log.edges("D45").size(), 1u);
  EXPECT_TRUE(log.edges("D45")[0].level);
  EXPECT_EQ(last(log.periods("D44"), 2), (V{16000, 16000}));
  EXPECT_EQ(last(log.highs("D44"), 2), (V{16000 - 4800, 16000 - 4800}));
  // Timer4 mode 11, OCR4A = 1000 = TOP, clk/8: OC4A toggles at TOP, OC4B 2 * 250 ticks
  EXPECT_EQ(last(log.periods("D6"), 1), (V{32000}));
  EXPECT_EQ(last(log.highs("D6"), 1), (V{16000}));
  EXPECT_EQ(last(log.periods("D7"), 2), (V{16000, 16000}));
  EXPECT_EQ(last(log.highs("D7"), 2), (V{4000, 4000}));
  // Timer1 mode 1 (8 bit), clk/64: 510 ticks
  EXPECT_EQ(last(log.periods("D11"), 2), (V{32640, 32640}));
  EXPECT_EQ(last(log.highs("D11"), 2), (V{8192, 8192}));
  // Timer0 mode 5, OCR0A = 100, clk/64: OC0A toggles at TOP, OC0B 2 * 25 ticks
  EXPECT_EQ(last(log.periods("D13"), 3), (V{25600, 25600, 25600}));
  EXPECT_EQ(last(log.highs("D13"), 3), (V{12800, 12800, 12800}));
  EXPECT_EQ(last(log.periods("D4"), 3), (V{12800, 12800, 12800}));
  EXPECT_EQ(last(log.highs("D4"), 3), (V{3200, 3200, 3200}));
  // Timer2 mode 1, clk/8
  EXPECT_EQ(last(log.periods("D9"), 3), (V{4080, 4080, 4080}));
  EXPECT_EQ(last(log.highs("D9"), 3), (V{1600, 1600, 1600}));
}

TEST(TimerModes, PhaseAndFrequencyCorrect) {
  TIMERS_REQUIRE_IMAGES();
  sim::Board board(image("timer_pfc"));
  PinLog log(board, {"D46", "D11", "D12"});
  board.runFor(0.002);
  EXPECT_EQ(last(log.periods("D46"), 3), (V{4000, 4000, 4000}));  // ICR5 2000, clk/1
  EXPECT_EQ(last(log.highs("D46"), 3), (V{1000, 1000, 1000}));
  EXPECT_EQ(last(log.periods("D11"), 3), (V{1600, 1600, 1600}));  // toggles at TOP = OCR1A = 400
  EXPECT_EQ(last(log.highs("D11"), 3), (V{800, 800, 800}));
  EXPECT_EQ(last(log.periods("D12"), 3), (V{800, 800, 800}));
  EXPECT_EQ(last(log.highs("D12"), 3), (V{200, 200, 200}));
}

// PB7 (D13) carries OC0A and OC1C; with both connected the output compare modulator combines
// them: AND while PORTB7 is 0, OR while it is 1.
TEST(TimerModes, TheOutputCompareModulatorOnPb7) {
  TIMERS_REQUIRE_IMAGES();
  sim::Board board(image("timer_pfc"));
  PinLog log(board, {"D13"});
  auto step = [&](const char* command) {
    const std::size_t before = log.edges("D13").size();
    const std::size_t from = board.output().size();
    board.sendText(command);
    board.runUntil([&] { return board.output().find("ok", from) != std::string::npos; }, sim::secondsToCycles(0.01));
    board.runFor(0.0005);  // the buffered OCR1C and the new level settle
    const std::size_t settled = log.edges("D13").size();
    board.runFor(0.0005);
    return std::make_pair(settled - before, log.edges("D13").size() - settled);
  };
  // OC1C constantly high (OCR1C = TOP), AND: D13 is OC0A, 128 of 256 cycles
  step("m");
  EXPECT_EQ(last(log.highs("D13"), 3), (V{128, 128, 128}));
  EXPECT_EQ(last(log.periods("D13"), 3), (V{256, 256, 256}));
  // OR with a constant high: high, no edge
  EXPECT_EQ(step("o").second, 0u);
  EXPECT_TRUE(board.ports().level('B', 7));
  // OC1C constantly low, OR: OC0A again
  EXPECT_GT(step("z").second, 20u);
  EXPECT_EQ(last(log.highs("D13"), 3), (V{128, 128, 128}));
  // AND with a constant low: low, no edge
  EXPECT_EQ(step("a").second, 0u);
  EXPECT_FALSE(board.ports().level('B', 7));
}

// The widths (or intervals) of a sequence: `before` repeated, then what is left, which must be
// `across` (if given) followed by `after` repeated at least twice.
void expectSwitch(const V& seen, int64_t before, const V& across, int64_t after, const char* pin) {
  std::size_t i = 0;
  while (i < seen.size() && seen[i] == before) ++i;
  ASSERT_GE(i, 3u) << pin;
  for (int64_t w : across) {
    ASSERT_LT(i, seen.size()) << pin;
    EXPECT_EQ(seen[i++], w) << pin;
  }
  ASSERT_GE(seen.size() - i, 2u) << pin;
  for (; i < seen.size(); ++i) EXPECT_EQ(seen[i], after) << pin << " item " << i;
}

TEST(TimerModes, DoubleBufferingAtTopAndBottomAndCtcAtOnce) {
  TIMERS_REQUIRE_IMAGES();
  sim::Board board(image("timer_buffering"));
  PinLog log(board, {"D6", "D5", "D46", "D11"});
  ASSERT_TRUE(board.runUntil([&] { return board.output().find("done") != std::string::npos; },
                             sim::secondsToCycles(0.02)));
  board.runFor(0.045);
  // fast PWM: the pulse in progress keeps 2000 ticks, then 500 (simavr 1.6: one of 4500)
  expectSwitch(log.highs("D6"), 16000, {}, 4000, "D6");
  // phase correct, updated at TOP: the pulse around BOTTOM stays 2 x 600 ticks
  expectSwitch(log.highs("D5"), 9600, {}, 3200, "D5");
  // phase and frequency correct, updated at BOTTOM: that pulse is 600 + 200 ticks
  expectSwitch(log.highs("D46"), 9600, {6400}, 3200, "D46");
  // CTC: a new OCR1A below TCNT1 is missed until the counter has gone round
  expectSwitch(log.intervals("D11"), 8000, {(65536 + 501) * 8}, 501 * 8, "D11");
}

}  // namespace
