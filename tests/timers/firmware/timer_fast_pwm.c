/* timer_fast_pwm: the fast PWM modes with their TOP choices and compare outputs (non-inverting,
 * inverting, toggle on OCnA, the extremes), and a connected output whose pin is not an output.
 * tests/timers/timer_modes_test.cpp measures (f = f_clk / (N (1 + TOP)), high OCRnx + 1 ticks):
 *   D6  PH3 OC4A  Timer4 mode 14 (TOP = ICR4 = 3999), clk/8, OCR4A = 999, non-inverting
 *   D7  PH4 OC4B  inverting, OCR4B = 1499: low for 1500 ticks
 *   D8  PH5 OC4C  OCR4C = 0: a one-tick spike
 *   D11 PB5 OC1A  Timer1 mode 15 (TOP = OCR1A = 999), clk/1, COM1A = 01: toggles at TOP
 *   D12 PB6 OC1B  OCR1B = 249, non-inverting
 *   D5  PE3 OC3A  Timer3 mode 5 (8 bit), clk/64, OCR3A = 127
 *   D45 PL4 OC5B  Timer5 mode 7 (10 bit), clk/1, OCR5B = 511
 *   D4  PG5 OC0B  Timer0 mode 3 (8 bit, as the Arduino core), clk/64, OCR0B = 63
 *   D9  PH6 OC2B  Timer2 mode 7 (TOP = OCR2A = 199), clk/8, OCR2B = 49
 *   D10 PB4 OC2A  connected (COM2A = 10) but DDRB4 = 0: no output
 * Meanwhile the main loop blinks D13 (PB7) by writing PINB, and D17 (PH0) by writing PORTH, as
 * flight firmware blinks its LEDs: the compare outputs on ports B and H must not notice (in
 * simavr 1.6 each such write drove OC1A and OC4A-C with their PORTx bits, 0). */
#include "probe.h"

int main(void) {
  DDRH = _BV(PH0) | _BV(PH3) | _BV(PH4) | _BV(PH5) | _BV(PH6);
  DDRB = _BV(PB5) | _BV(PB6) | _BV(PB7);
  DDRE = _BV(PE3);
  DDRL = _BV(PL4);
  DDRG = _BV(PG5);

  TCCR4A = _BV(WGM41);
  TCCR4B = _BV(WGM43) | _BV(WGM42);
  ICR4 = 3999;
  OCR4A = 999;
  OCR4B = 1499;
  OCR4C = 0;
  TCCR4A |= _BV(COM4A1) | _BV(COM4B1) | _BV(COM4B0) | _BV(COM4C1);
  TCCR4B |= _BV(CS41);

  TCCR1A = _BV(COM1A0) | _BV(COM1B1) | _BV(WGM11) | _BV(WGM10);
  TCCR1B = _BV(WGM13) | _BV(WGM12);
  OCR1A = 999;
  OCR1B = 249;
  TCCR1B |= _BV(CS10);

  TCCR3A = _BV(COM3A1) | _BV(WGM30);
  TCCR3B = _BV(WGM32);
  OCR3A = 127;
  TCCR3B |= _BV(CS31) | _BV(CS30);

  TCCR5A = _BV(COM5B1) | _BV(WGM51) | _BV(WGM50);
  TCCR5B = _BV(WGM52);
  OCR5B = 511;
  TCCR5B |= _BV(CS50);

  TCCR0A = _BV(COM0B1) | _BV(WGM01) | _BV(WGM00);
  OCR0B = 63;
  TCCR0B = _BV(CS01) | _BV(CS00);

  TCCR2A = _BV(COM2A1) | _BV(COM2B1) | _BV(WGM21) | _BV(WGM20);
  TCCR2B = _BV(WGM22);
  OCR2A = 199;
  OCR2B = 49;
  TCCR2B |= _BV(CS21);

  for (uint16_t i = 0;; ++i) {
    if ((i & 0x3FF) == 0) PINB = _BV(PB7);
    if ((i & 0x3FF) == 0x200) PORTH ^= _BV(PH0);
  }
}
