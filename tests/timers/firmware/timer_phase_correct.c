/* timer_phase_correct: the phase-correct PWM modes (f = f_clk / (2 N TOP), high 2 OCRnx ticks)
 * with fixed, ICRn and OCRnA TOP, their extremes and toggle on OCnA. Timer3 runs as MultiWii 2.4
 * runs its motors on a Mega (mode 10, ICR3 = 16383, clk/1, D5 D2 D3), with D2 and D3 on INT4
 * and INT5 held low most of the time; the main loop is busy, as a flight loop is: the bench's
 * speed figure for such a firmware (`thrustcal bench`, section sim) runs this image.
 *   D5  PE3 OC3A  Timer3 mode 10, OCR3A = 8000 (1000 us)
 *   D2  PE4 OC3B  OCR3B = 4000 (INT4)
 *   D3  PE5 OC3C  OCR3C = 2000 (INT5)
 *   D46 PL3 OC5A  Timer5 mode 10 (TOP = ICR5 = 1000), clk/8, OCR5A = 0: constantly low
 *   D45 PL4 OC5B  OCR5B = 1000 = TOP: constantly high
 *   D44 PL5 OC5C  inverting, OCR5C = 300: low for 600 ticks
 *   D6  PH3 OC4A  Timer4 mode 11 (TOP = OCR4A = 1000), clk/8, COM4A = 01: toggles at TOP
 *   D7  PH4 OC4B  OCR4B = 250
 *   D11 PB5 OC1A  Timer1 mode 1 (8 bit), clk/64, OCR1A = 64
 *   D13 PB7 OC0A  Timer0 mode 5 (TOP = OCR0A = 100), clk/64, COM0A = 01: toggles at TOP
 *   D4  PG5 OC0B  OCR0B = 25
 *   D9  PH6 OC2B  Timer2 mode 1 (8 bit), clk/8, OCR2B = 100
 * Console: "n" prints how many main-loop passes ran ("loops N"). Built with -DNO_TIMERS it is the
 * same loop with every timer off: the bench's baseline for what the PWM costs. */
#include "probe.h"

int main(void) {
  uart_init();
#ifndef NO_TIMERS
  DDRE = _BV(PE3) | _BV(PE4) | _BV(PE5);
  DDRL = _BV(PL3) | _BV(PL4) | _BV(PL5);
  DDRH = _BV(PH3) | _BV(PH4) | _BV(PH6);
  DDRB = _BV(PB5) | _BV(PB7);
  DDRG = _BV(PG5);

  TCCR3A = _BV(COM3A1) | _BV(COM3B1) | _BV(COM3C1) | _BV(WGM31);
  TCCR3B = _BV(WGM33);
  ICR3 = 16383;
  OCR3A = 8000;
  OCR3B = 4000;
  OCR3C = 2000;
  TCCR3B |= _BV(CS30);

  TCCR5A = _BV(COM5A1) | _BV(COM5B1) | _BV(COM5C1) | _BV(COM5C0) | _BV(WGM51);
  TCCR5B = _BV(WGM53);
  ICR5 = 1000;
  OCR5A = 0;
  OCR5B = 1000;
  OCR5C = 300;
  TCCR5B |= _BV(CS51);

  TCCR4A = _BV(COM4A0) | _BV(COM4B1) | _BV(WGM41) | _BV(WGM40);
  TCCR4B = _BV(WGM43);
  OCR4A = 1000;
  OCR4B = 250;
  TCCR4B |= _BV(CS41);

  TCCR1A = _BV(COM1A1) | _BV(WGM10);
  OCR1A = 64;
  TCCR1B = _BV(CS11) | _BV(CS10);

  TCCR0A = _BV(COM0A0) | _BV(COM0B1) | _BV(WGM00);
  OCR0A = 100;
  OCR0B = 25;
  TCCR0B = _BV(WGM02) | _BV(CS01) | _BV(CS00);

  TCCR2A = _BV(COM2B1) | _BV(WGM20);
  OCR2B = 100;
  TCCR2B = _BV(CS21);
#endif

  uint32_t loops = 0;
  for (;;) {
    ++loops;
    if (uart_get() == 'n') {
      uart_puts("loops ");
      uart_putu(loops);
      uart_puts("\r\n");
    }
  }
}
