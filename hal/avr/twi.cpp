// The TWI (I2C) master, interrupt-driven, after the ATmega2560 datasheet ch. 24 (its tables
// 24-3 and 24-4: what each status code means and what the master does next). The interrupt
// walks one transfer through its states; the main program only starts it and reads result().
//
//   register read:  08 START       -> SLA+W         18 SLA+W ack  -> register
//                   28 data ack    -> repeated START 10 rep. START -> SLA+R
//                   40 SLA+R ack   -> receive, ack unless last     50 byte, ack sent -> store
//                   58 byte, nack sent (the last) -> store, STOP
//   register write: 08 -> SLA+W, 18 -> register, 28 -> value, 28 -> STOP
//   20/30/48 no ack: STOP, kNack; 38 arbitration lost: let go, kLost; 00 and anything else:
//   STOP, kBusError.
// TWINT is write-one-to-clear and every TWCR write here sets it, so each write both answers the
// status and starts the next step; the TWI interrupt is level-triggered (pending while TWINT
// and TWIE are set): the STOP is written without TWIE, and no TWINT follows a STOP.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>
#include <util/delay.h>

#include "hal/hal.hpp"

namespace hal {
namespace detail {
volatile Twi::Result g_twi_state = Twi::Result::kIdle;
}  // namespace detail
}  // namespace hal

namespace {

using Result = hal::Twi::Result;

static_assert(hal::kTwiPins.port == 'D' && hal::kTwiPins.sda_bit == PD1 && hal::kTwiPins.scl_bit == PD0,
              "the ATmega2560's TWI pins: SDA PD1, SCL PD0");
constexpr uint8_t kSda = _BV(PD1);
constexpr uint8_t kScl = _BV(PD0);
constexpr uint8_t kNoStatus = 0xF8;  // TWSR's "no relevant state" code

constexpr uint8_t kGo = _BV(TWINT) | _BV(TWEN) | _BV(TWIE);

volatile Result& g_state = hal::detail::g_twi_state;
volatile uint8_t g_last_status = kNoStatus;
volatile uint8_t g_sla_write = 0;  // address << 1
volatile uint8_t g_register = 0;
volatile uint8_t g_value = 0;
volatile uint8_t g_read_length = 0;  // 0: a register write
volatile uint8_t g_sent = 0;         // bytes written after SLA+W (register, value)
volatile uint8_t g_received = 0;
volatile uint8_t g_rx[hal::Twi::kMaxRead];
volatile uint16_t g_end_ticks = 0;  // TCNT1 (the ESC frame's counter, 0.5 us) at the last end

// The interrupt's helpers are inlined: a call from an interrupt makes it save every
// call-clobbered register, 16 interrupts a read.
inline __attribute__((always_inline)) void finish(Result result) {
  TWCR = _BV(TWINT) | _BV(TWEN) | _BV(TWSTO);  // STOP; no TWIE: nothing follows
  g_end_ticks = TCNT1;  // interrupts are off here: one consistent 16-bit read
  g_state = result;
}

// After SLA+R ack or a byte acknowledged: receive the next byte, acknowledging it unless it is
// the last one.
inline __attribute__((always_inline)) void receiveNext() {
  const bool more_after = static_cast<uint8_t>(g_read_length - g_received) > 1;
  TWCR = more_after ? static_cast<uint8_t>(kGo | _BV(TWEA)) : kGo;
}

inline __attribute__((always_inline)) void store() {
  if (g_received < hal::Twi::kMaxRead) g_rx[g_received] = TWDR;
  g_received = static_cast<uint8_t>(g_received + 1);
}

bool start(uint8_t address, uint8_t reg, uint8_t value, uint8_t read_length) {
  bool started = false;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    // A STOP still pending (a slave holds SDA low) means the bus is not ours yet.
    if (g_state != Result::kBusy && !(TWCR & _BV(TWSTO))) {
      g_sla_write = static_cast<uint8_t>(address << 1);
      g_register = reg;
      g_value = value;
      g_read_length = read_length;
      g_sent = 0;
      g_received = 0;
      g_state = Result::kBusy;
      TWCR = kGo | _BV(TWSTA);
      started = true;
    }
  }
  return started;
}

}  // namespace

ISR(TWI_vect) {
  const uint8_t status = TWSR & 0xF8;
  g_last_status = status;
  switch (status) {
    case 0x08:  // START sent
      TWDR = g_sla_write;
      TWCR = kGo;
      break;
    case 0x10:  // repeated START sent
      TWDR = static_cast<uint8_t>(g_sla_write | 1u);
      TWCR = kGo;
      break;
    case 0x18:  // SLA+W acknowledged
      TWDR = g_register;
      g_sent = 1;
      TWCR = kGo;
      break;
    case 0x28:  // data byte acknowledged
      if (g_read_length != 0) {
        TWCR = kGo | _BV(TWSTA);  // repeated START, then read
      } else if (g_sent == 1) {
        TWDR = g_value;
        g_sent = 2;
        TWCR = kGo;
      } else {
        finish(Result::kDone);
      }
      break;
    case 0x40:  // SLA+R acknowledged
      receiveNext();
      break;
    case 0x50:  // byte received, ack sent
      store();
      receiveNext();
      break;
    case 0x58:  // byte received, nack sent: the last
      store();
      finish(Result::kDone);
      break;
    case 0x20:  // SLA+W not acknowledged
    case 0x30:  // data byte not acknowledged
    case 0x48:  // SLA+R not acknowledged
      finish(Result::kNack);
      break;
    case 0x38:  // arbitration lost: the bus is someone else's; let go without a STOP
      TWCR = _BV(TWINT) | _BV(TWEN);
      g_end_ticks = TCNT1;
      g_state = Result::kLost;
      break;
    default:  // 0x00 bus error (the datasheet's recovery is a STOP) or a status out of place
      finish(Result::kBusError);
      break;
  }
}

namespace hal {

void Twi::init(uint32_t scl_hz) {
  TWCR = 0;
  // No internal pull-ups: they pull to 5 V, the bus has its own to 3.3 V (docs/fly.md).
  PORTD &= static_cast<uint8_t>(~(kSda | kScl));
  TWSR = 0;  // prescaler 1 (TWPS = 0)
  TWBR = board::twiBitRateRegister(scl_hz);
  g_state = Result::kIdle;
  g_last_status = kNoStatus;
  TWCR = _BV(TWEN);
}

bool Twi::startWrite(uint8_t address, uint8_t reg, uint8_t value) { return start(address, reg, value, 0); }

bool Twi::startRead(uint8_t address, uint8_t reg, uint8_t length) {
  if (length == 0 || length > kMaxRead) return false;
  return start(address, reg, 0, length);
}


uint8_t Twi::lastStatus() { return g_last_status; }

static_assert(hal::board::escUsesTimer(1), "Esc::frameTimeUs's clock is Timer1 (esc_phase.cpp)");
uint16_t Twi::endFrameTimeUs() {
  uint16_t ticks;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { ticks = g_end_ticks; }
  return static_cast<uint16_t>(ticks / 2u);
}

uint8_t Twi::readData(uint8_t* dst, uint8_t length) {
  uint8_t n = g_received < length ? g_received : length;
  if (n > kMaxRead) n = kMaxRead;
  for (uint8_t i = 0; i < n; ++i) dst[i] = g_rx[i];
  return n;
}

void Twi::abort() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    TWCR = 0;  // off: the TWI lets go of both pins and forgets START/STOP requests
    TWCR = _BV(TWEN);
    if (g_state == Result::kBusy) g_state = Result::kAborted;
  }
}

bool Twi::recoverBus() {
  abort();
  TWCR = 0;  // the pins are port pins again: open drain by DDRD (PORTD stays 0)
  PORTD &= static_cast<uint8_t>(~(kSda | kScl));
  DDRD &= static_cast<uint8_t>(~(kSda | kScl));
  _delay_us(5);
  // Clock until the slave lets SDA go (at most one byte and its ack bit: 9 clocks).
  for (uint8_t i = 0; i < kRecoveryClocks && !(PIND & kSda); ++i) {
    DDRD |= kScl;
    _delay_us(5);
    DDRD &= static_cast<uint8_t>(~kScl);
    _delay_us(5);
  }
  // A STOP: SDA low while SCL is low, SCL high, then SDA high.
  DDRD |= kScl;
  _delay_us(5);
  DDRD |= kSda;
  _delay_us(5);
  DDRD &= static_cast<uint8_t>(~kScl);
  _delay_us(5);
  DDRD &= static_cast<uint8_t>(~kSda);
  _delay_us(5);
  const bool free = (PIND & (kSda | kScl)) == (kSda | kScl);
  TWCR = _BV(TWEN);
  return free;
}

}  // namespace hal
