// The ATmega2560's Timer/Counters 0-5 on the simulated board, in place of simavr 1.6's timers
// (taken over through the core's io[] table, as sim/twi.hpp does for the TWI). Each timer is a
// sim::TimerModel (sim/timer_model.hpp: every waveform and compare-output mode, OCRnx double
// buffering, TCNTn writes blocking a match) clocked by the chip's prescalers:
//   - one prescaler for Timer0/1/3/4/5 and one for Timer2, free running since the reset, so a
//     timer started at clk/N first counts 1..N cycles later; GTCCR's PSRSYNC/PSRASY reset them
//     and TSM holds them; a PRTIMn bit in PRR0/PRR1 stops its timer's clock;
//   - the 16-bit registers through the timer's TEMP byte (write high then low, read low then
//     high; OCRnx reads directly); TIFRn write-one-to-clear (SBI clears its bit only); an
//     interrupt whose flag is already set is taken when TIMSKn enables it;
//   - OCnx on its pin through sim::Ports (an output only where DDR says so);
//   - input capture from the ICPn pin (ICP1 PD4, ICP3 PE7, ICP4 PL0, ICP5 PL1): ICESn picks the
//     edge, ICNCn's noise canceller delays the capture by 4 cycles and drops shorter pulses.
// No polling: the next tick at which something happens is computed and a cycle timer set for
// it. What the simulator does not model stops the run (the `stop` callback, which makes the
// board throw sim::BoardError): an external clock on Tn (CSn = 6, 7), Timer2's asynchronous
// mode (AS2/EXCLK in ASSR), input capture from the analog comparator (ACIC), and what the
// datasheet leaves undefined (a reserved WGM or COM setting) once the timer counts with it.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "sim/timer_model.hpp"

struct avr_t;
struct avr_irq_t;
struct avr_int_vector_t;
struct avr_timer_t;

namespace sim {

class Ports;

class Timers {
 public:
  static constexpr int kTimers = 6;
  using Stop = std::function<void(const std::string& why)>;
  Timers(avr_t* avr, Ports& ports, Stop stop);
  ~Timers();
  Timers(const Timers&) = delete;
  Timers& operator=(const Timers&) = delete;

  void afterReset();
  // Timer n (0..5) as it is now (its counter brought up to the present cycle).
  const TimerModel& timer(int n);

  struct Spec;
  struct Unit;

 private:
  struct Reg;
  static void onWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param);
  static uint8_t onRead(avr_t* avr, uint16_t addr, void* param);
  static uint64_t onEvent(avr_t* avr, uint64_t when, void* param);
  static uint64_t onCapture(avr_t* avr, uint64_t when, void* param);
  static void onIcpPin(avr_irq_t* irq, uint32_t value, void* param);
  static void onComparatorCapture(avr_irq_t* irq, uint32_t value, void* param);

  void write(const Reg& r, uint8_t v);
  uint8_t read(const Reg& r);
  void writeControl(Unit& u, int which, uint8_t v);
  void writePrescalerReset(uint8_t v);
  void writeTimsk(Unit& u, uint8_t v);
  void writeTifr(Unit& u, uint16_t addr, uint8_t v);
  void setClock(Unit& u);
  void advance(Unit& u, uint64_t cycle);
  void apply(Unit& u, const TimerTick& t, uint64_t cycle);
  void drive(Unit& u, int ch, uint64_t cycle);
  void reschedule(Unit& u);
  uint64_t nextEvent(Unit& u) const;
  bool unmodelled(const Unit& u) const;
  std::string describeUnmodelled(const Unit& u) const;
  void filtered(Unit& u, bool level, uint64_t cycle);  // the ICPn level after the noise canceller
  void capture(Unit& u, uint64_t cycle);
  void hookCore();
  void own(uint16_t addr, Unit* unit, uint8_t role, uint8_t ch, bool readable);

  avr_t* avr_;
  Ports& ports_;
  Stop stop_;
  std::array<std::unique_ptr<Unit>, kTimers> units_;
  std::array<std::unique_ptr<Reg>, 96> regs_{};
  int reg_count_ = 0;
  // The two prescalers: the cycle each was last reset at, and whether TSM holds it in reset.
  uint64_t sync_base_ = 0, async_base_ = 0;
  bool sync_held_ = false, async_held_ = false;
  avr_irq_t* comparator_icp_ = nullptr;
};

}  // namespace sim
