/* timer_capture: input capture (ICRn <- TCNTn at an ICPn edge). The test drives the pins:
 *   D49 PL0 ICP4  Timer4 normal mode, clk/8, rising edges (ICES4), no noise canceller
 *   D48 PL1 ICP5  Timer5 normal mode, clk/1, falling edges, noise canceller on (ICNC5): a
 *                 level must hold 4 cycles, and the capture comes 4 cycles after the edge
 * Each capture interrupt stores ICRn; the main loop prints "c4 ICR" / "c5 ICR" in order. */
#include <avr/interrupt.h>

#include "probe.h"

static volatile uint16_t seen_[16];
static volatile uint8_t which_[16];
static volatile uint8_t head_, tail_;

static void keep(uint8_t which, uint16_t icr) {
  const uint8_t next = (uint8_t)((head_ + 1) & 15);
  if (next == tail_) return;
  seen_[head_] = icr;
  which_[head_] = which;
  head_ = next;
}

ISR(TIMER4_CAPT_vect) { keep(4, ICR4); }
ISR(TIMER5_CAPT_vect) { keep(5, ICR5); }

int main(void) {
  uart_init();
  TCCR4B = _BV(ICES4) | _BV(CS41);
  TCCR5B = _BV(ICNC5) | _BV(CS50);
  TIFR4 = _BV(ICF4);
  TIFR5 = _BV(ICF5);
  TIMSK4 = _BV(ICIE4);
  TIMSK5 = _BV(ICIE5);
  sei();
  uart_puts("ready\r\n");
  for (;;) {
    if (tail_ == head_) continue;
    uart_puts(which_[tail_] == 4 ? "c4 " : "c5 ");
    uart_putu(seen_[tail_]);
    uart_puts("\r\n");
    tail_ = (uint8_t)((tail_ + 1) & 15);
  }
}
