// The ATmega2560's TWI in master mode: see sim/twi.hpp. Status codes and register rules:
// ATmega2560 datasheet ch. 24 (tables 24-2 to 24-4: master transmitter and receiver).
#include "sim/twi.hpp"

#include <cstring>
#include <stdexcept>

#include "hal/board.hpp"
#include "sim/ports.hpp"

extern "C" {
#include <simavr/avr_ioport.h>
#include <simavr/avr_twi.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_interrupts.h>
#include <simavr/sim_irq.h>
}

namespace sim {
namespace {

// ATmega2560 TWI registers (data space addresses) and TWCR bits.
constexpr uint16_t kTwbr = 0xB8, kTwsr = 0xB9, kTwdr = 0xBB, kTwcr = 0xBC;
constexpr uint8_t kTwint = 0x80, kTwea = 0x40, kTwsta = 0x20, kTwsto = 0x10, kTwwc = 0x08,
                  kTwen = 0x04, kTwie = 0x01;
constexpr uint8_t kTwcrWritable = kTwea | kTwsta | kTwsto | kTwen | kTwie;
constexpr uint8_t kTwpsMask = 0x03;

// Status codes (datasheet tables 24-2, 24-3, 24-4).
constexpr uint8_t kStart = 0x08, kRepStart = 0x10, kSlaWAck = 0x18, kSlaWNack = 0x20,
                  kDataTxAck = 0x28, kDataTxNack = 0x30, kArbitrationLost = 0x38,
                  kSlaRAck = 0x40, kSlaRNack = 0x48, kDataRxAck = 0x50, kDataRxNack = 0x58,
                  kNoState = 0xF8;

const char* kTwiIrqNames[TWI_IRQ_COUNT] = {"8<twi.chip.in", "32>twi.chip.out", "8>twi.chip.status"};

avr_int_vector_t* coreTwiVector(avr_t* avr) {
  for (avr_io_t* io = avr->io_port; io; io = io->next)
    if (io->kind && std::strcmp(io->kind, "twi") == 0) return &reinterpret_cast<avr_twi_t*>(io)->twi;
  return nullptr;
}

// Bits of `byte` sent MSB first until the first 1 (which a held-low SDA makes the master
// lose), or 0 when the byte has no 1.
int bitsUntilFirstOne(uint8_t byte) {
  for (int k = 0; k < 8; ++k)
    if (byte & (0x80 >> k)) return k + 1;
  return 0;
}

}  // namespace

Twi::Twi(avr_t* avr) : avr_(avr) {
  vector_ = coreTwiVector(avr_);
  if (!vector_) throw std::runtime_error("this simavr core has no TWI; the board must be an atmega2560");
  irq_ = avr_alloc_irq(&avr_->irq_pool, 0, TWI_IRQ_COUNT, kTwiIrqNames);
  avr_irq_register_notify(irq_ + TWI_IRQ_INPUT, &Twi::onSlaveAnswer, this);
  avr_irq_register_notify(vector_->irq + AVR_INT_IRQ_RUNNING, &Twi::onVectorRunning, this);
  const uint32_t port = AVR_IOCTL_IOPORT_GETIRQ(hal::kTwiPins.port);
  scl_pin_ = avr_io_getirq(avr_, port, hal::kTwiPins.scl_bit);
  sda_pin_ = avr_io_getirq(avr_, port, hal::kTwiPins.sda_bit);
  avr_irq_register_notify(scl_pin_, &Twi::onSclPin, this);
  // simavr refuses to override a registered handler (avr_register_io_*); the table is public.
  auto& control = avr_->io[AVR_DATA_TO_IO(kTwcr)];
  control.w.c = &Twi::onControlWrite;
  control.w.param = this;
  auto& data = avr_->io[AVR_DATA_TO_IO(kTwdr)];
  data.w.c = &Twi::onDataWrite;
  data.w.param = this;
  data.r.c = &Twi::onDataRead;
  data.r.param = this;
  auto& status = avr_->io[AVR_DATA_TO_IO(kTwsr)];
  status.w.c = &Twi::onStatusWrite;
  status.w.param = this;
  afterReset();
}

Twi::~Twi() {
  avr_cycle_timer_cancel(avr_, &Twi::onOpDone, this);
  avr_cycle_timer_cancel(avr_, &Twi::onAfterResetCycle, this);
  avr_irq_unregister_notify(scl_pin_, &Twi::onSclPin, this);
  avr_irq_unregister_notify(vector_->irq + AVR_INT_IRQ_RUNNING, &Twi::onVectorRunning, this);
  for (uint16_t a : {kTwcr, kTwdr, kTwsr}) {
    auto& io = avr_->io[AVR_DATA_TO_IO(a)];
    if (io.w.param == this) io.w = {nullptr, nullptr};
    if (io.r.param == this) io.r = {nullptr, nullptr};
  }
  avr_free_irq(irq_, TWI_IRQ_COUNT);
}

uint8_t& Twi::reg(uint16_t addr) { return avr_->data[addr]; }

uint64_t Twi::bitCycles() const {
  const uint8_t twps = avr_->data[kTwsr] & kTwpsMask;
  return 16u + 2u * static_cast<uint64_t>(avr_->data[kTwbr]) * (1u << (2u * twps));
}

uint8_t Twi::status() const { return avr_->data[kTwsr] & 0xF8; }

void Twi::afterReset() {
  // avr_reset() zeroed the registers and cancelled every cycle timer.
  busy_ = master_ = start_waiting_ = reading_ = slave_acked_ = slave_released_ = false;
  bus_held_ = sda_low_;
  reg(kTwsr) = kNoState;
  reg(kTwdr) = 0xFF;
  // The core's own peripherals reset after this call: the lines are set up again one cycle
  // later.
  if (pull_ups_) avr_cycle_timer_register(avr_, 1, &Twi::onAfterResetCycle, this);
}

uint64_t Twi::onAfterResetCycle(avr_t*, uint64_t, void* param) {
  static_cast<Twi*>(param)->applyLines();
  return 0;
}

// --- registers ---

void Twi::onControlWrite(avr_t*, uint16_t, uint8_t v, void* param) {
  static_cast<Twi*>(param)->writeControl(v);
}

void Twi::writeControl(uint8_t v) {
  uint8_t& twcr = reg(kTwcr);
  const uint8_t old = twcr;
  const bool twint_was = (old & kTwint) != 0;
  const bool cleared = twint_was && (v & kTwint);
  twcr = static_cast<uint8_t>((v & kTwcrWritable) | (old & kTwwc) | (twint_was && !cleared ? kTwint : 0));
  if (!(twcr & kTwen)) {
    if (old & kTwen) switchOff();
    return;
  }
  if (cleared) avr_clear_interrupt(avr_, vector_);
  raiseLevelInterrupt();
  if (!(twcr & kTwint) && !busy_) startNext(cleared);
}

void Twi::onDataWrite(avr_t* avr, uint16_t addr, uint8_t v, void*) {
  // Writable only while TWINT is set (no byte is being shifted); otherwise TWWC.
  uint8_t& twcr = avr->data[kTwcr];
  if (twcr & kTwint) {
    avr->data[addr] = v;
    twcr = static_cast<uint8_t>(twcr & ~kTwwc);
  } else {
    twcr = static_cast<uint8_t>(twcr | kTwwc);
  }
}

uint8_t Twi::onDataRead(avr_t* avr, uint16_t addr, void*) { return avr->data[addr]; }

void Twi::onStatusWrite(avr_t* avr, uint16_t addr, uint8_t v, void*) {
  avr->data[addr] = static_cast<uint8_t>((avr->data[addr] & 0xF8) | (v & kTwpsMask));
}

void Twi::switchOff() {
  // TWEN written to zero: every transmission ends, whatever it was doing.
  avr_cycle_timer_cancel(avr_, &Twi::onOpDone, this);
  if (master_ && !sda_low_) toSlaves(TWI_COND_STOP, 0, 1);  // the lines are released
  busy_ = master_ = start_waiting_ = false;
  reg(kTwsr) = static_cast<uint8_t>(kNoState | (reg(kTwsr) & kTwpsMask));
  avr_clear_interrupt(avr_, vector_);
}

// --- operations ---

void Twi::startNext(bool twint_cleared) {
  const uint8_t twcr = reg(kTwcr);
  if (twcr & kTwsto) {
    beginStop();
  } else if (twcr & kTwsta) {
    beginStart();
  } else if (twint_cleared && master_) {
    beginByte();
  }
}

void Twi::begin(TwiOp op, uint64_t after_cycles, uint8_t status) {
  op_ = op;
  op_status_ = status;
  busy_ = true;
  record(TwiEvent::What::kOpStart, static_cast<uint8_t>(op));
  avr_cycle_timer_register(avr_, after_cycles, &Twi::onOpDone, this);
}

void Twi::beginStart() {
  op_sets_data_ = op_lost_ = false;
  op_sets_twint_ = true;
  if (master_) {  // repeated START: SDA must rise first, which a held-low SDA forbids
    op_lost_ = sda_low_;
    begin(TwiOp::kRepeatedStart, bitCycles(), sda_low_ ? kArbitrationLost : kRepStart);
  } else if (bus_held_) {
    start_waiting_ = true;  // the TWI waits for a STOP on the bus before its START
  } else {
    start_waiting_ = false;
    begin(TwiOp::kStart, bitCycles(), kStart);
  }
}

void Twi::beginByte() {
  const uint8_t data = reg(kTwdr);
  const uint64_t bit = bitCycles();
  op_sets_data_ = op_lost_ = false;
  op_sets_twint_ = true;
  const bool address = op_ == TwiOp::kStart || op_ == TwiOp::kRepeatedStart;
  const bool receive = !address && reading_;
  if (sda_low_) {
    // Nothing reaches the slaves; a 1 the master sends (a bit, or the NACK) is lost.
    const bool nack_out = receive && !(reg(kTwcr) & kTwea);
    const int lost_at = receive ? (nack_out ? 9 : 0) : bitsUntilFirstOne(data);
    op_lost_ = lost_at > 0;
    op_sets_data_ = receive;
    op_data_ = 0x00;
    const uint8_t held = address ? (data & 1 ? kSlaRAck : kSlaWAck) : receive ? kDataRxAck : kDataTxAck;
    begin(address ? TwiOp::kAddress : receive ? TwiOp::kRead : TwiOp::kWrite,
          (op_lost_ ? lost_at : 9) * bit, op_lost_ ? kArbitrationLost : held);
    return;
  }
  answer_ack_ = answer_read_ = false;
  answer_data_ = 0xFF;
  if (address) {
    reading_ = data & 1;
    slave_released_ = false;
    toSlaves(TWI_COND_START | TWI_COND_ADDR, data, 0);
    slave_acked_ = answer_ack_;
    begin(TwiOp::kAddress, 9 * bit,
          reading_ ? (slave_acked_ ? kSlaRAck : kSlaRNack) : (slave_acked_ ? kSlaWAck : kSlaWNack));
  } else if (!reading_) {
    if (slave_acked_) toSlaves(TWI_COND_WRITE, 0, data);
    begin(TwiOp::kWrite, 9 * bit, answer_ack_ ? kDataTxAck : kDataTxNack);
  } else {
    const bool ack = (reg(kTwcr) & kTwea) != 0;
    if (slave_acked_ && !slave_released_)
      toSlaves(static_cast<uint8_t>(TWI_COND_READ | (ack ? TWI_COND_ACK : 0)), 0, 0);
    if (!ack) slave_released_ = true;  // after a NACK the slave lets SDA go
    op_sets_data_ = true;
    op_data_ = answer_read_ ? answer_data_ : 0xFF;
    begin(TwiOp::kRead, 9 * bit, ack ? kDataRxAck : kDataRxNack);
  }
}

void Twi::beginStop() {
  op_sets_data_ = op_lost_ = false;
  op_sets_twint_ = false;
  if (!master_) {
    // Not the bus master (after a lost arbitration): TWSTO only resets the TWI, no STOP.
    reg(kTwcr) = static_cast<uint8_t>(reg(kTwcr) & ~kTwsto);
    if (reg(kTwcr) & kTwsta) beginStart();
    return;
  }
  if (!sda_low_) toSlaves(TWI_COND_STOP, 0, 1);
  begin(TwiOp::kStop, bitCycles(), kNoState);
}

uint64_t Twi::onOpDone(avr_t*, uint64_t when, void* param) {
  static_cast<Twi*>(param)->finish(when);
  return 0;
}

void Twi::finish(uint64_t when) {
  busy_ = false;
  reg(kTwsr) = static_cast<uint8_t>(op_status_ | (reg(kTwsr) & kTwpsMask));
  avr_raise_irq(irq_ + TWI_IRQ_STATUS, op_status_);
  // The cycle it was due (simavr runs the timer at the next instruction boundary).
  if (tracing_) trace_.push_back(TwiEvent{when, TwiEvent::What::kStatus, op_status_});
  if (op_ == TwiOp::kStop) {
    // TWSTO clears itself; no TWINT. A held-low SDA makes no STOP: the bus stays busy.
    master_ = false;
    bus_held_ = sda_low_;
    uint8_t& twcr = reg(kTwcr);
    twcr = static_cast<uint8_t>(twcr & ~kTwsto);
    if ((twcr & kTwsta) && (twcr & kTwen)) beginStart();
    return;
  }
  if (op_lost_) {
    master_ = false;  // another device owns the bus now
    bus_held_ = true;
  } else if (op_ == TwiOp::kStart || op_ == TwiOp::kRepeatedStart) {
    master_ = true;
  }
  if (op_sets_data_) reg(kTwdr) = op_data_;
  reg(kTwcr) = static_cast<uint8_t>(reg(kTwcr) | kTwint);
  raiseLevelInterrupt();
}

void Twi::raiseLevelInterrupt() {
  const uint8_t twcr = reg(kTwcr);
  if ((twcr & kTwen) && (twcr & kTwint) && (twcr & kTwie)) avr_raise_interrupt(avr_, vector_);
}

void Twi::onVectorRunning(avr_irq_t*, uint32_t value, void* param) {
  // A RETI: the request is still active while TWINT and TWIE stay set.
  if (value == 0) static_cast<Twi*>(param)->raiseLevelInterrupt();
}

// --- slaves ---

void Twi::toSlaves(uint8_t msg, uint8_t addr, uint8_t data) {
  avr_raise_irq(irq_ + TWI_IRQ_OUTPUT, avr_twi_irq_msg(msg, addr, data));
}

void Twi::onSlaveAnswer(avr_irq_t*, uint32_t value, void* param) {
  auto* self = static_cast<Twi*>(param);
  avr_twi_msg_irq_t m;
  m.u.v = value;
  if (m.u.twi.msg & TWI_COND_ACK) self->answer_ack_ = (m.u.twi.data & 1) != 0;
  if (m.u.twi.msg & TWI_COND_READ) {
    self->answer_read_ = true;
    self->answer_data_ = m.u.twi.data;
  }
}

// --- lines ---

void Twi::setPullUps(bool on) {
  pull_ups_ = on;
  applyLines();
}

void Twi::holdSdaLow(int release_after_scl_clocks) {
  sda_low_ = true;
  bus_held_ = true;
  release_clocks_left_ = release_after_scl_clocks;
  applyLines();
}

void Twi::releaseSda() {
  if (!sda_low_) return;
  sda_low_ = false;
  release_clocks_left_ = 0;
  applyLines();
  busFreed();
}

void Twi::busFreed() {
  // SDA rising while SCL is high is a STOP on the bus: every slave resets, the bus is free.
  toSlaves(TWI_COND_STOP, 0, 1);
  if (master_) return;
  bus_held_ = false;
  const uint8_t twcr = reg(kTwcr);
  if (start_waiting_ && !busy_ && (twcr & kTwen) && (twcr & kTwsta) && !(twcr & kTwint)) beginStart();
}

void Twi::applyLines() {
  const uint8_t sda = static_cast<uint8_t>(1u << hal::kTwiPins.sda_bit);
  const uint8_t scl = static_cast<uint8_t>(1u << hal::kTwiPins.scl_bit);
  if (!pull_ups_) {  // nothing on the bus: the pins float as simavr has them
    clearExternalLevels(avr_, hal::kTwiPins.port, sda | scl);
    return;
  }
  // INT0/INT1 share the pins: sim::ExtInt follows their levels without polling them.
  setExternalLevels(avr_, hal::kTwiPins.port, sda | scl, static_cast<uint8_t>((sda_low_ ? 0 : sda) | scl));
  avr_ioport_state_t st{};
  avr_ioctl(avr_, AVR_IOCTL_IOPORT_GETSTATE(hal::kTwiPins.port), &st);
  const bool scl_driven_low = (st.ddr & scl) && !(st.port & scl);
  avr_raise_irq(scl_pin_, scl_driven_low ? 0 : 1);
  avr_raise_irq(sda_pin_, sda_low_ ? 0 : 1);
}

void Twi::onSclPin(avr_irq_t* irq, uint32_t value, void* param) {
  auto* self = static_cast<Twi*>(param);
  const bool rising = irq->value == 0 && value != 0;
  const bool gpio = !(self->avr_->data[kTwcr] & kTwen);
  if (!rising || !gpio || !self->sda_low_ || self->release_clocks_left_ <= 0) return;
  if (--self->release_clocks_left_ == 0) self->releaseSda();
}

void Twi::record(TwiEvent::What what, uint8_t value) {
  if (tracing_) trace_.push_back(TwiEvent{avr_->cycle, what, value});
}

}  // namespace sim
