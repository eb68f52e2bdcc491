/* timer_buffering: when a new OCRnx takes effect. In the PWM modes a write goes to a buffer
 * the comparator takes at TOP (phase correct) or BOTTOM (fast PWM, phase and frequency
 * correct), so a pulse in progress is never cut or stretched; in CTC a write counts at once,
 * and one below the counter is missed until the counter has gone round. Each timer gets its
 * new value once, mid-pulse, after three periods; tests/timers/timer_modes_test.cpp reads
 * the pulse widths before, across and after:
 *   D6  PH3 OC4A  Timer4 mode 14 (fast PWM, ICR4 = 3999), clk/8: OCR4A 1999 -> 499 while high
 *   D5  PE3 OC3A  Timer3 mode 10 (phase correct, ICR3 = 1000), clk/8: OCR3A 600 -> 200 while
 *                 high and counting down (the pulse around BOTTOM keeps 2 x 600 ticks)
 *   D46 PL3 OC5A  Timer5 mode 8 (phase and frequency correct, ICR5 = 1000), clk/8: OCR5A
 *                 600 -> 200 at the same point: BOTTOM takes it, that pulse is 600 + 200
 *   D11 PB5 OC1A  Timer1 mode 4 (CTC, OCR1A = 999), clk/8, toggle: OCR1A 999 -> 500 when
 *                 TCNT1 is past 600: the match is missed, the counter goes round (65536 ticks)
 * Prints "done" when every write is made. */
#include "probe.h"

static uint16_t count4(void) { return TCNT4; }
static uint16_t count3(void) { return TCNT3; }
static uint16_t count5(void) { return TCNT5; }

/* Waits until `count` runs down through (lo, hi) twice in a row: counting down, in the window. */
static void waitDown(uint16_t (*count)(void), uint16_t lo, uint16_t hi) {
  for (;;) {
    const uint16_t a = count();
    const uint16_t b = count();
    if (b < a && b > lo && b < hi) return;
  }
}

int main(void) {
  uart_init();
  DDRH = _BV(PH3);
  DDRE = _BV(PE3);
  DDRL = _BV(PL3);
  DDRB = _BV(PB5);

  TCCR4A = _BV(COM4A1) | _BV(WGM41);
  TCCR4B = _BV(WGM43) | _BV(WGM42);
  ICR4 = 3999;
  OCR4A = 1999;
  TCCR3A = _BV(COM3A1) | _BV(WGM31);
  TCCR3B = _BV(WGM33);
  ICR3 = 1000;
  OCR3A = 600;
  TCCR5A = _BV(COM5A1);
  TCCR5B = _BV(WGM53);
  ICR5 = 1000;
  OCR5A = 600;
  OCR1A = 999;
  TCCR1A = _BV(COM1A0);
  TCCR1B = _BV(WGM12);
  /* all four at clk/8, one after the other */
  TCCR4B |= _BV(CS41);
  TCCR3B |= _BV(CS31);
  TCCR5B |= _BV(CS51);
  TCCR1B |= _BV(CS11);

  while (!(TIFR4 & _BV(TOV4))) {
  }
  for (uint8_t i = 0; i < 3; ++i) { /* three whole periods of Timer4 */
    TIFR4 = _BV(TOV4);
    while (!(TIFR4 & _BV(TOV4))) {
    }
  }
  while (!(count4() > 1000 && count4() < 1500)) {
  }
  OCR4A = 499;
  waitDown(count3, 300, 550);
  OCR3A = 200;
  waitDown(count5, 300, 550);
  OCR5A = 200;
  while (!(TCNT1 > 600 && TCNT1 < 900)) {
  }
  OCR1A = 500;
  uart_puts("done\r\n");
  for (;;) {
  }
}
