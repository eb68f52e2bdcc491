// AVR cycle benchmark for core/ (run by tests/core/avr_cycles.sh in simavr; prints over UART0).
#include <avr/io.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include <stdio.h>
#include "thrustcal/median_filter.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/curve_builder.hpp"
#include "thrustcal/eeprom_codec.hpp"

static int uart_putchar(char c, FILE*) { while (!(UCSR0A & (1 << UDRE0))) {} UDR0 = c; return 0; }
static FILE out_stream;
static volatile uint16_t sink;

static inline void start() { TCCR1A = 0; TCCR1B = 0; TCNT1 = 0; TIFR1 = 1 << TOV1; TCCR1B = 1; }  // clk/1
static inline uint16_t stop() { uint16_t t = TCNT1; TCCR1B = 0; return t; }

tc::MedianFilter<201> med;
tc::MotorCalibration cal;
tc::CurveBuilder<351> builder;
struct Ram { static uint8_t b[1024]; static uint8_t readByte(uint16_t a) { return b[a]; } static void updateByte(uint16_t a, uint8_t v) { b[a] = v; } };
uint8_t Ram::b[1024];

// One median window as gather_store reads the load cell: reset, 201 pushes of next(), median().
// Timer1 at clk/64 (a window takes more than 65,535 cycles): cycles, +-64.
template <typename Next>
static uint32_t windowCycles(Next next) {
  TCCR1B = 0; TCNT1 = 0; TCCR1B = 3;
  med.reset();
  for (uint16_t i = 0; i < 201; ++i) med.push(next());
  sink = med.median();
  return (uint32_t)stop() * 64;
}

int main() {
  UCSR0B = 1 << TXEN0; UBRR0 = 8;
  fdev_setup_stream(&out_stream, uart_putchar, nullptr, _FDEV_SETUP_WRITE);
  stdout = &out_stream;
  // median 201: one window as gather_store reads the load cell (reset, 201 pushes, median()),
  // then random pushes; then worst case (oldest at one end, new at the other)
  uint16_t x = 1;
  const uint32_t t_window = windowCycles([&] { x = x * 25173u + 13849u; return (uint16_t)(x >> 6); });
  printf("median201 window (201 pushes + median), 16-bit random: %lu cycles (+-64)\n", t_window);
  // the same on readings as a settled load cell gives them: 508..515 counts
  const uint32_t t_cell = windowCycles([&] { x = x * 25173u + 13849u; return (uint16_t)(508 + (x >> 13)); });
  printf("median201 window (201 pushes + median), 508..515 counts: %lu cycles (+-64)\n", t_cell);
  uint32_t total = 0; uint16_t worst = 0;
  for (uint16_t i = 0; i < 1000; ++i) {
    x = x * 25173u + 13849u; uint16_t s = x >> 6;
    start(); med.push(s); uint16_t t = stop();
    total += t; if (t > worst) worst = t;
  }
  printf("median201 push random: mean %lu max %u cycles\n", total / 1000, worst);
  med.reset();
  for (uint16_t i = 0; i < 201; ++i) med.push(i);  // ascending: oldest is the smallest
  worst = 0;
  for (uint16_t i = 0; i < 201; ++i) { start(); med.push(1000 + i); uint16_t t = stop(); if (t > worst) worst = t; }
  start(); sink = med.median(); uint16_t tm = stop();
  printf("median201 push worst (oldest min, new max): %u cycles; median(): %u\n", worst, tm);

  // curve build: 351 samples 1000..1700 step 2, quadratic force
  start(); // prescaler 64 for the long one
  TCCR1B = 3;
  for (uint16_t p = 1000; p <= 1700; p += 2) {
    int32_t d = p > 1080 ? (int32_t)(p - 1080) : 0;
    builder.add(p, (int16_t)(d * d * 5000 / 360000));
  }
  tc::BuildReport rep = builder.build(cal.first);
  uint16_t tb = stop();
  cal.first.start_mv = 12000;
  printf("curve build 351 samples: status %u, %lu cycles (+-64)\n", (unsigned)rep.status, (uint32_t)tb * 64);
  // second curve: copy shifted
  cal.second = cal.first; cal.second.start_mv = 11000; cal.second.pwm_at_1g_us += 50; cal.second.finalize();
  worst = 0; total = 0;
  for (uint16_t f = 1; f <= 500; ++f) {
    start(); tc::ForcePwmResult r = tc::forceToPwm(cal, f, 11437); uint16_t t = stop();
    sink = r.pwm_us; total += t; if (t > worst) worst = t;
  }
  printf("forceToPwm two curves: mean %lu max %u cycles\n", total / 500, worst);
  TCCR1B = 3; TCNT1 = 0; tc::writeRecord<Ram>(0, cal); uint16_t tw = stop();
  // decoded into cal itself: no RAM for a second record
  TCCR1B = 3; TCNT1 = 0; tc::DecodeStatus st = tc::readRecord<Ram>(0, cal); uint16_t tr = stop();
  printf("record encode %lu, decode %lu cycles (+-64), status %u\n", (uint32_t)tw * 64, (uint32_t)tr * 64, (unsigned)st);
  // correctness on AVR's 16-bit int: a force span wider than int16 (expect 1050 1053 1053)
  builder.reset();
  builder.add(1000, -20000);
  builder.add(1100, 20000);
  static tc::ForceCurve<100> wide;
  builder.build(wide);
  wide.start_mv = 12000;
  printf("wide span check (cycles test): %u %u %u\n", wide.pwmForGrams(1), wide.pwmForGrams(100), wide.pwmForGrams(2000));
  while (!(UCSR0A & (1 << TXC0))) {}
  for (;;) {}  // done (a sleep with interrupts off would read as a stopped image)
}
