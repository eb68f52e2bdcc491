/* ext_int: the external interrupts beside a PWM that holds INT4/INT5 low most of the time, as
 * MultiWii's motor outputs on D2/D3 do; the main loop sleeps (idle) between interrupts.
 *   D2 PE4 OC3B, D3 PE5 OC3C  Timer3 mode 10 (ICR3 = 16383), clk/1, OCR3B = OCR3C = 1000
 *   INT4 (PE4)  any edge, enabled: counts the PWM's own edges (2 per period)
 *   INT2 (PD2, D19)  low level (ISC21:0 = 00), enabled by "l": requested for as long as the pin
 *                    is low, again after each return; the handler counts and, at 100, disables it
 *   INT3 (PD3, D18)  falling edge, enabled: counts
 *   INT7 (PE7)  falling edge, not enabled: its flag INTF7 is only set
 * Console: "l" enables INT2; "p" prints "int4 N int2 N int3 N intf7 F"; "x" clears INTF7 by
 * writing EIFR (a one clears, so EIFR = 0x80); "s" the same with SBI. */
#include <avr/interrupt.h>
#include <avr/sleep.h>

#include "probe.h"

static volatile uint16_t int4_, int2_, int3_;

ISR(INT4_vect) { ++int4_; }
ISR(INT3_vect) { ++int3_; }
ISR(INT2_vect) {
  if (++int2_ >= 100) EIMSK &= (uint8_t)~_BV(INT2);
}

int main(void) {
  uart_init();
  DDRE = _BV(PE4) | _BV(PE5);
  TCCR3A = _BV(COM3B1) | _BV(COM3C1) | _BV(WGM31);
  TCCR3B = _BV(WGM33);
  ICR3 = 16383;
  OCR3B = 1000;
  OCR3C = 1000;
  TCCR3B |= _BV(CS30);

  EICRA = _BV(ISC31);                        /* INT3 falling, INT2 low level */
  EICRB = _BV(ISC40) | _BV(ISC71);           /* INT4 any edge, INT7 falling */
  EIFR = 0xFF;
  EIMSK = _BV(INT4) | _BV(INT3);
  set_sleep_mode(SLEEP_MODE_IDLE);
  sei();
  for (;;) {
    const int c = uart_get();
    if (c == 'l') {
      int2_ = 0;
      EIMSK |= _BV(INT2);
    } else if (c == 'x') {
      EIFR = _BV(INTF7);
    } else if (c == 's') {
      __asm__ volatile("sbi %0, %1" ::"I"(_SFR_IO_ADDR(EIFR)), "I"(INTF7));
    } else if (c == 'p') {
      uart_puts("int4 ");
      uart_putu(int4_);
      uart_puts(" int2 ");
      uart_putu(int2_);
      uart_puts(" int3 ");
      uart_putu(int3_);
      uart_puts(" intf7 ");
      uart_putu((EIFR >> INTF7) & 1);
      uart_puts("\r\n");
    }
    sleep_mode();
  }
}
