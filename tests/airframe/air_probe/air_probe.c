/* air_probe: a small ATmega2560 program for the virtual-airframe HIL tests (tests/airframe).
 * It drives the TWI the two ways flight code does, polled and interrupt-driven, and prints
 * every status code it saw, so a test pins the chip's sequence; it also runs the ESCs and
 * reads the MPU-6050, so a test sees what firmware sees when a fault is injected.
 * Console on UART0 at 115200 (prompt "a> "); numbers are decimal:
 *   rate TWBR TWPS   set the bus rate (SCL = 16 MHz / (16 + 2 TWBR 4^TWPS))
 *   addr A           7-bit slave address for rd/ri/wr (default 104 = 0x68)
 *   rd REG N         polled read of N bytes from REG: "st 08 18 ... spin S cyc C data ..."
 *   ri REG N         the same read, driven by the TWI interrupt
 *   wr REG VAL       polled write of one register: "st ... cyc C"
 *   wc               TWDR written while a byte is shifting: "twwc 1" if TWWC was set
 *   imu              burst of 0x3B..0x48: "imu ax ay az t gx gy gz" (raw, signed)
 *   pins             "pins SDA SCL" as PIND reads them
 *   recover          TWI off, nine SCL clocks as GPIO (open drain), then "pins SDA SCL"
 *   pwm CH US        ESC CH (0..3) pulse in us (50 Hz frames)
 * A wait for TWINT that lasts more than ~40 ms of spinning prints "TO" as its status.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "avr_mcu_section.h"
AVR_MCU(F_CPU, "atmega2560");
AVR_MCU_VOLTAGES(5000, 5000, 5000);

#define TW_GO ((1 << TWINT) | (1 << TWEN))

static volatile uint8_t rx_buf_[64];
static volatile uint8_t rx_head_, rx_tail_;
static volatile uint16_t t5_overflows_;
static uint8_t addr_ = 0x68;

ISR(USART0_RX_vect) {
  uint8_t b = UDR0;
  uint8_t next = (uint8_t)((rx_head_ + 1) & 63);
  if (next != rx_tail_) {
    rx_buf_[rx_head_] = b;
    rx_head_ = next;
  }
}
ISR(TIMER5_OVF_vect) { ++t5_overflows_; }

static uint32_t cycles(void) {
  uint8_t s = SREG;
  cli();
  uint16_t lo = TCNT5;
  uint16_t hi = t5_overflows_;
  if ((TIFR5 & (1 << TOV5)) && lo < 0x8000) ++hi;
  SREG = s;
  return ((uint32_t)hi << 16) | lo;
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
static void puti(int16_t v) {
  char b[8];
  itoa(v, b, 10);
  puts_(b);
}
static void puthex(uint8_t v) {
  const char* h = "0123456789ABCDEF";
  put(h[v >> 4]);
  put(h[v & 15]);
}

/* ---- the status log both drivers fill ---- */
static volatile uint8_t log_[48];
static volatile uint8_t nlog_;
static uint8_t data_[16];
static void logStatus(uint8_t st) {
  if (nlog_ < sizeof log_) log_[nlog_++] = st;
}
static void printLog(uint32_t cyc, uint8_t n) {
  puts_("st");
  for (uint8_t i = 0; i < nlog_; ++i) {
    put(' ');
    if (log_[i] == 0xFF)
      puts_("TO");
    else
      puthex(log_[i]);
  }
  puts_(" cyc ");
  putu(cyc);
  if (n) puts_(" data");
  for (uint8_t i = 0; i < n; ++i) {
    put(' ');
    puthex(data_[i]);
  }
  puts_("\r\n");
}

/* ---- polled driver ---- */
static uint16_t spins_;
static uint8_t waitTwint(void) {
  uint32_t n = 0;
  while (!(TWCR & (1 << TWINT)))
    if (++n > 100000UL) {
      logStatus(0xFF);
      return 0xFF;
    }
  if (n > 0xFFFF) n = 0xFFFF;
  spins_ = (uint16_t)n;
  uint8_t st = TWSR & 0xF8;
  logStatus(st);
  return st;
}
static uint8_t stepTw(uint8_t control, uint8_t expect) {
  TWCR = control;
  return waitTwint() == expect;
}
static void stopTw(void) {
  TWCR = TW_GO | (1 << TWSTO);
  for (uint16_t n = 0; (TWCR & (1 << TWSTO)) && n < 20000; ++n) {
  }
}
/* START + SLA+W + register: 1 when all three were acknowledged. */
static uint8_t selectRegister(uint8_t reg, uint16_t* start_spins) {
  if (!stepTw(TW_GO | (1 << TWSTA), 0x08)) return 0;
  *start_spins = spins_;
  TWDR = (uint8_t)(addr_ << 1);
  if (!stepTw(TW_GO, 0x18)) return 0;
  TWDR = reg;
  return stepTw(TW_GO, 0x28);
}
static uint8_t readPolled(uint8_t reg, uint8_t n, uint16_t* start_spins) {
  if (!selectRegister(reg, start_spins)) return 0;
  if (!stepTw(TW_GO | (1 << TWSTA), 0x10)) return 0;
  TWDR = (uint8_t)((addr_ << 1) | 1);
  if (!stepTw(TW_GO, 0x40)) return 0;
  for (uint8_t i = 0; i < n; ++i) {
    uint8_t last = i + 1 == n;
    if (!stepTw(TW_GO | (last ? 0 : (1 << TWEA)), last ? 0x58 : 0x50)) return i;
    data_[i] = TWDR;
  }
  return n;
}

/* ---- interrupt-driven driver ---- */
static volatile uint8_t ireg_, in_, iidx_, idone_;
ISR(TWI_vect) {
  uint8_t st = TWSR & 0xF8;
  logStatus(st);
  const uint8_t go = TW_GO | (1 << TWIE);
  switch (st) {
    case 0x08: TWDR = (uint8_t)(addr_ << 1); TWCR = go; break;
    case 0x18: TWDR = ireg_; TWCR = go; break;
    case 0x28: TWCR = go | (1 << TWSTA); break;
    case 0x10: TWDR = (uint8_t)((addr_ << 1) | 1); TWCR = go; break;
    case 0x40: TWCR = go | (in_ > 1 ? (1 << TWEA) : 0); break;
    case 0x50:
      data_[iidx_++] = TWDR;
      TWCR = go | (iidx_ + 1 < in_ ? (1 << TWEA) : 0);
      break;
    case 0x58:
      data_[iidx_++] = TWDR;
      TWCR = TW_GO | (1 << TWSTO);
      idone_ = 1;
      break;
    default: TWCR = TW_GO | (1 << TWSTO); idone_ = 2; break;
  }
}
static uint8_t readIrq(uint8_t reg, uint8_t n) {
  ireg_ = reg;
  in_ = n;
  iidx_ = 0;
  idone_ = 0;
  TWCR = TW_GO | (1 << TWSTA) | (1 << TWIE);
  for (uint32_t k = 0; !idone_ && k < 100000UL; ++k) {
  }
  if (!idone_) logStatus(0xFF);
  for (uint16_t k = 0; (TWCR & (1 << TWSTO)) && k < 20000; ++k) {
  }
  return iidx_;
}

static void writeReg(uint8_t reg, uint8_t value) {
  uint16_t s;
  if (selectRegister(reg, &s)) {
    TWDR = value;
    stepTw(TW_GO, 0x28);
  }
  stopTw();
}

static void printPins(void) {
  puts_("pins ");
  putu((PIND >> 1) & 1);
  put(' ');
  putu(PIND & 1);
  puts_("\r\n");
}

static void recover(void) {
  TWCR = 0;
  PORTD &= (uint8_t)~3;
  for (uint8_t i = 0; i < 9; ++i) {
    DDRD |= 1;  /* SCL low */
    for (volatile uint8_t d = 0; d < 20; ++d) {
    }
    DDRD &= (uint8_t)~1;  /* released: the pull-up takes it high */
    for (volatile uint8_t d = 0; d < 20; ++d) {
    }
  }
  printPins();
}

static volatile uint16_t* const ocr_[4] = {&OCR4A, &OCR4B, &OCR4C, &OCR1A};

static void setup(void) {
  DDRH |= (1 << 3) | (1 << 4) | (1 << 5);
  DDRB |= (1 << 5);
  TCCR4A = (1 << COM4A1) | (1 << COM4B1) | (1 << COM4C1) | (1 << WGM41);
  TCCR4B = (1 << WGM43) | (1 << WGM42) | (1 << CS41);
  ICR4 = 39999;
  TCCR1A = (1 << COM1A1) | (1 << WGM11);
  TCCR1B = (1 << WGM13) | (1 << WGM12) | (1 << CS11);
  ICR1 = 39999;
  for (uint8_t i = 0; i < 4; ++i) *ocr_[i] = 1999;
  TCCR5A = 0;
  TCCR5B = (1 << CS50); /* clk/1: cycle counter */
  TIMSK5 = (1 << TOIE5);
  UCSR0A = (1 << U2X0);
  UBRR0 = 16;
  UCSR0B = (1 << RXEN0) | (1 << TXEN0) | (1 << RXCIE0);
  UCSR0C = (1 << UCSZ01) | (1 << UCSZ00);
  TWSR = 0;
  TWBR = 12; /* 400 kHz */
}

static void run(char** argv, uint8_t argc) {
  uint8_t a1 = argc > 1 ? (uint8_t)atoi(argv[1]) : 0;
  uint8_t a2 = argc > 2 ? (uint8_t)atoi(argv[2]) : 0;
  nlog_ = 0;
  if (argc == 3 && !strcmp(argv[0], "rate")) {
    TWBR = a1;
    TWSR = a2 & 3;
    puts_("ok\r\n");
  } else if (argc == 2 && !strcmp(argv[0], "addr")) {
    addr_ = a1;
    puts_("ok\r\n");
  } else if (argc == 3 && (!strcmp(argv[0], "rd") || !strcmp(argv[0], "ri"))) {
    if (a2 > sizeof data_) a2 = sizeof data_;
    uint16_t s = 0;
    uint32_t t0 = cycles();
    uint8_t got = argv[0][1] == 'd' ? readPolled(a1, a2, &s) : readIrq(a1, a2);
    if (argv[0][1] == 'd') stopTw();
    uint32_t dt = cycles() - t0;
    printLog(dt, got);
    if (argv[0][1] == 'd') {
      puts_("spin ");
      putu(s);
      puts_("\r\n");
    }
  } else if (argc == 3 && !strcmp(argv[0], "wr")) {
    uint32_t t0 = cycles();
    writeReg(a1, a2);
    printLog(cycles() - t0, 0);
  } else if (argc == 1 && !strcmp(argv[0], "wc")) {
    TWCR = TW_GO | (1 << TWSTA);
    waitTwint();
    TWDR = (uint8_t)(addr_ << 1);
    TWCR = TW_GO;
    TWDR = 0x55; /* while the address is shifting out */
    uint8_t wc = (TWCR >> TWWC) & 1;
    waitTwint();
    stopTw();
    puts_("twwc ");
    putu(wc);
    puts_("\r\n");
  } else if (argc == 1 && !strcmp(argv[0], "imu")) {
    uint16_t s;
    uint8_t got = readPolled(0x3B, 14, &s);
    stopTw();
    if (got != 14) {
      printLog(0, got);
    } else {
      puts_("imu");
      for (uint8_t i = 0; i < 7; ++i) {
        put(' ');
        puti((int16_t)(((uint16_t)data_[2 * i] << 8) | data_[2 * i + 1]));
      }
      puts_("\r\n");
    }
  } else if (argc == 1 && !strcmp(argv[0], "pins")) {
    printPins();
  } else if (argc == 1 && !strcmp(argv[0], "recover")) {
    recover();
  } else if (argc == 3 && !strcmp(argv[0], "pwm")) {
    uint16_t us = (uint16_t)atoi(argv[2]);
    if (a1 < 4) *ocr_[a1] = (uint16_t)(us * 2 - 1);
    puts_("ok\r\n");
  } else if (argc > 0) {
    puts_("error: unknown command\r\n");
  }
}

int main(void) {
  setup();
  sei();
  puts_("air_probe ready\r\na> ");
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
      continue;
    }
    line[len] = 0;
    len = 0;
    char* argv[3] = {0, 0, 0};
    uint8_t argc = 0;
    for (char* t = strtok(line, " "); t && argc < 3; t = strtok(0, " ")) argv[argc++] = t;
    run(argv, argc);
    puts_("a> ");
  }
}
