// Four ESC outputs, 16-bit timers in fast PWM mode 14 (TOP = ICRn), prescaler 8 -> 0.5 us
// per tick. ICRn = 2e6 / frame_hz - 1 (39999 at 50 Hz, 4999 at 400 Hz), OCRnx = 2 * pwm_us - 1.
// Which timer, compare unit and pin each channel uses is the table hal::kEscPins
// (hal/board.hpp); the compare registers, output-enable bits and pin masks below are derived
// from it at compile time. The timer set-up is written for timers 4 and 1 (asserted).
// OCRnx is double-buffered in mode 14: a new pulse width takes effect at the next frame.
#include <avr/io.h>
#include <util/atomic.h>

#include "hal/hal.hpp"

static_assert(F_CPU == hal::kCpuHz, "hal/board.hpp's clock is the one the build targets");

namespace {

namespace board = hal::board;

// The set-up below starts timers 4 and 1 with prescaler 8 and enables exactly the table's pins.
static_assert(hal::kEscPrescaler == 8, "CSn1: clk / 8");
static_assert(board::escUsesTimer(4) && board::escUsesTimer(1) && !board::escUsesTimer(3) &&
                  !board::escUsesTimer(5),
              "the ESC outputs use timers 4 and 1");
static_assert(__builtin_popcount(board::escPortMask('H')) +
                      __builtin_popcount(board::escPortMask('B')) == hal::kEscChannels,
              "every ESC pin is on port H or B");
static_assert(board::escPortMask('H') == (_BV(PH3) | _BV(PH4) | _BV(PH5)) &&
                  board::escPortMask('B') == _BV(PB5) &&
                  board::escCompareBits(4) == (_BV(COM4A1) | _BV(COM4B1) | _BV(COM4C1)) &&
                  board::escCompareBits(1) == _BV(COM1A1),
              "pin masks and output-enable bits as the datasheet names them");
static_assert(board::escCompareAddress(0) == _SFR_MEM_ADDR(OCR4A) &&
                  board::escCompareAddress(1) == _SFR_MEM_ADDR(OCR4B) &&
                  board::escCompareAddress(2) == _SFR_MEM_ADDR(OCR4C) &&
                  board::escCompareAddress(3) == _SFR_MEM_ADDR(OCR1A),
              "the table's compare registers are the ATmega2560's");

constexpr uint32_t kTicksPerSecond = hal::kEscTicksPerSecond;

// Everything taken from the table as constants (so the table itself never reaches SRAM).
constexpr uint8_t kPortHMask = board::escPortMask('H');
constexpr uint8_t kPortBMask = board::escPortMask('B');
constexpr uint8_t kTimer4Outputs = board::escCompareBits(4);
constexpr uint8_t kTimer1Outputs = board::escCompareBits(1);

template <uint8_t Channel>
volatile uint16_t& compareRegister() {
  constexpr uint16_t address = board::escCompareAddress(Channel);
  return _SFR_MEM16(address);
}
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
      static_assert(hal::kEscChannels == 4, "one case per channel");
      switch (channel) {
        case 0: compareRegister<0>() = value; break;
        case 1: compareRegister<1>() = value; break;
        case 2: compareRegister<2>() = value; break;
        default: compareRegister<3>() = value; break;
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
  TCCR4A = kTimer4Outputs | _BV(WGM41);
  TCCR1A = kTimer1Outputs | _BV(WGM11);
  DDRH |= kPortHMask;
  DDRB |= kPortBMask;
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
    // restart one tick below TOP, so the second tick is BOTTOM and the new frame begins with a
    // full pulse. Not at TOP itself: a TCNTn write blocks the compare match of the next tick,
    // TOP's too in mode 14, and the counter would run on to 0xFFFF (datasheet, "Using the
    // Output Compare Unit"): some 30 ms without a pulse.
    TCCR4B = _BV(WGM43) | _BV(WGM42);
    TCCR1B = _BV(WGM13) | _BV(WGM12);
    ICR4 = top;
    ICR1 = top;
    TCNT4 = top - 1;
    TCNT1 = top - 1;
    TCCR4B = _BV(WGM43) | _BV(WGM42) | _BV(CS41);
    TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);
  }
  return true;
}

uint16_t Esc::frameRateHz() { return g_frame_hz; }

void Esc::writePulse(uint8_t channel, uint16_t pwm_us) {
  if (channel >= kEscChannels) return;
  if (pwm_us < kPulseClampMinUs) pwm_us = kPulseClampMinUs;
  if (pwm_us > kPulseClampMaxUs) pwm_us = kPulseClampMaxUs;
  g_pulse_us[channel] = pwm_us;
  writeCompare(channel, static_cast<uint16_t>(2u * pwm_us - 1u));
}

void Esc::writeAll(const uint16_t (&pwm_us)[kEscChannels]) {
  for (uint8_t ch = 0; ch < kEscChannels; ++ch) writePulse(ch, pwm_us[ch]);
}

uint16_t Esc::pulseUs(uint8_t channel) {
  return channel < kEscChannels ? g_pulse_us[channel] : 0;
}

}  // namespace hal
