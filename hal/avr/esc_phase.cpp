// The ESC frame's phase interrupt (hal::Esc::setPhaseHook, frameTimeUs): Timer1's compare unit B,
// whose pin OC1B (PB6) stays a port pin (COM1B = 0), matches at the same tick of every frame
// (Timer1 and Timer4 run the same frame, started together by Esc::init). A file of its own so
// that only an image that uses the hook links its interrupt.
// OCR1B is double-buffered in mode 14 like the pulse registers: a new phase counts from the next
// frame. A new frame rate (Esc::setFrameRate) keeps the phase's tick: set the hook after it.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "hal/hal.hpp"

namespace {
hal::Esc::PhaseHook g_phase_hook = nullptr;
}  // namespace

ISR(TIMER1_COMPB_vect) {
  if (g_phase_hook != nullptr) g_phase_hook();
}

namespace hal {

void Esc::setPhaseHook(uint16_t at_us, PhaseHook hook) {
  TIMSK1 &= static_cast<uint8_t>(~_BV(OCIE1B));
  g_phase_hook = hook;
  if (hook == nullptr) return;
  const uint16_t frame_hz = frameRateHz();
  const uint16_t period_us =
      static_cast<uint16_t>(1000000UL / (frame_hz != 0 ? frame_hz : kEscDefaultFrameHz));
  if (at_us < 1) at_us = 1;
  if (at_us > period_us - 1) at_us = static_cast<uint16_t>(period_us - 1);
  const uint16_t ticks = static_cast<uint16_t>(2u * at_us);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    OCR1B = ticks ^ 1u;  // as esc.cpp's writeCompare: simavr 1.6 misses a change of the high byte alone
    OCR1B = ticks;
  }
  TIFR1 = _BV(OCF1B);  // a match from before is not this frame's
  TIMSK1 |= _BV(OCIE1B);
}

uint16_t Esc::frameTimeUs() {
  uint16_t ticks;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { ticks = TCNT1; }
  return static_cast<uint16_t>(ticks / 2u);
}

}  // namespace hal
