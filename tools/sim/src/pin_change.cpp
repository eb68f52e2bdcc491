// The ATmega2560's pin-change interrupts: see sim/pin_change.hpp. Registers and vectors:
// ATmega2560 datasheet ch. 15.2 (PCICR, PCIFR, PCMSK0..2) and table 14-1 (vectors 9..11).
#include "sim/pin_change.hpp"

#include <stdexcept>
#include <string>

#include "sim/io_regs.hpp"

extern "C" {
#include <simavr/avr_ioport.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_interrupts.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>
}

namespace sim {
namespace {

constexpr uint16_t kPcifr = 0x3B;  // I/O 0x1B
constexpr uint16_t kPcicr = 0x68;
constexpr uint16_t kPcmsk[3] = {0x6B, 0x6C, 0x6D};
constexpr uint8_t kFirstVector = 9;  // PCINT0_vect; PCINT1_vect 10, PCINT2_vect 11
constexpr uint8_t kGroupBits = 0x07;

// Each group's pins in PCMSKn bit order: port and bit.
struct GroupPin {
  char port;
  uint8_t bit;
  uint8_t group;
  uint8_t mask_bit;
};
constexpr GroupPin kPins[24] = {
    {'B', 0, 0, 0}, {'B', 1, 0, 1}, {'B', 2, 0, 2}, {'B', 3, 0, 3},
    {'B', 4, 0, 4}, {'B', 5, 0, 5}, {'B', 6, 0, 6}, {'B', 7, 0, 7},
    {'E', 0, 1, 0}, {'J', 0, 1, 1}, {'J', 1, 1, 2}, {'J', 2, 1, 3},
    {'J', 3, 1, 4}, {'J', 4, 1, 5}, {'J', 5, 1, 6}, {'J', 6, 1, 7},
    {'K', 0, 2, 0}, {'K', 1, 2, 1}, {'K', 2, 2, 2}, {'K', 3, 2, 3},
    {'K', 4, 2, 4}, {'K', 5, 2, 5}, {'K', 6, 2, 6}, {'K', 7, 2, 7},
};

avr_regbit_t regbit(uint16_t reg, uint8_t bit) {
  avr_regbit_t r{};
  r.reg = reg;
  r.bit = bit;
  r.mask = 1;
  return r;
}

avr_ioport_t* portB(avr_t* avr) {
  for (avr_io_t* io = avr->io_port; io; io = io->next)
    if (io->kind && std::string(io->kind) == "port" && reinterpret_cast<avr_ioport_t*>(io)->name == 'B')
      return reinterpret_cast<avr_ioport_t*>(io);
  throw std::runtime_error("this simavr core has no PORTB; the board must be an atmega2560");
}

}  // namespace

PinChange::PinChange(avr_t* avr) : avr_(avr) {
  avr_ioport_t* portb = portB(avr_);
  portb->r_pcint = 0;  // simavr raises PCINT0 itself no more: this class does
  vectors_[0] = &portb->pcint;
  avr_int_table_t& table = avr_->interrupts;
  if (table.vector_count + 2 > static_cast<int>(sizeof table.vector / sizeof table.vector[0]))
    throw std::runtime_error("simavr's interrupt table is full; cannot add PCINT1/PCINT2");
  own_ = std::make_unique<avr_int_vector_t[]>(2);
  for (uint8_t g = 1; g <= 2; ++g) {
    avr_int_vector_t& v = own_[g - 1];
    v.vector = static_cast<uint8_t>(kFirstVector + g);
    v.enable = regbit(kPcicr, g);
    v.raised = regbit(kPcifr, g);
    avr_register_vector(avr_, &v);
    vectors_[g] = &v;
  }
  for (std::size_t i = 0; i < 24; ++i) {
    pins_[i] = PinParam{this, kPins[i].group, static_cast<uint8_t>(1u << kPins[i].mask_bit)};
    pin_irqs_[i] = avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(kPins[i].port), kPins[i].bit);
    avr_irq_register_notify(pin_irqs_[i], &PinChange::onPin, &pins_[i]);
  }
  takeIoWrite(avr_, kPcifr, &PinChange::onFlagWrite, this);
  takeIoWrite(avr_, kPcicr, &PinChange::onEnableWrite, this);
}

PinChange::~PinChange() {
  for (uint16_t a : {kPcifr, kPcicr}) releaseIo(avr_, a, this);
  for (std::size_t i = 0; i < 24; ++i) avr_irq_unregister_notify(pin_irqs_[i], &PinChange::onPin, &pins_[i]);
  avr_int_table_t& table = avr_->interrupts;
  int kept = 0;
  for (int i = 0; i < table.vector_count; ++i)
    if (table.vector[i] != vectors_[1] && table.vector[i] != vectors_[2]) table.vector[kept++] = table.vector[i];
  table.vector_count = static_cast<uint8_t>(kept);
  for (int g = 0; g < 2; ++g) avr_free_irq(own_[g].irq, AVR_INT_IRQ_COUNT);  // their names
  portB(avr_)->r_pcint = kPcmsk[0];
}

void PinChange::onPin(avr_irq_t* irq, uint32_t value, void* param) {
  // Called before simavr stores the new value: irq->value is the old level.
  const bool was = irq->value != 0, now = (value & 0xFF) != 0;
  if (was == now) return;
  const auto* p = static_cast<const PinParam*>(param);
  p->self->change(p->group, p->mask_bit);
}

void PinChange::change(uint8_t group, uint8_t mask_bit) {
  if (!(avr_->data[kPcmsk[group]] & mask_bit)) return;
  ++requests_[group];
  avr_raise_interrupt(avr_, vectors_[group]);  // sets PCIFn; requests the interrupt if PCIEn is set
}

void PinChange::onFlagWrite(avr_t* avr, uint16_t addr, uint8_t value, void* param) {
  auto* self = static_cast<PinChange*>(param);
  const uint8_t ones = flagsWrittenOne(avr, addr, value);  // SBI and CBI act on their bit only
  for (uint8_t g = 0; g < 3; ++g)
    if (ones & (1u << g)) avr_clear_interrupt(avr, self->vectors_[g]);  // write one to clear
  avr->data[kPcifr] &= kGroupBits;
}

void PinChange::onEnableWrite(avr_t* avr, uint16_t, uint8_t value, void* param) {
  auto* self = static_cast<PinChange*>(param);
  const uint8_t before = avr->data[kPcicr];
  avr->data[kPcicr] = static_cast<uint8_t>(value & kGroupBits);
  for (uint8_t g = 0; g < 3; ++g) {
    const uint8_t bit = static_cast<uint8_t>(1u << g);
    // A flag already set requests the interrupt as soon as its group is enabled.
    if ((value & bit) && !(before & bit) && (avr->data[kPcifr] & bit) && !self->vectors_[g]->pending)
      avr_raise_interrupt(avr, self->vectors_[g]);
  }
}

}  // namespace sim
