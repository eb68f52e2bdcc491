// 10-bit ADC: AVcc (5 V) reference, prescaler 128 -> 125 kHz ADC clock, 13 clocks (104 us)
// per conversion. The CPU idles during a conversion and the ADC interrupt wakes it.
// Not ADC-noise-reduction sleep: that mode stops the timers that generate the ESC pulses.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "hal/hal.hpp"

// Only wakes the CPU; the result is read from ADC afterwards.
EMPTY_INTERRUPT(ADC_vect);

namespace hal {

void Adc::init() {
  ADMUX = _BV(REFS0);                                        // AVcc reference, channel 0
  ADCSRB = 0;
  DIDR0 = _BV(ADC0D) | _BV(ADC1D);                           // A0, A1 analog only
  ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);  // enable, clk / 128
}

uint16_t Adc::readCounts(uint8_t channel) {
  channel &= 0x0F;
  ADMUX = static_cast<uint8_t>(_BV(REFS0) | (channel & 0x07));
  if (channel & 0x08) {
    ADCSRB |= _BV(MUX5);
  } else {
    ADCSRB &= static_cast<uint8_t>(~_BV(MUX5));
  }
  ADCSRA |= _BV(ADIF);              // clear a stale flag (written 1 clears it)
  ADCSRA |= _BV(ADIE) | _BV(ADSC);  // start, interrupt on completion
  set_sleep_mode(SLEEP_MODE_IDLE);
  for (;;) {
    cli();
    if (!(ADCSRA & _BV(ADSC))) break;
    // sei; sleep is atomic: the instruction after sei runs before any pending interrupt, so
    // a conversion that completes in between still wakes us.
    sleep_enable();
    sei();
    sleep_cpu();
    sleep_disable();
  }
  sei();
  ADCSRA &= static_cast<uint8_t>(~_BV(ADIE));
  return ADC;
}

}  // namespace hal
