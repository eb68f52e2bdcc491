/* timer_pfc: the phase and frequency correct modes (OCRnx updated at BOTTOM): f = f_clk /
 * (2 N TOP), high 2 OCRnx ticks.
 *   D46 PL3 OC5A  Timer5 mode 8 (TOP = ICR5 = 2000), clk/1, OCR5A = 500
 *   D11 PB5 OC1A  Timer1 mode 9 (TOP = OCR1A = 400), clk/1, COM1A = 01: toggles, 50 % at
 *                 f_clk / (4 N OCR1A)
 *   D12 PB6 OC1B  OCR1B = 100
 * On "m": the output compare modulator on D13 (PB7), where OC0A and OC1C meet: Timer0 fast PWM
 * at clk/1 with OCR0A = 127 (high 128 of 256 cycles) and OC1C with OCR1C = 400 = TOP
 * (constantly high), PORTB7 = 0 (AND). Then "o" sets PORTB7 (OR), "z" makes OCR1C = 0
 * (constantly low), "a" clears PORTB7 again (AND). Each command answers "ok". */
#include "probe.h"

int main(void) {
  uart_init();
  DDRL = _BV(PL3);
  DDRB = _BV(PB5) | _BV(PB6);

  TCCR5A = _BV(COM5A1);
  TCCR5B = _BV(WGM53);
  ICR5 = 2000;
  OCR5A = 500;
  TCCR5B |= _BV(CS50);

  TCCR1A = _BV(COM1A0) | _BV(COM1B1) | _BV(WGM10);
  TCCR1B = _BV(WGM13);
  OCR1A = 400;
  OCR1B = 100;
  TCCR1B |= _BV(CS10);

  for (;;) {
    const int c = uart_get();
    if (c == 'm') {
      OCR1C = 400;
      TCCR1A |= _BV(COM1C1);
      OCR0A = 127;
      TCCR0A = _BV(COM0A1) | _BV(WGM01) | _BV(WGM00);
      TCCR0B = _BV(CS00);
      DDRB |= _BV(PB7);
    } else if (c == 'o') {
      PORTB |= _BV(PB7);
    } else if (c == 'z') {
      OCR1C = 0;
    } else if (c == 'a') {
      PORTB &= (uint8_t)~_BV(PB7);
    }
    if (c > 0) uart_puts("ok\r\n");
  }
}
