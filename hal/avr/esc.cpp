// Four ESC outputs, 16-bit timers in fast PWM mode 14 (TOP = ICRn), prescaler 8 -> 0.5 us
// per tick. ICRn = 2e6 / frame_hz - 1 (39999 at 50 Hz, 4999 at 400 Hz), OCRnx = 2 * pwm_us - 1.
//   ESC 0  D6  PH3 OC4A      ESC 2  D8  PH5 OC4C
//   ESC 1  D7  PH4 OC4B      ESC 3  D11 PB5 OC1A
// OCRnx is double-buffered in mode 14: a new pulse width takes effect at the next frame.
#include <avr/io.h>
#include <util/atomic.h>

#include "hal/hal.hpp"

static_assert(F_CPU == 16000000UL, "ESC timer settings assume a 16 MHz clock (0.5 us ticks)");

namespace {

constexpr uint32_t kTicksPerSecond = F_CPU / 8;
uint16_t g_pulse_us[hal::kEscChannels] = {};
uint16_t g_frame_hz = 0;

uint16_t topFor(uint16_t frame_hz) {
  return static_cast<uint16_t>(kTicksPerSecond / frame_hz - 1);
}

// Writes ticks ^ 1 first, then ticks. On the chip only the second counts: OCRnx is double
// buffered in mode 14 and both writes land within a few cycles (if BOTTOM fell in between,
// one pulse would be 0.5 us off). simavr 1.6 needs it: its OCRnx write hook sits on the low
// byte and compares the old value read after the high byte was already stored, so a change
// that keeps the low byte is missed. Seen in tests/console_fuzz: read_run at 349 Hz wrote
// OCR1A = 0x07CF (1000 us) every frame while Timer1 went on with 0x0BCF (1512 us) after the
// failsafe; with this, the same run stops at 1000 us.
void writeCompare(uint8_t channel, uint16_t ticks) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {  // 16-bit registers share the TEMP byte
    for (uint16_t value = ticks ^ 1u;; value = ticks) {
      switch (channel) {
        case 0: OCR4A = value; break;
        case 1: OCR4B = value; break;
        case 2: OCR4C = value; break;
        default: OCR1A = value; break;
      }
      if (value == ticks) break;
    }
  }
}

}  // namespace

namespace hal {

void Esc::init(uint16_t frame_hz) {
  if (frame_hz < kEscMinFrameHz || frame_hz > kEscMaxFrameHz) frame_hz = kEscDefaultFrameHz;
  // Stop both timers while configuring.
  TCCR4B = 0;
  TCCR1B = 0;
  g_frame_hz = frame_hz;
  const uint16_t top = topFor(frame_hz);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    ICR4 = top;
    ICR1 = top;
    TCNT4 = 0;
    TCNT1 = 0;
  }
  for (uint8_t ch = 0; ch < kEscChannels; ++ch) writePulse(ch, 1000);
  // Non-inverting compare outputs, WGM 14 = WGMn3:WGMn2:WGMn1.
  TCCR4A = _BV(COM4A1) | _BV(COM4B1) | _BV(COM4C1) | _BV(WGM41);
  TCCR1A = _BV(COM1A1) | _BV(WGM11);
  DDRH |= _BV(PH3) | _BV(PH4) | _BV(PH5);
  DDRB |= _BV(PB5);
  // Start both at clk / 8, back to back so the frames stay nearly aligned.
  TCCR4B = _BV(WGM43) | _BV(WGM42) | _BV(CS41);
  TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);
}

bool Esc::setFrameRate(uint16_t frame_hz) {
  if (frame_hz < kEscMinFrameHz || frame_hz > kEscMaxFrameHz) return false;
  // Change between pulses: stopping a timer while its pin is high and restarting the frame
  // would stretch that pulse. Every pin is low once both counters are past their largest
  // compare value (at most one frame of waiting; none if a pulse fills the whole frame).
  const uint16_t old_top = ICR4;
  uint16_t last4 = OCR4A;
  if (OCR4B > last4) last4 = OCR4B;
  if (OCR4C > last4) last4 = OCR4C;
  const uint16_t last1 = OCR1A;
  if (last4 < old_top && last1 < old_top) {
    while (TCNT4 <= last4 || TCNT1 <= last1) {
    }
  }
  g_frame_hz = frame_hz;
  const uint16_t top = topFor(frame_hz);
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    // Clock off, new TOP, clock on. Stopping the clock is also what makes simavr 1.6 re-read
    // ICRn: it reconfigures a timer only when its clock source or mode changes. The counters
    // restart at TOP so the next tick is BOTTOM and the new frame begins with a full pulse.
    TCCR4B = _BV(WGM43) | _BV(WGM42);
    TCCR1B = _BV(WGM13) | _BV(WGM12);
    ICR4 = top;
    ICR1 = top;
    TCNT4 = top;
    TCNT1 = top;
    TCCR4B = _BV(WGM43) | _BV(WGM42) | _BV(CS41);
    TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);
  }
  return true;
}

uint16_t Esc::frameRateHz() { return g_frame_hz; }

void Esc::writePulse(uint8_t channel, uint16_t pwm_us) {
  if (channel >= kEscChannels) return;
  if (pwm_us < kEscPulseMinUs) pwm_us = kEscPulseMinUs;
  if (pwm_us > kEscPulseMaxUs) pwm_us = kEscPulseMaxUs;
  g_pulse_us[channel] = pwm_us;
  writeCompare(channel, static_cast<uint16_t>(2u * pwm_us - 1u));
}

uint16_t Esc::pulseUs(uint8_t channel) {
  return channel < kEscChannels ? g_pulse_us[channel] : 0;
}

}  // namespace hal
