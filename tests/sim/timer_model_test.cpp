// sim::TimerModel (tools/sim/include/sim/timer_model.hpp), in timer ticks, without simavr: the
// waveforms against the datasheet's formulas, its special cases, and the fast path (skipping
// quiet ticks) against ticking every tick.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "sim/timer_model.hpp"

namespace {

using sim::TimerModel;
using sim::TimerTick;

// OCnx over `ticks` ticks: the level after each tick.
std::vector<bool> trace(TimerModel& m, int ch, int ticks) {
  std::vector<bool> levels;
  for (int i = 0; i < ticks; ++i) {
    m.tick();
    levels.push_back(m.output(ch));
  }
  return levels;
}

struct Wave {
  int high = -1, period = -1;  // ticks, from the last complete cycle; -1: no edge
};

Wave measure(const std::vector<bool>& v) {
  std::vector<int> rises, falls;
  for (std::size_t i = 1; i < v.size(); ++i) {
    if (!v[i - 1] && v[i]) rises.push_back(static_cast<int>(i));
    if (v[i - 1] && !v[i]) falls.push_back(static_cast<int>(i));
  }
  Wave w;
  if (rises.size() < 2) return w;
  const int r0 = rises[rises.size() - 2], r1 = rises.back();
  w.period = r1 - r0;
  for (int f : falls)
    if (f > r0 && f <= r1) w.high = f - r0;
  return w;
}

// The lengths of the complete high runs.
std::vector<int> highRuns(const std::vector<bool>& v) {
  std::vector<int> runs;
  int start = -1;
  for (std::size_t i = 1; i < v.size(); ++i) {
    if (!v[i - 1] && v[i]) start = static_cast<int>(i);
    if (v[i - 1] && !v[i] && start >= 0) runs.push_back(static_cast<int>(i) - start);
  }
  return runs;
}

// Timer n set up as the firmware would: mode, then compare values, then COM.
TimerModel make(bool wide, uint8_t wgm, uint16_t icr, uint16_t ocra, uint16_t ocrb, uint8_t com_a,
                uint8_t com_b) {
  TimerModel m(wide, wide ? 3 : 2);
  m.setWgm(wgm);
  m.writeIcr(icr);
  m.writeOcr(0, ocra);
  m.writeOcr(1, ocrb);
  m.setCom(0, com_a);
  m.setCom(1, com_b);
  return m;
}

TEST(TimerModel, FastPwmIsHighForOcrPlusOneTicksOfTopPlusOne) {
  // given mode 14 (TOP = ICRn) as hal/avr/esc.cpp sets it: 50 Hz at clk/8, 1000 us
  TimerModel m = make(true, 14, 39999, 1999, 2999, 2, 3);
  // when / then: f = f_clk / (N (1 + TOP)), high OCR + 1 ticks (non-inverting)
  std::vector<bool> a = trace(m, 0, 120000);
  EXPECT_EQ(measure(a).period, 40000);
  EXPECT_EQ(measure(a).high, 2000);
}

TEST(TimerModel, FastPwmInvertedAndTheExtremes) {
  TimerModel inverted = make(true, 14, 999, 0, 299, 2, 3);
  const std::vector<bool> b = trace(inverted, 1, 4000);
  std::vector<bool> low(b.size());
  for (std::size_t i = 0; i < b.size(); ++i) low[i] = !b[i];
  EXPECT_EQ(measure(low).high, 300);  // low for OCR + 1 ticks
  TimerModel spike = make(true, 14, 999, 0, 0, 2, 0);
  EXPECT_EQ(measure(trace(spike, 0, 4000)).high, 1);  // OCR = BOTTOM: a one-tick spike
  TimerModel full = make(true, 14, 999, 999, 0, 2, 0);
  trace(full, 0, 1000);
  for (bool level : trace(full, 0, 3000)) ASSERT_TRUE(level);  // OCR = TOP: constantly high
}

TEST(TimerModel, PhaseCorrectIsHighForTwoOcrTicksOfTwoTop) {
  // given mode 10 (TOP = ICRn) as MultiWii runs its motors: ICR 16383, clk/1
  TimerModel m = make(true, 10, 16383, 8000, 12000, 2, 2);
  // then: f = f_clk / (2 N TOP), high 2 OCR ticks
  const std::vector<bool> a = trace(m, 0, 120000);
  EXPECT_EQ(measure(a).period, 2 * 16383);
  EXPECT_EQ(measure(a).high, 2 * 8000);
  TimerModel zero = make(true, 10, 500, 0, 500, 2, 2);
  for (bool level : trace(zero, 0, 3000)) ASSERT_FALSE(level);  // OCR = BOTTOM: low
  TimerModel top = make(true, 10, 500, 0, 500, 2, 2);
  trace(top, 1, 600);
  for (bool level : trace(top, 1, 3000)) ASSERT_TRUE(level);  // OCR = TOP: high
}

TEST(TimerModel, EightBitPhaseCorrectAndFastPwmAsTheArduinoCoreSetsThem) {
  // Timer0/2: phase-correct 8 bit (mode 1), f = f_clk / (N 510); fast PWM (mode 3) / (N 256)
  TimerModel pc = make(false, 1, 0, 100, 200, 2, 2);
  EXPECT_EQ(measure(trace(pc, 1, 3000)).period, 510);
  TimerModel pc2 = make(false, 1, 0, 100, 200, 2, 2);
  EXPECT_EQ(measure(trace(pc2, 0, 3000)).high, 200);
  TimerModel fast = make(false, 3, 0, 100, 200, 2, 2);
  const Wave w = measure(trace(fast, 0, 3000));
  EXPECT_EQ(w.period, 256);
  EXPECT_EQ(w.high, 101);
}

TEST(TimerModel, CtcToggleGivesHalfTheCompareFrequency) {
  // mode 4 (TOP = OCRnA), COMnA = 01: f = f_clk / (2 N (1 + OCRnA))
  TimerModel m = make(true, 4, 0, 249, 100, 1, 1);
  const Wave a = measure(trace(m, 0, 5000));
  EXPECT_EQ(a.period, 2 * 250);
  EXPECT_EQ(a.high, 250);
  TimerModel b = make(true, 4, 0, 249, 100, 1, 1);
  EXPECT_EQ(measure(trace(b, 1, 5000)).period, 2 * 250);  // B toggles once per TOP + 1 too
}

TEST(TimerModel, ToggleOnAInPwmModesWithOcrATop) {
  // fast PWM mode 15, COMnA = 01: 50 % at f_clk / (2 N (1 + OCRnA))
  TimerModel fast = make(true, 15, 0, 99, 0, 1, 0);
  const Wave f = measure(trace(fast, 0, 2000));
  EXPECT_EQ(f.period, 200);
  EXPECT_EQ(f.high, 100);
  // phase and frequency correct mode 9: 50 % at f_clk / (4 N OCRnA)
  TimerModel pfc = make(true, 9, 0, 100, 0, 1, 0);
  const Wave p = measure(trace(pfc, 0, 2000));
  EXPECT_EQ(p.period, 400);
  EXPECT_EQ(p.high, 200);
  // COMnB = 01 in a PWM mode: disconnected, never toggles
  TimerModel b = make(true, 15, 0, 99, 50, 1, 1);
  EXPECT_FALSE(b.connected(1));
  EXPECT_TRUE(b.connected(0));
}

TEST(TimerModel, OcrIsDoubleBufferedAtTopOrBottomAndImmediateInCtc) {
  // fast PWM: a write mid-pulse takes effect at the next BOTTOM; the pulse in progress keeps
  // its width (the 3500 us pulse: simavr 1.6 applied it at once)
  TimerModel fast = make(true, 14, 999, 499, 0, 2, 0);
  std::vector<bool> v = trace(fast, 0, 1100);  // 100 ticks into the first pulse
  fast.writeOcr(0, 49);
  EXPECT_EQ(fast.ocr(0), 49);         // reads the buffer
  EXPECT_EQ(fast.activeOcr(0), 499);  // the comparator still the old value
  const std::vector<bool> after = trace(fast, 0, 3000);
  v.insert(v.end(), after.begin(), after.end());
  EXPECT_EQ(highRuns(v), (std::vector<int>{500, 50, 50, 50}));
  // phase-correct: at TOP; phase and frequency correct: at BOTTOM
  TimerModel pc = make(true, 10, 100, 50, 0, 2, 0);  // 50 is taken at the first TOP
  for (int i = 0; i < 210; ++i) pc.tick();  // up, down, up again: at 10
  pc.writeOcr(0, 20);
  for (int i = 0; i < 90; ++i) pc.tick();  // at TOP, not yet left
  EXPECT_EQ(pc.activeOcr(0), 50);
  pc.tick();
  EXPECT_EQ(pc.activeOcr(0), 20);
  TimerModel pfc = make(true, 8, 100, 50, 0, 2, 0);
  for (int i = 0; i < 150; ++i) pfc.tick();  // counting down
  pfc.writeOcr(0, 20);
  for (int i = 0; i < 50; ++i) pfc.tick();   // at BOTTOM
  EXPECT_EQ(pfc.activeOcr(0), 50);
  pfc.tick();
  EXPECT_EQ(pfc.activeOcr(0), 20);
  TimerModel ctc = make(true, 4, 0, 999, 500, 0, 0);
  ctc.writeOcr(1, 7);
  EXPECT_EQ(ctc.activeOcr(1), 7);
}

TEST(TimerModel, FixedTopMasksTheCompareValue) {
  TimerModel m = make(true, 6, 0, 0, 0, 0, 0);  // fast PWM 9 bit
  m.writeOcr(0, 0xFFFF);
  EXPECT_EQ(m.ocr(0), 0x01FF);
}

TEST(TimerModel, OverflowFlagAtMaxTopOrBottomAsTheTableSays) {
  // the ticks of the first two overflows
  auto overflows = [](TimerModel m) {
    std::vector<int> at;
    for (int i = 1; i < 200000 && at.size() < 2; ++i)
      if (m.tick().flags & sim::kFlagOverflow) at.push_back(i);
    return at;
  };
  EXPECT_EQ(overflows(make(false, 0, 0, 0, 0, 0, 0)), (std::vector<int>{256, 512}));    // normal: leaving MAX
  EXPECT_EQ(overflows(make(true, 14, 999, 0, 0, 0, 0)), (std::vector<int>{1000, 2000}));  // fast PWM: leaving TOP
  EXPECT_EQ(overflows(make(true, 10, 999, 0, 0, 0, 0)), (std::vector<int>{1, 1999}));    // phase correct: leaving BOTTOM
  EXPECT_TRUE(overflows(make(true, 4, 0, 999, 0, 0, 0)).empty());  // CTC below MAX: never
}

TEST(TimerModel, WritingTcntBlocksTheNextMatchAndAVariableTop) {
  // a match at the value written is missed
  TimerModel m = make(true, 0, 0, 100, 0, 1, 0);
  m.writeCount(100);
  EXPECT_EQ(m.tick().flags & sim::compareFlag(0), 0);
  EXPECT_FALSE(m.output(0));
  // TCNTn = TOP in mode 14: TOP is missed, the counter runs on to MAX and around (65536 - 999
  // ticks to BOTTOM), as the datasheet warns
  TimerModel esc = make(true, 14, 999, 100, 0, 2, 0);
  esc.writeCount(999);
  int ticks = 0;
  while (!esc.output(0) && ticks < 70000) {
    esc.tick();
    ++ticks;
  }
  EXPECT_EQ(ticks, 65536 - 999 + 1000);  // on to MAX, around, then up to TOP
}

TEST(TimerModel, ForceOutputCompareOnlyInNonPwmModes) {
  TimerModel m = make(true, 0, 0, 100, 0, 1, 0);
  EXPECT_TRUE(m.force(0));
  EXPECT_TRUE(m.output(0));
  TimerModel pwm = make(true, 14, 999, 100, 0, 2, 0);
  EXPECT_FALSE(pwm.force(0));
}

TEST(TimerModel, ReservedSettingsAreNamed) {
  EXPECT_EQ(make(true, 13, 0, 0, 0, 0, 0).reservedSetting(), "waveform generation mode 13 is reserved");
  EXPECT_EQ(make(false, 3, 0, 0, 0, 0, 1).reservedSetting(), "COMB = 01 is reserved in fast PWM mode");
  EXPECT_TRUE(make(false, 4, 0, 0, 0, 0, 0).hasReservedSetting());
  EXPECT_FALSE(make(true, 10, 0, 0, 0, 2, 2).hasReservedSetting());
}

// The fast path: quietTicks() ticks change nothing but the counter, so skipping them and
// ticking the special one gives what ticking every tick gives.
TEST(TimerModel, SkippingQuietTicksEqualsTickingEachOne) {
  std::mt19937 rng(20250);
  auto pick = [&](uint32_t n) { return static_cast<uint32_t>(rng() % n); };
  for (int trial = 0; trial < 150; ++trial) {
    const bool wide = pick(2) == 1;
    const int channels = wide ? 3 : 2;
    TimerModel slow(wide, channels), fast(wide, channels);
    const uint16_t span = wide ? static_cast<uint16_t>(pick(10) == 0 ? 0xFFFF : 1 + pick(2000)) : 0xFF;
    auto both = [&](auto&& f) {
      f(slow);
      f(fast);
    };
    for (int step = 0; step < 40; ++step) {
      const uint32_t action = pick(10);
      const int ch = static_cast<int>(pick(channels));
      const uint16_t value = static_cast<uint16_t>(pick(span + 1u));
      if (action == 0) {
        const uint8_t wgm = static_cast<uint8_t>(pick(wide ? 16 : 8));
        both([&](TimerModel& m) { m.setWgm(wgm); });
      } else if (action == 1) {
        const uint8_t com = static_cast<uint8_t>(pick(4));
        both([&](TimerModel& m) { m.setCom(ch, com); });
      } else if (action == 2) {
        both([&](TimerModel& m) { m.writeOcr(ch, value); });
      } else if (action == 3) {
        both([&](TimerModel& m) { m.writeIcr(value); });
      } else if (action == 4) {
        both([&](TimerModel& m) { m.writeCount(value); });
      } else {
        const uint32_t ticks = pick(std::min(3u * span, 40000u) + 8u);
        std::vector<std::pair<uint32_t, TimerTick>> a, b;
        for (uint32_t i = 0; i < ticks; ++i) {
          const TimerTick t = slow.tick();
          if (t.flags || t.outputs) a.emplace_back(i, t);
        }
        for (uint32_t i = 0; i < ticks;) {
          const uint32_t quiet = fast.quietTicks();
          if (ticks - i <= quiet) {
            fast.skip(ticks - i);
            break;
          }
          fast.skip(quiet);
          i += quiet;
          const TimerTick t = fast.tick();
          if (t.flags || t.outputs) b.emplace_back(i, t);
          ++i;
        }
        ASSERT_EQ(a.size(), b.size()) << "trial " << trial << " step " << step;
        for (std::size_t k = 0; k < a.size(); ++k) {
          ASSERT_EQ(a[k].first, b[k].first) << "trial " << trial << " step " << step;
          ASSERT_EQ(a[k].second.flags, b[k].second.flags);
          ASSERT_EQ(a[k].second.outputs, b[k].second.outputs);
        }
      }
      ASSERT_EQ(slow.count(), fast.count()) << "trial " << trial << " step " << step;
      ASSERT_EQ(slow.countingDown(), fast.countingDown());
      for (int c = 0; c < channels; ++c) ASSERT_EQ(slow.output(c), fast.output(c));
    }
  }
}

}  // namespace
