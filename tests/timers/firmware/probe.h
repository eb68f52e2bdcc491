/* Shared by the timer test images (tests/timers): the simavr tag and a small UART0 console at
 * 115200 baud (double speed), polled. Each image is one mode family of the ATmega2560's timers;
 * the HIL tests in tests/timers measure its pins and check them against the
 * datasheet's formulas. */
#ifndef TIMERS_PROBE_H
#define TIMERS_PROBE_H
#include <avr/io.h>
#include <stdint.h>
#include <stdlib.h>

#include "avr_mcu_section.h"
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

static inline void uart_init(void) {
  UBRR0 = (F_CPU / 8 / 115200) - 1;
  UCSR0A = _BV(U2X0);
  UCSR0B = _BV(TXEN0) | _BV(RXEN0);
}
static inline void uart_put(char c) {
  while (!(UCSR0A & _BV(UDRE0))) {
  }
  UDR0 = (uint8_t)c;
}
static inline void uart_puts(const char* s) {
  while (*s) uart_put(*s++);
}
static inline void uart_putu(uint32_t v) {
  char b[11];
  ultoa(v, b, 10);
  uart_puts(b);
}
/* The next received byte, or -1. */
static inline int uart_get(void) { return (UCSR0A & _BV(RXC0)) ? UDR0 : -1; }
#endif
