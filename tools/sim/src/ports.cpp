// The ATmega2560's I/O ports with compare-output overrides: see sim/ports.hpp.
#include "sim/ports.hpp"

#include <stdexcept>
#include <string>

#include "sim/io_regs.hpp"

extern "C" {
#include <simavr/avr_ioport.h>
#include <simavr/sim_irq.h>
}

namespace sim {
namespace {

constexpr char kPortNames[] = "ABCDEFGHJKL";
constexpr uint8_t kModulatedBit = 7;  // PB7: OC0A and OC1C

avr_ioport_t* corePort(avr_t* avr, char name) {
  for (avr_io_t* io = avr->io_port; io; io = io->next)
    if (io->kind && std::string(io->kind) == "port" && reinterpret_cast<avr_ioport_t*>(io)->name == name)
      return reinterpret_cast<avr_ioport_t*>(io);
  return nullptr;
}

}  // namespace

Ports::Ports(avr_t* avr) : avr_(avr) {
  for (int i = 0; i < 11; ++i) {
    Port& p = ports_[i];
    p.owner = this;
    p.core = corePort(avr_, kPortNames[i]);
    if (!p.core)
      throw std::runtime_error(std::string("this simavr core has no PORT") + kPortNames[i] +
                               "; the board must be an atmega2560");
    takeIoWrite(avr_, p.core->r_port, &Ports::onPortWrite, &p);
    takeIoWrite(avr_, p.core->r_ddr, &Ports::onDdrWrite, &p);
    takeIoWrite(avr_, p.core->r_pin, &Ports::onPinWrite, &p);
    takeIoRead(avr_, p.core->r_pin, &Ports::onPinRead, &p);
  }
}

Ports::~Ports() {
  for (Port& p : ports_)
    for (uint16_t a : {p.core->r_port, p.core->r_ddr, p.core->r_pin}) releaseIo(avr_, a, &p);
}

Ports::Port* Ports::find(char port) {
  for (int i = 0; i < 11; ++i)
    if (kPortNames[i] == port) return &ports_[i];
  return nullptr;
}

const Ports::Port* Ports::find(char port) const { return const_cast<Ports*>(this)->find(port); }

avr_irq_t* Ports::pinIrq(char port, int bit) const {
  const Port* p = find(port);
  return p && bit >= 0 && bit < 8 ? p->core->io.irq + bit : nullptr;
}

bool Ports::level(char port, int bit) const {
  const avr_irq_t* irq = pinIrq(port, bit);
  return irq && irq->value != 0;
}

uint64_t Ports::changeCycle() const { return delivering_ ? delivering_cycle_ : avr_->cycle; }

uint8_t Ports::driven(const Port& p) const {
  const uint8_t port = avr_->data[p.core->r_port];
  uint8_t out = port;
  for (int b = 0; b < 8; ++b) {
    const auto& on = p.on[b];
    const auto& lv = p.level[b];
    if (!on[0] && !on[1]) continue;
    bool level;
    if (on[0] && on[1])  // the output compare modulator (PB7)
      level = (port >> b) & 1 ? (lv[0] || lv[1]) : (lv[0] && lv[1]);
    else
      level = on[0] ? lv[0] : lv[1];
    out = static_cast<uint8_t>(level ? out | (1u << b) : out & ~(1u << b));
  }
  return out;
}

// simavr's avr_ioport_update_irqs with the overrides: an output shows what drives it, an input
// what pulls it (outside, or its pull-up); a floating input keeps its level.
void Ports::update(Port& p) {
  avr_ioport_t* c = p.core;
  const uint8_t ddr = avr_->data[c->r_ddr];
  const uint8_t port = avr_->data[c->r_port];
  const uint8_t out = driven(p);
  p.asserted = 0;
  for (int b = 0; b < 8; ++b) {
    const uint8_t m = static_cast<uint8_t>(1u << b);
    if (ddr & m) {
      avr_raise_irq(c->io.irq + b, (out & m) ? 1 : 0);
      p.asserted |= m;
    } else if (c->external.pull_mask & m) {
      avr_raise_irq(c->io.irq + b, (c->external.pull_value & m) ? 1 : 0);
    } else if (port & m) {
      avr_raise_irq(c->io.irq + b, 1);
      p.asserted |= m;
    }
  }
  uint8_t pins = static_cast<uint8_t>((avr_->data[c->r_pin] & ~ddr) | (out & ddr));
  pins = static_cast<uint8_t>((pins & ~c->external.pull_mask) | c->external.pull_value);
  avr_raise_irq(c->io.irq + IOPORT_IRQ_PIN_ALL, pins);
}

void Ports::onPortWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  auto* p = static_cast<Port*>(param);
  avr_core_watch_write(avr, addr, v);
  avr_raise_irq(p->core->io.irq + IOPORT_IRQ_REG_PORT, v);
  p->owner->update(*p);
}

void Ports::onDdrWrite(avr_t* avr, uint16_t addr, uint8_t v, void* param) {
  auto* p = static_cast<Port*>(param);
  avr_raise_irq(p->core->io.irq + IOPORT_IRQ_DIRECTION_ALL, v);
  avr_core_watch_write(avr, addr, v);
  p->owner->update(*p);
}

void Ports::onPinWrite(avr_t* avr, uint16_t, uint8_t v, void* param) {
  auto* p = static_cast<Port*>(param);
  onPortWrite(avr, p->core->r_port, static_cast<uint8_t>(avr->data[p->core->r_port] ^ v), param);
}

uint8_t Ports::onPinRead(avr_t* avr, uint16_t addr, void* param) {
  auto* p = static_cast<Port*>(param);
  const uint8_t ddr = avr->data[p->core->r_ddr];
  const uint8_t v = static_cast<uint8_t>((avr->data[addr] & ~ddr) | (p->owner->driven(*p) & ddr));
  avr_raise_irq(p->core->io.irq + IOPORT_IRQ_REG_PIN, v);
  return v;
}

void Ports::setOverride(char port, int bit, int source, bool connected, bool level, uint64_t cycle) {
  Port* p = find(port);
  if (!p || bit < 0 || bit > 7 || source < 0 || source > 1) return;
  if (source == 1 && !(port == 'B' && bit == kModulatedBit))
    throw std::logic_error("a second compare output exists only on PB7");
  p->on[bit][source] = connected;
  p->level[bit][source] = level;
  deliver(cycle, *p, bit, -1);
}

void Ports::setInput(char port, int bit, bool level, uint64_t cycle) {
  Port* p = find(port);
  if (!p || bit < 0 || bit > 7) throw std::invalid_argument("setInput: no such pin");
  const auto mask = static_cast<uint8_t>(1u << bit);
  setExternalLevels(avr_, port, mask, level ? mask : 0);
  deliver(cycle, *p, bit, level ? 1 : 0);
}

void Ports::releaseInput(char port, int bit) {
  if (find(port) && bit >= 0 && bit < 8) clearExternalLevels(avr_, port, static_cast<uint8_t>(1u << bit));
}

void setExternalLevels(avr_t* avr, char port, uint8_t mask, uint8_t value) {
  avr_ioport_t* p = corePort(avr, port);
  if (!p) throw std::invalid_argument(std::string("this simavr core has no PORT") + port);
  p->external.pull_mask = static_cast<uint8_t>(p->external.pull_mask | mask);
  p->external.pull_value = static_cast<uint8_t>((p->external.pull_value & ~mask) | (value & mask));
}

void clearExternalLevels(avr_t* avr, char port, uint8_t mask) {
  avr_ioport_t* p = corePort(avr, port);
  if (!p) throw std::invalid_argument(std::string("this simavr core has no PORT") + port);
  p->external.pull_mask = static_cast<uint8_t>(p->external.pull_mask & ~mask);
  p->external.pull_value = static_cast<uint8_t>(p->external.pull_value & ~mask);
}

void Ports::deliver(uint64_t cycle, Port& p, int bit, int level) {
  const bool outer = delivering_;  // a listener may drive another pin meanwhile
  const uint64_t outer_cycle = delivering_cycle_;
  delivering_ = true;
  delivering_cycle_ = cycle;
  if (level < 0)
    update(p);
  else
    avr_raise_irq(p.core->io.irq + bit, static_cast<uint32_t>(level));
  delivering_ = outer;
  delivering_cycle_ = outer_cycle;
}

void Ports::afterReset() {
  // Every register is 0 again: all pins inputs without pull-up. What this board drove falls
  // to the level something outside holds it at, else 0; PINx reads the pins as they are.
  for (Port& p : ports_) {
    avr_ioport_t* c = p.core;
    for (auto& on : p.on) on = {false, false};
    for (int b = 0; b < 8; ++b) {
      const uint8_t m = static_cast<uint8_t>(1u << b);
      if (!(p.asserted & m)) continue;
      avr_raise_irq(c->io.irq + b, (c->external.pull_mask & m) ? (c->external.pull_value & m ? 1 : 0) : 0);
    }
    p.asserted = 0;
    uint8_t pins = 0;
    for (int b = 0; b < 8; ++b)
      if (c->io.irq[b].value) pins = static_cast<uint8_t>(pins | (1u << b));
    avr_->data[c->r_pin] = pins;
  }
}

}  // namespace sim
