// The ATmega2560's Timer/Counters 0-5 on the simulated board: see sim/timers.hpp. Register
// addresses, pins and bit positions from the ATmega2560 datasheet's register summary and its
// Timer/Counter chapters.
#include "sim/timers.hpp"

#include <fmt/format.h>

#include <cstring>
#include <stdexcept>

#include "sim/io_regs.hpp"
#include "sim/ports.hpp"
#include "timers_parts.hpp"

extern "C" {
#include <simavr/avr_ioport.h>
#include <simavr/avr_timer.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_interrupts.h>
#include <simavr/sim_irq.h>
#include <simavr/sim_regbit.h>
}

namespace sim {

using namespace timers_detail;

namespace {

// clang-format off
const Timers::Spec kSpecs[Timers::kTimers] = {
  {0, false, 2, 0x44, 0x45, 0,    0x46,  0,     {0x47, 0x48, 0},       0x6E, 0x35, "BG",  {7, 5, 0}, "T0 (PD7)", 0,   0, kPrr0, 5, false},
  {1, true,  3, 0x80, 0x81, 0x82, 0x84,  0x86,  {0x88, 0x8A, 0x8C},    0x6F, 0x36, "BBB", {5, 6, 7}, "T1 (PD6)", 'D', 4, kPrr0, 3, false},
  {2, false, 2, 0xB0, 0xB1, 0,    0xB2,  0,     {0xB3, 0xB4, 0},       0x70, 0x37, "BH",  {4, 6, 0}, "",         0,   0, kPrr0, 6, true},
  {3, true,  3, 0x90, 0x91, 0x92, 0x94,  0x96,  {0x98, 0x9A, 0x9C},    0x71, 0x38, "EEE", {3, 4, 5}, "T3 (PE6)", 'E', 7, kPrr1, 3, false},
  {4, true,  3, 0xA0, 0xA1, 0xA2, 0xA4,  0xA6,  {0xA8, 0xAA, 0xAC},    0x72, 0x39, "HHH", {3, 4, 5}, "T4 (PH7)", 'L', 0, kPrr1, 4, false},
  {5, true,  3, 0x120, 0x121, 0x122, 0x124, 0x126, {0x128, 0x12A, 0x12C}, 0x73, 0x3A, "LLL", {3, 4, 5}, "T5 (PL2)", 'L', 1, kPrr1, 5, false},
};
// clang-format on

avr_timer_t* coreTimer(avr_t* avr, char name) {
  for (avr_io_t* io = avr->io_port; io; io = io->next)
    if (io->kind && std::strcmp(io->kind, "timer") == 0 && reinterpret_cast<avr_timer_t*>(io)->name == name)
      return reinterpret_cast<avr_timer_t*>(io);
  return nullptr;
}

avr_irq_t* pinIrqOf(avr_t* avr, avr_regbit_t bit) {
  avr_ioport_getirq_t req{};
  req.bit = bit;
  return avr_ioctl(avr, AVR_IOCTL_IOPORT_GETIRQ_REGBIT, &req) > 0 ? req.irq[0] : nullptr;
}


}  // namespace


Timers::Timers(avr_t* avr, Ports& ports, Stop stop) : avr_(avr), ports_(ports), stop_(std::move(stop)) {
  for (int n = 0; n < kTimers; ++n) {
    const Spec& s = kSpecs[n];
    avr_timer_t* core = coreTimer(avr_, static_cast<char>('0' + n));
    if (!core) throw std::runtime_error(fmt::format("this simavr core has no Timer{}; the board must be an atmega2560", n));
    units_[n] = std::make_unique<Unit>(this, s, core);
    Unit& u = *units_[n];
    u.overflow = &core->overflow;
    for (int ch = 0; ch < s.channels; ++ch) u.compare[ch] = &core->comp[ch].interrupt;
    if (s.wide) u.capture = &core->icr;
    // The flags are the vectors' "raised" bits: they must be the datasheet's TIFRn bits.
    auto check = [&](const avr_int_vector_t* v, int bit) {
      if (v->raised.reg != s.tifr || v->raised.bit != bit)
        throw std::runtime_error(fmt::format("simavr's Timer{} vectors do not use TIFR{} bit {}", n, n, bit));
    };
    check(u.overflow, 0);
    for (int ch = 0; ch < s.channels; ++ch) check(u.compare[ch], ch + 1);
    if (u.capture) check(u.capture, kTifrCaptureBit);
  }
  hookCore();
  for (auto& up : units_) {
    Unit& u = *up;
    const Spec& s = *u.spec;
    own(s.tccra, &u, kTccrA, 0, false);
    own(s.tccrb, &u, kTccrB, 0, false);
    if (s.tccrc) own(s.tccrc, &u, kTccrC, 0, false);
    own(s.tcnt, &u, kTcnt, 0, true);
    if (s.wide) {
      own(s.tcnt + 1, &u, kTcntHigh, 0, true);
      own(s.icr, &u, kIcr, 0, true);
      own(s.icr + 1, &u, kIcrHigh, 0, true);
    }
    for (int ch = 0; ch < s.channels; ++ch) {
      own(s.ocr[ch], &u, kOcr, static_cast<uint8_t>(ch), true);
      if (s.wide) own(s.ocr[ch] + 1, &u, kOcrHigh, static_cast<uint8_t>(ch), true);
    }
    own(s.timsk, &u, kTimsk, 0, false);
    own(s.tifr, &u, kTifr, 0, false);
    if (s.async) own(kAssr, &u, kAsyncStatus, 0, false);
    if (s.icp_port) {
      u.icp = ports_.pinIrq(s.icp_port, s.icp_bit);
      avr_irq_register_notify(u.icp, &Timers::onIcpPin, &u);
    }
  }
  own(kGtccr, nullptr, kPrescalerReset, 0, false);
  own(kPrr0, nullptr, kPowerReduction, 0, false);
  own(kPrr1, nullptr, kPowerReduction, 0, false);
  afterReset();
}

Timers::~Timers() {
  for (auto& up : units_) {
    avr_cycle_timer_cancel(avr_, &Timers::onEvent, up.get());
    avr_cycle_timer_cancel(avr_, &Timers::onCapture, up.get());
    if (up->icp) avr_irq_unregister_notify(up->icp, &Timers::onIcpPin, up.get());
  }
  if (comparator_icp_) avr_irq_unregister_notify(comparator_icp_, &Timers::onComparatorCapture, this);
  for (int i = 0; i < reg_count_; ++i) releaseIo(avr_, regs_[i]->addr, regs_[i].get());
}

// simavr's timers lose their pins and their capture unit: nothing of theirs reaches a pin again
// (their reset connects the pins it finds in these fields, which are emptied here).
void Timers::hookCore() {
  for (auto& up : units_) {
    avr_timer_t* core = up->core;
    for (int ch = 0; ch < AVR_TIMER_COMP_COUNT; ++ch) {
      if (!core->comp[ch].com_pin.reg) continue;
      if (avr_irq_t* pin = pinIrqOf(avr_, core->comp[ch].com_pin))
        avr_unconnect_irq(core->io.irq + TIMER_IRQ_OUT_COMP + ch, pin);
      core->comp[ch].com_pin = avr_regbit_t{};
    }
    if (core->icp.reg) {
      if (avr_irq_t* pin = pinIrqOf(avr_, core->icp)) avr_unconnect_irq(pin, core->io.irq + TIMER_IRQ_IN_ICP);
      core->icp = avr_regbit_t{};
    }
    core->mode.top = avr_timer_wgm_reg_icr;  // its own capture handler ignores what still comes
  }
  // The analog comparator reaches Timer1's capture through simavr's IRQ (ACIC).
  comparator_icp_ = avr_io_getirq(avr_, AVR_IOCTL_TIMER_GETIRQ('1'), TIMER_IRQ_IN_ICP);
  if (comparator_icp_) avr_irq_register_notify(comparator_icp_, &Timers::onComparatorCapture, this);
}

void Timers::own(uint16_t addr, Unit* unit, uint8_t role, uint8_t ch, bool readable) {
  if (reg_count_ >= static_cast<int>(regs_.size())) throw std::logic_error("Timers: too many registers");
  regs_[reg_count_] = std::make_unique<Reg>(Reg{this, unit, addr, role, ch});
  Reg* r = regs_[reg_count_++].get();
  takeIoWrite(avr_, addr, &Timers::onWrite, r);
  if (readable) takeIoRead(avr_, addr, &Timers::onRead, r);
}

void Timers::afterReset() {
  // avr_reset() zeroed the registers and cancelled every cycle timer; both prescalers restart.
  sync_base_ = async_base_ = avr_->cycle;
  sync_held_ = async_held_ = false;
  for (auto& up : units_) {
    Unit& u = *up;
    u.model.reset();
    u.prescaler = 0;
    u.external = false;
    u.next_tick = kNever;
    u.temp = 0;
    u.icp_filtered = u.icp && u.icp->value != 0;
  }
}

const TimerModel& Timers::timer(int n) {
  Unit& u = *units_.at(n);
  advance(u, avr_->cycle);
  return u.model;
}

// --- time ---

void Timers::advance(Unit& u, uint64_t cycle) {
  while (u.next_tick <= cycle) {
    const uint64_t due = (cycle - u.next_tick) / u.prescaler + 1;  // ticks up to `cycle`
    const uint32_t quiet = u.model.quietTicks();
    if (due <= quiet) {
      u.model.skip(static_cast<uint32_t>(due));
      u.next_tick += due * u.prescaler;
      return;
    }
    u.model.skip(quiet);
    u.next_tick += uint64_t{quiet} * u.prescaler;
    const TimerTick t = u.model.tick();
    apply(u, t, u.next_tick);
    u.next_tick += u.prescaler;
  }
}

void Timers::apply(Unit& u, const TimerTick& t, uint64_t cycle) {
  if (t.flags & kFlagOverflow) avr_raise_interrupt(avr_, u.overflow);
  for (int ch = 0; ch < u.spec->channels; ++ch)
    if (t.flags & compareFlag(ch)) avr_raise_interrupt(avr_, u.compare[ch]);
  if ((t.flags & kFlagCapture) && u.capture) avr_raise_interrupt(avr_, u.capture);
  for (int ch = 0; ch < u.spec->channels; ++ch)
    if (t.outputs & (1u << ch)) drive(u, ch, cycle);
}

void Timers::drive(Unit& u, int ch, uint64_t cycle) {
  const int source = u.spec->number == 1 && ch == 2 ? 1 : 0;  // OC1C shares PB7 with OC0A
  ports_.setOverride(u.spec->oc_ports[ch], u.spec->oc_bits[ch], source, u.model.connected(ch),
                     u.model.output(ch), cycle);
}

bool Timers::unmodelled(const Unit& u) const {
  const bool asynchronous = u.spec->async && (avr_->data[kAssr] & (kAs2 | kExclk));
  return u.external || asynchronous || u.model.hasReservedSetting();
}

uint64_t Timers::nextEvent(Unit& u) const {
  if (unmodelled(u)) {
    // An external or asynchronous clock acts at once, a reserved setting at the next tick.
    const bool clock = u.external || (u.spec->async && (avr_->data[kAssr] & (kAs2 | kExclk)));
    if (clock) return avr_->cycle + 1;
    return u.next_tick == kNever ? 0 : u.next_tick;
  }
  if (u.next_tick == kNever) return 0;
  return u.next_tick + uint64_t{u.model.quietTicks()} * u.prescaler;
}

void Timers::reschedule(Unit& u) {
  const uint64_t next = nextEvent(u);
  if (next == 0)
    avr_cycle_timer_cancel(avr_, &Timers::onEvent, &u);
  else
    avr_cycle_timer_register(avr_, next - avr_->cycle, &Timers::onEvent, &u);
}

uint64_t Timers::onEvent(avr_t*, uint64_t when, void* param) {
  auto& u = *static_cast<Unit*>(param);
  Timers& self = *u.owner;
  if (self.unmodelled(u)) {
    self.stop_(self.describeUnmodelled(u));
    return 0;
  }
  self.advance(u, when);
  return self.nextEvent(u);
}

std::string Timers::describeUnmodelled(const Unit& u) const {
  const Spec& s = *u.spec;
  const int n = s.number;
  if (u.external)
    return fmt::format("Timer{0}: CS{0}2:0 = {1} clocks it from its pin {2} (an external clock), which the "
                       "simulator does not model; use the prescaler (CS{0}2:0 = 1..5)",
                       n, avr_->data[s.tccrb] & 7, s.t_pin);
  if (s.async && (avr_->data[kAssr] & (kAs2 | kExclk)))
    return fmt::format("Timer2: asynchronous operation (ASSR = 0x{:02X}: AS2 clocks it from a 32 kHz crystal "
                       "on TOSC1/2, EXCLK from an external clock) is not modelled; the simulator runs "
                       "Timer2 from the system clock only",
                       avr_->data[kAssr]);
  return fmt::format("Timer{}: {} (TCCR{}A = 0x{:02X}, TCCR{}B = 0x{:02X}): the ATmega2560 datasheet does not "
                     "say what the timer does then, so the simulator stops here rather than guess",
                     n, u.model.reservedSetting(), n, avr_->data[s.tccra], n, avr_->data[s.tccrb]);
}
// --- input capture ---

void Timers::onIcpPin(avr_irq_t* irq, uint32_t value, void* param) {
  auto& u = *static_cast<Unit*>(param);
  Timers& self = *u.owner;
  const bool now = value != 0;
  if ((irq->value != 0) == now) return;
  const uint64_t edge = self.ports_.changeCycle();
  if (self.avr_->data[u.spec->tccrb] & kIcnc) {
    // The noise canceller passes a level that holds for 4 samples: a shorter pulse is dropped.
    avr_cycle_timer_cancel(self.avr_, &Timers::onCapture, &u);
    if (now == u.icp_filtered) return;
    const uint64_t passes = edge + kNoiseCancellerCycles;
    if (passes > self.avr_->cycle)
      avr_cycle_timer_register(self.avr_, passes - self.avr_->cycle, &Timers::onCapture, &u);
    else
      self.filtered(u, now, passes);  // delivered late: it has held since
    return;
  }
  self.filtered(u, now, edge);
}

void Timers::filtered(Unit& u, bool level, uint64_t cycle) {
  u.icp_filtered = level;
  if (level == ((avr_->data[u.spec->tccrb] & kIces) != 0)) capture(u, cycle);
}

uint64_t Timers::onCapture(avr_t*, uint64_t when, void* param) {
  auto& u = *static_cast<Unit*>(param);
  u.owner->filtered(u, u.icp->value != 0, when);
  return 0;
}

void Timers::capture(Unit& u, uint64_t cycle) {
  advance(u, cycle);
  if (!u.model.capture(u.model.count())) return;  // ICRn is TOP: no capture
  avr_->data[u.spec->icr] = static_cast<uint8_t>(u.model.icr());
  avr_->data[u.spec->icr + 1] = static_cast<uint8_t>(u.model.icr() >> 8);
  avr_raise_interrupt(avr_, u.capture);
}

void Timers::onComparatorCapture(avr_irq_t*, uint32_t, void* param) {
  static_cast<Timers*>(param)->stop_(
      "Timer1: input capture from the analog comparator (ACIC in ACSR) is not modelled; capture from "
      "an ICPn pin instead (ICP4 PL0 = D49, ICP5 PL1 = D48, ICP3 PE7)");
}

}  // namespace sim
