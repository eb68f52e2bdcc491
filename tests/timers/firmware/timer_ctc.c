/* timer_ctc: the non-PWM modes (normal, CTC with OCRnA or ICRn as TOP) and their compare
 * outputs (toggle, clear, set, forced), one timer each, plus an overflow interrupt that toggles
 * a plain port pin. tests/timers/timer_modes_test.cpp measures the pins:
 *   D11 PB5 OC1A  Timer1 mode 4 (TOP = OCR1A = 999), clk/8, toggle: f = f_clk / (2 N (1 + OCR1A))
 *   D12 PB6 OC1B  the same timer, OCR1B = 499: toggles 500 ticks after OC1A
 *   D5  PE3 OC3A  Timer3 mode 12 (TOP = ICR3 = 199), clk/1, toggle
 *   D10 PB4 OC2A  Timer2 mode 2 (TOP = OCR2A = 99), clk/32, toggle
 *   D13 PB7 OC0A  Timer0 mode 0 (normal), clk/64, toggle at OCR0A = 128
 *   D22 PA0       toggled by the Timer0 overflow interrupt (PINA write)
 *   D46 PL3 OC5A  Timer5 mode 0, clk/1: set on compare match at OCR5A = 1000
 *   D45 PL4 OC5B  forced high (FOC5B with COM5B = set), then cleared on match at OCR5B = 3000 */
#include <avr/interrupt.h>

#include "probe.h"

ISR(TIMER0_OVF_vect) { PINA = _BV(PA0); }

int main(void) {
  DDRA = _BV(PA0);
  DDRB = _BV(PB4) | _BV(PB5) | _BV(PB6) | _BV(PB7);
  DDRE = _BV(PE3);
  DDRL = _BV(PL3) | _BV(PL4);

  OCR1A = 999;
  OCR1B = 499;
  TCCR1A = _BV(COM1A0) | _BV(COM1B0);
  TCCR1B = _BV(WGM12) | _BV(CS11);

  TCCR3B = _BV(WGM33) | _BV(WGM32);
  ICR3 = 199;
  TCCR3A = _BV(COM3A0);
  TCCR3B |= _BV(CS30);

  OCR2A = 99;
  TCCR2A = _BV(COM2A0) | _BV(WGM21);
  TCCR2B = _BV(CS21) | _BV(CS20);

  OCR0A = 128;
  TCCR0A = _BV(COM0A0);
  TIMSK0 = _BV(TOIE0);
  TCCR0B = _BV(CS01) | _BV(CS00);

  OCR5A = 1000;
  OCR5B = 3000;
  TCCR5A = _BV(COM5A1) | _BV(COM5A0) | _BV(COM5B1) | _BV(COM5B0);
  TCCR5C = _BV(FOC5B);
  TCCR5A = _BV(COM5A1) | _BV(COM5A0) | _BV(COM5B1);
  TCCR5B = _BV(CS50);

  sei();
  for (;;) {
  }
}
