/* probe: a tiny ATmega2560 program that exercises every wire of the simavr harness
 * (tests/sim): ESC pulses on OC4A/OC4B/OC4C/OC1A (fast PWM mode 14, 0.5 us ticks, 50 Hz),
 * ADC conversions, UART0 at 115200 with an interrupt-driven receiver, EEPROM bytes, idle sleep.
 * Console (prompt "p> "):
 *   pwm CH US     set ESC channel CH (0..3) to US microseconds
 *   adc CH        print one conversion of channel CH: "adc CH COUNTS"
 *   ee ADDR VAL   write an EEPROM byte          er ADDR   print "ee ADDR VAL"
 *   ms            print the millisecond clock: "ms N"
 *   halt          cli + sleep: the simulator reports a stopped firmware
 */
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "avr_mcu_section.h"
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

static volatile uint32_t ms_;
static volatile uint8_t rx_buf_[64];
static volatile uint8_t rx_head_, rx_tail_;

ISR(TIMER0_COMPA_vect) { ++ms_; }
ISR(USART0_RX_vect) {
  uint8_t b = UDR0;
  uint8_t next = (uint8_t)((rx_head_ + 1) & 63);
  if (next != rx_tail_) {
    rx_buf_[rx_head_] = b;
    rx_head_ = next;
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
static void putu(uint32_t v) {
  char b[11];
  ultoa(v, b, 10);
  puts_(b);
}

static volatile uint16_t* const ocr[4] = {&OCR4A, &OCR4B, &OCR4C, &OCR1A};

int main(void) {
  /* 1 kHz tick */
  TCCR0A = (1 << WGM01);
  TCCR0B = (1 << CS01) | (1 << CS00); /* /64 -> 250 kHz */
  OCR0A = 249;
  TIMSK0 = (1 << OCIE0A);
  /* ESC outputs: fast PWM mode 14, /8 prescaler (0.5 us), TOP = ICR = 39999 (50 Hz) */
  DDRH |= (1 << 3) | (1 << 4) | (1 << 5);
  DDRB |= (1 << 5);
  TCCR4A = (1 << COM4A1) | (1 << COM4B1) | (1 << COM4C1) | (1 << WGM41);
  TCCR4B = (1 << WGM43) | (1 << WGM42) | (1 << CS41);
  ICR4 = 39999;
  TCCR1A = (1 << COM1A1) | (1 << WGM11);
  TCCR1B = (1 << WGM13) | (1 << WGM12) | (1 << CS11);
  ICR1 = 39999;
  for (uint8_t i = 0; i < 4; ++i) *ocr[i] = 1999; /* 1000 us */
  /* UART0 115200, U2X */
  UCSR0A = (1 << U2X0);
  UBRR0 = 16;
  UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
  UCSR0C = (1 << UCSZ01) | (1 << UCSZ00);
  ADCSRA = (1 << ADEN) | 7;
  sei();
  puts_("probe ready\r\np> ");
  char line[40];
  uint8_t len = 0;
  set_sleep_mode(SLEEP_MODE_IDLE);
  for (;;) {
    cli();
    if (rx_head_ == rx_tail_) {
      sleep_enable();
      sei();
      sleep_cpu();
      sleep_disable();
      continue;
    }
    uint8_t c = rx_buf_[rx_tail_];
    rx_tail_ = (uint8_t)((rx_tail_ + 1) & 63);
    sei();
    if (c != '\r' && c != '\n') {
      if (len < sizeof line - 1) line[len++] = (char)c;
      put((char)c);
      continue;
    }
    line[len] = 0;
    len = 0;
    puts_("\r\n");
    char* argv[3] = {0, 0, 0};
    uint8_t argc = 0;
    for (char* t = strtok(line, " "); t && argc < 3; t = strtok(0, " ")) argv[argc++] = t;
    if (argc == 3 && !strcmp(argv[0], "pwm")) {
      uint8_t ch = (uint8_t)atoi(argv[1]);
      uint16_t us = (uint16_t)atoi(argv[2]);
      if (ch < 4) *ocr[ch] = (uint16_t)(us * 2 - 1);
      puts_("ok\r\n");
    } else if (argc == 2 && !strcmp(argv[0], "adc")) {
      uint8_t ch = (uint8_t)atoi(argv[1]);
      ADMUX = (uint8_t)((1 << REFS0) | (ch & 7));
      ADCSRA |= (1 << ADSC);
      while (ADCSRA & (1 << ADSC)) {
      }
      puts_("adc ");
      putu(ch);
      put(' ');
      putu(ADC);
      puts_("\r\n");
    } else if (argc == 3 && !strcmp(argv[0], "ee")) {
      eeprom_update_byte((uint8_t*)atoi(argv[1]), (uint8_t)atoi(argv[2]));
      puts_("ok\r\n");
    } else if (argc == 2 && !strcmp(argv[0], "er")) {
      uint16_t a = (uint16_t)atoi(argv[1]);
      puts_("ee ");
      putu(a);
      put(' ');
      putu(eeprom_read_byte((const uint8_t*)a));
      puts_("\r\n");
    } else if (argc == 1 && !strcmp(argv[0], "ms")) {
      cli();
      uint32_t now = ms_;
      sei();
      puts_("ms ");
      putu(now);
      puts_("\r\n");
    } else if (argc == 1 && !strcmp(argv[0], "halt")) {
      puts_("halting\r\n");
      while (!(UCSR0A & (1 << TXC0))) {
      }
      cli();
      sleep_enable();
      sleep_cpu();
    } else if (argc > 0) {
      puts_("error: unknown command\r\n");
    }
    puts_("p> ");
  }
}
