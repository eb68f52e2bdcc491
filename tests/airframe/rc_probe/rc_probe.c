/* rc_probe: a small ATmega2560 program for the RC-input tests (tests/airframe/rc_test.cpp).
 * Three receiver decoders run at once, each the way flight firmware commonly does it, and print
 * what they decode on UART0 (115200, polled output):
 *   PPM by input capture: ICP4 (PL0, D49), Timer4 at clk/8, rising edges;
 *     "ppm-icp v1 v2 ... v8" once a frame (rising edge to rising edge, a gap > 3 ms is the sync)
 *   PPM by external interrupt: INT2 (PD2, D19), rising edges, timed with Timer5 (clk/8);
 *     "ppm-int v1 ... v8"
 *   PWM by pin-change interrupt: PCINT16..23 (PK0..7, A8..A15), pull-ups on (as receivers'
 *     inputs often are), each pin's high time timed with Timer5;
 *     "pwm v1 ... v8" when channel 1 rises, for the pulses that ended since ("-": none)
 * Values in microseconds with one decimal (the timers count 0.5 us). A decoder that decoded
 * frames and then sees none for ~100 ms prints "lost DECODER" once.
 * A line "pcif" on UART0 checks the pin-change flag against the datasheet and prints
 * "pcif set S cleared C isr I": with PCIE2 off a pin change still sets PCIF2 (S 1), writing a 1
 * clears it (C 0), and enabling PCIE2 with the flag set runs the interrupt (I 1).
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "avr_mcu_section.h"
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

#define SYNC_TICKS 6000u /* 3 ms at 0.5 us */

struct Ppm {
  uint16_t last;
  uint8_t ch;
  uint16_t val[8];
  volatile uint16_t out[8];
  volatile uint8_t ready;
  uint8_t had, seen, lost;
};
static struct Ppm icp_, int_;

static volatile uint8_t pins_last_;
static uint16_t rise_[8];
static volatile uint16_t width_[8];
static volatile uint8_t got_;
static volatile uint8_t frame_start_;  /* channel 1 rose: print the last frame */
static volatile uint8_t pcint_runs_;
static volatile uint8_t t5_overflows_;
static uint8_t pwm_had_, pwm_seen_, pwm_lost_;

static void ppmEdge(struct Ppm* p, uint16_t now) {
  uint16_t diff = now - p->last;
  p->last = now;
  if (diff > SYNC_TICKS) {
    if (p->ch == 8 && !p->ready) {
      for (uint8_t i = 0; i < 8; ++i) p->out[i] = p->val[i];
      p->ready = 1;
    }
    p->ch = 0;
  } else if (p->ch < 8) {
    p->val[p->ch++] = diff;
  }
}

ISR(TIMER4_CAPT_vect) { ppmEdge(&icp_, ICR4); }
ISR(INT2_vect) { ppmEdge(&int_, TCNT5); }
ISR(TIMER5_OVF_vect) { ++t5_overflows_; }

ISR(PCINT2_vect) {
  uint16_t now = TCNT5;
  uint8_t pins = PINK;
  uint8_t changed = pins ^ pins_last_;
  pins_last_ = pins;
  ++pcint_runs_;
  for (uint8_t i = 0; i < 8; ++i) {
    uint8_t bit = (uint8_t)(1u << i);
    if (!(changed & bit)) continue;
    if (pins & bit) {
      rise_[i] = now;
      if (i == 0) frame_start_ = 1;
    } else {
      width_[i] = now - rise_[i];
      got_ |= bit;
    }
  }
}

static void put(char c) {
  while (!(UCSR0A & (1 << UDRE0))) {
  }
  UDR0 = (uint8_t)c;
}
static void puts_(const char* s) {
  while (*s) put(*s++);
}
static void putTicks(uint16_t ticks) { /* 0.5 us ticks as "1500.5" */
  char b[8];
  utoa(ticks / 2, b, 10);
  puts_(b);
  puts_(ticks & 1 ? ".5" : ".0");
}

static void printPpm(struct Ppm* p, const char* name) {
  uint16_t v[8];
  cli();
  for (uint8_t i = 0; i < 8; ++i) v[i] = p->out[i];
  p->ready = 0;
  sei();
  puts_(name);
  for (uint8_t i = 0; i < 8; ++i) {
    put(' ');
    putTicks(v[i]);
  }
  puts_("\r\n");
  p->had = 1;
  p->seen = t5_overflows_;
  p->lost = 0;
}

static void printPwm(void) {
  uint16_t v[8];
  uint8_t got;
  cli();
  got = got_;
  got_ = 0;
  frame_start_ = 0;
  for (uint8_t i = 0; i < 8; ++i) v[i] = width_[i];
  sei();
  if (!got) return;
  puts_("pwm");
  for (uint8_t i = 0; i < 8; ++i) {
    put(' ');
    if (got & (1u << i))
      putTicks(v[i]);
    else
      put('-');
  }
  puts_("\r\n");
  pwm_had_ = 1;
  pwm_seen_ = t5_overflows_;
  pwm_lost_ = 0;
}

/* A decoder that printed frames and then none for 4 Timer5 overflows (4 x 32.8 ms): "lost". */
static void checkLost(uint8_t* seen, uint8_t* lost, uint8_t had, const char* name) {
  if (had && !*lost && (uint8_t)(t5_overflows_ - *seen) >= 4) {
    puts_("lost ");
    puts_(name);
    puts_("\r\n");
    *lost = 1;
  }
}

static void pcifCheck(void) {
  PCICR &= (uint8_t)~(1 << PCIE2);
  PCIFR = (1 << PCIF2);
  uint8_t runs = pcint_runs_;
  uint8_t t0 = t5_overflows_;
  while (!(PCIFR & (1 << PCIF2)) && (uint8_t)(t5_overflows_ - t0) < 3) {
  }
  uint8_t set = (PCIFR >> PCIF2) & 1;
  PCIFR = (1 << PCIF2);
  uint8_t cleared = (PCIFR >> PCIF2) & 1;
  /* a change now sets the flag with the interrupt off; enabling it then runs the handler */
  t0 = t5_overflows_;
  while (!(PCIFR & (1 << PCIF2)) && (uint8_t)(t5_overflows_ - t0) < 3) {
  }
  PCICR |= (1 << PCIE2);
  uint8_t isr = pcint_runs_ != runs;
  puts_("pcif set ");
  put((char)('0' + set));
  puts_(" cleared ");
  put((char)('0' + cleared));
  puts_(" isr ");
  put((char)('0' + isr));
  puts_("\r\n");
}

int main(void) {
  UBRR0 = 16; /* 115200 at 16 MHz, double speed */
  UCSR0A = (1 << U2X0);
  UCSR0B = (1 << TXEN0) | (1 << RXEN0);
  /* Timer4: normal mode, clk/8, input capture on rising edges of ICP4 (PL0) */
  DDRL &= (uint8_t)~(1 << PL0);
  TCCR4A = 0;
  TCCR4B = (1 << ICES4) | (1 << CS41);
  TIMSK4 = (1 << ICIE4);
  /* Timer5: normal mode, clk/8, the time base of the interrupt decoders */
  TCCR5A = 0;
  TCCR5B = (1 << CS51);
  TIMSK5 = (1 << TOIE5);
  /* INT2 (PD2): rising edges */
  DDRD &= (uint8_t)~(1 << PD2);
  EICRA = (1 << ISC21) | (1 << ISC20);
  EIMSK = (1 << INT2);
  /* PK0..7 inputs with pull-ups, every pin in PCMSK2 */
  DDRK = 0;
  PORTK = 0xFF;
  pins_last_ = PINK;
  PCMSK2 = 0xFF;
  PCICR = (1 << PCIE2);
  sei();
  puts_("rc_probe ready\r\n");
  char line[16];
  uint8_t n = 0;
  for (;;) {
    if (icp_.ready) printPpm(&icp_, "ppm-icp");
    if (int_.ready) printPpm(&int_, "ppm-int");
    if (frame_start_) printPwm();
    checkLost(&icp_.seen, &icp_.lost, icp_.had, "ppm-icp");
    checkLost(&int_.seen, &int_.lost, int_.had, "ppm-int");
    checkLost(&pwm_seen_, &pwm_lost_, pwm_had_, "pwm");
    if (UCSR0A & (1 << RXC0)) {
      char c = (char)UDR0;
      if (c == '\r' || c == '\n') {
        line[n] = 0;
        if (strcmp(line, "pcif") == 0) pcifCheck();
        n = 0;
      } else if (n < sizeof line - 1) {
        line[n++] = c;
      }
    }
  }
}
