// Millisecond clock on Timer0: CTC mode, prescaler 64, OCR0A = 249 -> 16 MHz / 64 / 250 = 1 kHz.
// Waiting happens in idle sleep: the CPU stops, the timers (and so the ESC pulses) run on,
// and any interrupt wakes it. On the bench it saves power; in simavr it lets the simulator
// skip ahead to the next event instead of executing a busy loop.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <util/atomic.h>

#include "hal/hal.hpp"

static_assert(F_CPU == hal::kCpuHz, "Timer0 settings assume the board's 16 MHz clock (hal/board.hpp)");

namespace {
constexpr uint8_t kTimer0Top = 249;  // 250 counts of 4 us
volatile uint32_t g_millis = 0;
}  // namespace

ISR(TIMER0_COMPA_vect) { g_millis = g_millis + 1; }

namespace hal {

void Clock::init() {
  TCCR0A = _BV(WGM01);              // CTC, TOP = OCR0A
  TCCR0B = _BV(CS01) | _BV(CS00);   // clk / 64
  OCR0A = kTimer0Top;
  TCNT0 = 0;
  TIFR0 = _BV(OCF0A);
  TIMSK0 = _BV(OCIE0A);
  set_sleep_mode(SLEEP_MODE_IDLE);
  sei();
}

uint32_t Clock::millis() {
  uint32_t ms;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { ms = g_millis; }
  return ms;
}

uint32_t Clock::micros() {
  uint32_t ms;
  uint8_t count;
  bool pending;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    ms = g_millis;
    count = TCNT0;
    pending = (TIFR0 & _BV(OCF0A)) != 0;
  }
  // The compare matched (the counter then restarts at 0) but its interrupt has not run yet: the
  // millisecond it ends is not counted in g_millis.
  if (pending && count != kTimer0Top) ++ms;
  return ms * 1000u + static_cast<uint32_t>(count) * 4u;
}

void Clock::delayMs(uint16_t ms) {
  const uint32_t start = millis();
  while (millis() - start < ms) sleepUntilInterrupt();
}

void Clock::sleepUntilInterrupt() {
  set_sleep_mode(SLEEP_MODE_IDLE);
  sleep_mode();  // sleep_enable, sleep_cpu, sleep_disable; the 1 ms tick wakes at the latest
}

void Clock::sleepUntil(bool (*ready)()) {
  set_sleep_mode(SLEEP_MODE_IDLE);
  for (;;) {
    cli();
    if (ready()) break;
    sleep_enable();
    sei();  // sei; sleep is atomic (see sleepUnless)
    sleep_cpu();
    sleep_disable();
  }
  sei();
}

void Clock::sleepUnless(bool (*pending)()) {
  set_sleep_mode(SLEEP_MODE_IDLE);
  cli();
  if (pending == nullptr || !pending()) {
    sleep_enable();
    sei();  // sei; sleep is atomic: an interrupt after the check still wakes the sleep
    sleep_cpu();
    sleep_disable();
  }
  sei();
}

}  // namespace hal
