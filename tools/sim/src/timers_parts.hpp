// What tools/sim/src/timers.cpp and timers_regs.cpp share (sim/timers.hpp): the chip's layout
// of each timer, the state the board keeps for it, the register roles. Private to tools/sim.
#pragma once
#include <array>
#include <cstdint>

#include "sim/timers.hpp"

extern "C" {
#include <simavr/avr_timer.h>
#include <simavr/sim_interrupts.h>
}

namespace sim {
namespace timers_detail {

constexpr uint64_t kNever = ~uint64_t{0};
constexpr uint16_t kGtccr = 0x43, kAssr = 0xB6, kPrr0 = 0x64, kPrr1 = 0x65;
constexpr uint8_t kTsm = 0x80, kPsrasy = 0x02, kPsrsync = 0x01;
constexpr uint8_t kAs2 = 0x20, kExclk = 0x40;
constexpr uint8_t kIcnc = 0x80, kIces = 0x40;    // TCCRnB
constexpr uint8_t kTifrCaptureBit = 5;           // ICFn / ICIEn
constexpr int kNoiseCancellerCycles = 4;
// CSn2:0 -> clk/N: Timer0/1/3/4/5 (6, 7: external clock on Tn), Timer2 (its own prescaler).
constexpr uint32_t kSyncDivisor[8] = {0, 1, 8, 64, 256, 1024, 0, 0};
constexpr uint32_t kAsyncDivisor[8] = {0, 1, 8, 32, 64, 128, 256, 1024};

enum Role : uint8_t {
  kTccrA, kTccrB, kTccrC, kTcnt, kTcntHigh, kIcr, kIcrHigh, kOcr, kOcrHigh, kTimsk, kTifr,
  kPrescalerReset, kAsyncStatus, kPowerReduction
};

// The first edge of a clk/N prescaler tap (counting since `base`) after `now`.
inline uint64_t nextAligned(uint64_t now, uint64_t base, uint32_t divisor) {
  if (divisor == 1) return now + 1;
  return base + ((now - base) / divisor + 1) * divisor;
}

}  // namespace timers_detail

// One timer as the chip lays it out (data-space addresses; 0 = not on this timer).
struct Timers::Spec {
  int number;
  bool wide;
  int channels;
  uint16_t tccra, tccrb, tccrc, tcnt, icr;
  std::array<uint16_t, 3> ocr;
  uint16_t timsk, tifr;
  const char* oc_ports;  // OCnA, OCnB, OCnC: port letters ...
  std::array<uint8_t, 3> oc_bits;  // ... and bits
  const char* t_pin;     // its external clock input, for messages
  char icp_port;         // ICPn (0: none)
  uint8_t icp_bit;
  uint16_t prr;          // PRR0/PRR1 and its PRTIMn bit
  uint8_t prr_bit;
  bool async;            // Timer2: its own prescaler, ASSR
};

struct Timers::Unit {
  Unit(Timers* o, const Spec& s, avr_timer_t* c) : owner(o), spec(&s), core(c), model(s.wide, s.channels) {}
  Timers* owner;
  const Spec* spec;
  avr_timer_t* core;  // simavr's, for its interrupt vectors only
  TimerModel model;
  std::array<avr_int_vector_t*, 3> compare{};
  avr_int_vector_t* overflow = nullptr;
  avr_int_vector_t* capture = nullptr;
  uint32_t prescaler = 0;  // clk / N; 0: no clock
  bool external = false;   // CSn selects Tn
  uint64_t next_tick = timers_detail::kNever;
  uint8_t temp = 0;        // the 16-bit registers' TEMP byte
  avr_irq_t* icp = nullptr;
  bool icp_filtered = false;  // the noise canceller's output
};

struct Timers::Reg {
  Timers* owner;
  Unit* unit;
  uint16_t addr;
  uint8_t role;
  uint8_t ch;
};

}  // namespace sim
