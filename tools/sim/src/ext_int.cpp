// INT0..INT7 without polling: see sim/ext_int.hpp.
#include "sim/ext_int.hpp"

#include <cstring>
#include <stdexcept>

#include "sim/io_regs.hpp"

extern "C" {
#include <simavr/avr_extint.h>
#include <simavr/avr_ioport.h>
#include <simavr/sim_interrupts.h>
#include <simavr/sim_irq.h>
#include <simavr/sim_regbit.h>
}

namespace sim {
namespace {

// ATmega2560 registers (data space addresses).
constexpr uint16_t kEicra = 0x69, kEicrb = 0x6A, kEimsk = 0x3D, kEifr = 0x3C;
// INTn's pin: INT0-3 PD0-3, INT4-7 PE4-7.
constexpr char pinPort(int n) { return n < 4 ? 'D' : 'E'; }
constexpr int pinBit(int n) { return n; }

avr_extint_t* coreExtInt(avr_t* avr) {
  for (avr_io_t* io = avr->io_port; io; io = io->next)
    if (io->kind && std::strcmp(io->kind, "extint") == 0) return reinterpret_cast<avr_extint_t*>(io);
  return nullptr;
}

}  // namespace

ExtInt::ExtInt(avr_t* avr) : avr_(avr), core_(coreExtInt(avr)) {
  if (!core_) throw std::runtime_error("this simavr core has no external interrupts; the board must be an atmega2560");
  for (int n = 0; n < kLines; ++n) {
    pins_[n] = avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(pinPort(n)), pinBit(n));
    // simavr's own handler goes: unhooked from the pin, and its reset finds no pin to hook
    // again (it looks the pin up by port_ioctl).
    avr_unconnect_irq(pins_[n], core_->io.irq + n);
    core_->eint[n].port_ioctl = 0;
    lines_[n] = Line{this, n};
    avr_irq_register_notify(pins_[n], &ExtInt::onPin, &lines_[n]);
    avr_irq_register_notify(core_->eint[n].vector.irq + AVR_INT_IRQ_RUNNING, &ExtInt::onRunning, &lines_[n]);
  }
  takeIoWrite(avr_, kEicra, &ExtInt::onSenseWrite, this);
  takeIoWrite(avr_, kEicrb, &ExtInt::onSenseWrite, this);
  takeIoWrite(avr_, kEimsk, &ExtInt::onMaskWrite, this);
  takeIoWrite(avr_, kEifr, &ExtInt::onFlagWrite, this);
}

ExtInt::~ExtInt() {
  for (int n = 0; n < kLines; ++n) {
    avr_irq_unregister_notify(pins_[n], &ExtInt::onPin, &lines_[n]);
    avr_irq_unregister_notify(core_->eint[n].vector.irq + AVR_INT_IRQ_RUNNING, &ExtInt::onRunning, &lines_[n]);
  }
  for (uint16_t a : {kEicra, kEicrb, kEimsk, kEifr}) releaseIo(avr_, a, this);
}

avr_int_vector_t* ExtInt::vector(int n) const { return &core_->eint[n].vector; }

uint8_t ExtInt::sense(int n) const {
  const uint8_t reg = avr_->data[n < 4 ? kEicra : kEicrb];
  return static_cast<uint8_t>((reg >> (2 * (n & 3))) & 3);
}

// A low level requests the interrupt while it lasts and INTn is enabled; the request goes when
// the level does (the datasheet: the level must be held until the current instruction ends).
void ExtInt::updateLevel(int n, bool pin_low) {
  const uint8_t bit = static_cast<uint8_t>(1u << n);
  avr_int_vector_t* v = vector(n);
  const bool active = sense(n) == 0 && (avr_->data[kEimsk] & bit) && pin_low;
  if (active) {
    if (!v->pending) {
      avr_raise_interrupt(avr_, v);
      levels_requested_ |= bit;
    }
    avr_regbit_clear(avr_, v->raised);  // INTFn is always 0 for a level interrupt
  } else if (levels_requested_ & bit) {
    levels_requested_ = static_cast<uint8_t>(levels_requested_ & ~bit);
    if (v->pending) avr_clear_interrupt(avr_, v);
  }
}

void ExtInt::updateLevel(int n) { updateLevel(n, pins_[n]->value == 0); }

void ExtInt::onPin(avr_irq_t* irq, uint32_t value, void* param) {
  auto* line = static_cast<Line*>(param);
  ExtInt& self = *line->owner;
  const bool was = irq->value != 0, now = value != 0;  // simavr stores the new value after us
  switch (self.sense(line->n)) {
    case 0: if (was != now) self.updateLevel(line->n, !now); break;
    case 1: if (was != now) avr_raise_interrupt(self.avr_, self.vector(line->n)); break;
    case 2: if (was && !now) avr_raise_interrupt(self.avr_, self.vector(line->n)); break;
    default: if (!was && now) avr_raise_interrupt(self.avr_, self.vector(line->n)); break;
  }
}

void ExtInt::onRunning(avr_irq_t*, uint32_t value, void* param) {
  auto* line = static_cast<Line*>(param);
  if (value == 0) line->owner->updateLevel(line->n);  // a RETI: still low, asked again
}

void ExtInt::onSenseWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  avr->data[addr] = v;
  auto* self = static_cast<ExtInt*>(param);
  for (int n = 0; n < kLines; ++n) self->updateLevel(n);
}

void ExtInt::onMaskWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  auto* self = static_cast<ExtInt*>(param);
  const uint8_t enabled = static_cast<uint8_t>(v & ~avr->data[addr]);
  avr->data[addr] = v;
  for (int n = 0; n < kLines; ++n) {
    avr_int_vector_t* vec = self->vector(n);
    // An edge flagged while the interrupt was off is taken once it is enabled.
    if ((enabled >> n) & 1 && avr_regbit_get(avr, vec->raised) && !vec->pending) avr_raise_interrupt(avr, vec);
    self->updateLevel(n);
  }
}

void ExtInt::onFlagWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  auto* self = static_cast<ExtInt*>(param);
  const uint8_t clear = flagsWrittenOne(avr, addr, v);
  for (int n = 0; n < kLines; ++n) {
    avr_int_vector_t* vec = self->vector(n);
    if ((clear >> n) & 1 && avr_regbit_get(avr, vec->raised)) avr_clear_interrupt(avr, vec);
  }
}

}  // namespace sim
