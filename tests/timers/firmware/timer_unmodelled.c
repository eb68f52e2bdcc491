/* timer_unmodelled: settings the simulator does not model, one per console command; each must
 * stop the run with an error that names the timer and the setting.
 *   "x"  Timer1 clocked from its T1 pin (CS12:0 = 7, rising edge)
 *   "a"  Timer2 asynchronous (AS2 in ASSR)
 *   "r"  Timer3 in the reserved mode 13, clock running
 *   "b"  Timer0 fast PWM with COM0B = 01 (reserved), clock running
 *   "t"  a reserved mode only between two writes at clk/64 (mode 7 -> 0 on Timer0 with TCCR0A
 *        written first), just after a prescaler reset: no timer clock edge sees it, so the
 *        run goes on ("ok")
 * "go" is printed at start. */
#include "probe.h"

int main(void) {
  uart_init();
  uart_puts("go\r\n");
  for (;;) {
    const int c = uart_get();
    if (c == 'x') {
      TCCR1B = _BV(CS12) | _BV(CS11) | _BV(CS10);
    } else if (c == 'a') {
      ASSR = _BV(AS2);
    } else if (c == 'r') {
      TCCR3A = _BV(WGM30);
      TCCR3B = _BV(WGM33) | _BV(WGM32) | _BV(CS30);
    } else if (c == 'b') {
      TCCR0A = _BV(COM0B0) | _BV(WGM01) | _BV(WGM00);
      TCCR0B = _BV(CS00);
    } else if (c == 't') {
      TCCR0A = _BV(WGM01) | _BV(WGM00);
      TCCR0B = _BV(WGM02) | _BV(CS01) | _BV(CS00);
      GTCCR = _BV(PSRSYNC); /* the next clk/64 edge is 64 cycles away */
      TCCR0A = 0;           /* mode 4 (reserved) until the next write */
      TCCR0B = _BV(CS01) | _BV(CS00);
      uart_puts("ok\r\n");
    }
  }
}
