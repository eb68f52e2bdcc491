// The ATmega2560's timer registers on the simulated board (sim/timers.hpp): TCCRnA/B/C, the
// 16-bit registers through TEMP, TIMSKn, TIFRn, GTCCR's prescaler resets, PRR0/PRR1, ASSR.
#include <fmt/format.h>

#include "sim/io_regs.hpp"
#include "sim/ports.hpp"
#include "sim/timers.hpp"
#include "timers_parts.hpp"

extern "C" {
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_regbit.h>
}

namespace sim {

using namespace timers_detail;

// --- registers ---

void Timers::onWrite(avr_t*, uint16_t, uint8_t v, void* param) {
  auto* r = static_cast<Reg*>(param);
  r->owner->write(*r, v);
}

uint8_t Timers::onRead(avr_t*, uint16_t, void* param) {
  auto* r = static_cast<Reg*>(param);
  return r->owner->read(*r);
}

void Timers::write(const Reg& r, uint8_t v) {
  const uint64_t now = avr_->cycle;
  if (r.role == kPrescalerReset) return writePrescalerReset(v);
  if (r.role == kPowerReduction) {
    for (auto& up : units_)
      if (up->spec->prr == r.addr) advance(*up, now);
    avr_->data[r.addr] = v;
    for (auto& up : units_)
      if (up->spec->prr == r.addr) {
        setClock(*up);
        reschedule(*up);
      }
    return;
  }
  Unit& u = *r.unit;
  const Spec& s = *u.spec;
  advance(u, now);
  const uint16_t wide_value = static_cast<uint16_t>(u.temp << 8 | v);
  switch (r.role) {
    case kTccrA: case kTccrB: case kTccrC: return writeControl(u, r.role, v);
    case kTimsk: return writeTimsk(u, v);
    case kTifr: return writeTifr(u, r.addr, v);
    case kTcntHigh: case kIcrHigh: case kOcrHigh: u.temp = v; return;
    case kTcnt:
      u.model.writeCount(s.wide ? wide_value : v);
      avr_->data[s.tcnt] = v;
      if (s.wide) avr_->data[s.tcnt + 1] = u.temp;
      break;
    case kIcr:
      u.model.writeIcr(wide_value);
      avr_->data[s.icr] = v;
      avr_->data[s.icr + 1] = u.temp;
      break;
    case kOcr: {
      u.model.writeOcr(r.ch, s.wide ? wide_value : v);
      const uint16_t reads = u.model.ocr(r.ch);
      avr_->data[s.ocr[r.ch]] = static_cast<uint8_t>(reads);
      if (s.wide) avr_->data[s.ocr[r.ch] + 1] = static_cast<uint8_t>(reads >> 8);
      break;
    }
    case kAsyncStatus: avr_->data[kAssr] = static_cast<uint8_t>(v & (kAs2 | kExclk)); break;
    default: break;
  }
  reschedule(u);
}

uint8_t Timers::read(const Reg& r) {
  Unit& u = *r.unit;
  advance(u, avr_->cycle);
  switch (r.role) {
    case kTcnt: {
      const uint16_t c = u.model.count();
      u.temp = static_cast<uint8_t>(c >> 8);
      return static_cast<uint8_t>(c);
    }
    case kIcr: {
      const uint16_t c = u.model.icr();
      u.temp = static_cast<uint8_t>(c >> 8);
      return static_cast<uint8_t>(c);
    }
    case kTcntHigh: case kIcrHigh: return u.temp;
    case kOcr: return static_cast<uint8_t>(u.model.ocr(r.ch));
    case kOcrHigh: return static_cast<uint8_t>(u.model.ocr(r.ch) >> 8);
    default: return avr_->data[r.addr];
  }
}

// TCCRnA/B/C: mode, outputs, clock; the FOCnx strobes (TCCRnC, or TCCRnB bits 7:6 on the
// 8-bit timers) read as 0.
void Timers::writeControl(Unit& u, int which, uint8_t v) {
  const Spec& s = *u.spec;
  uint8_t strobes = 0;  // bit ch: FOCnx
  const uint8_t old_cs = avr_->data[s.tccrb] & 7;
  if (which == kTccrA) {
    avr_->data[s.tccra] = v;
  } else if (which == kTccrB) {
    if (!s.wide) strobes = static_cast<uint8_t>(((v >> 7) & 1) | ((v >> 5) & 2));
    avr_->data[s.tccrb] = static_cast<uint8_t>(v & (s.wide ? 0xDF : 0x0F));
  } else {
    strobes = static_cast<uint8_t>(((v >> 7) & 1) | ((v >> 5) & 2) | ((v >> 3) & 4));
    avr_->data[s.tccrc] = 0;
  }
  const uint8_t a = avr_->data[s.tccra], b = avr_->data[s.tccrb];
  u.model.setWgm(static_cast<uint8_t>((a & 3) | ((b >> 1) & (s.wide ? 0x0C : 0x04))));
  for (int ch = 0; ch < s.channels; ++ch) u.model.setCom(ch, static_cast<uint8_t>(a >> (6 - 2 * ch)));
  for (int ch = 0; ch < s.channels; ++ch)
    if ((strobes >> ch) & 1) u.model.force(ch);
  if ((b & 7) != old_cs) setClock(u);
  for (int ch = 0; ch < s.channels; ++ch) drive(u, ch, avr_->cycle);  // COM connects or lets go
  reschedule(u);
}

void Timers::setClock(Unit& u) {
  const Spec& s = *u.spec;
  const uint8_t cs = avr_->data[s.tccrb] & 7;
  u.external = !s.async && cs >= 6;
  u.prescaler = (s.async ? kAsyncDivisor : kSyncDivisor)[cs];
  const bool gated = (avr_->data[s.prr] >> s.prr_bit) & 1;
  const bool held = u.prescaler > 1 && (s.async ? async_held_ : sync_held_);
  if (u.prescaler == 0 || gated || held)
    u.next_tick = kNever;
  else
    u.next_tick = nextAligned(avr_->cycle, s.async ? async_base_ : sync_base_, u.prescaler);
}

void Timers::writePrescalerReset(uint8_t v) {
  const uint64_t now = avr_->cycle;
  for (auto& up : units_) advance(*up, now);
  const bool tsm = v & kTsm;
  const bool sync_held = tsm && (v & kPsrsync), async_held = tsm && (v & kPsrasy);
  if ((v & kPsrsync) || (sync_held_ && !sync_held)) sync_base_ = now;  // reset, or let go
  if ((v & kPsrasy) || (async_held_ && !async_held)) async_base_ = now;
  sync_held_ = sync_held;
  async_held_ = async_held;
  avr_->data[kGtccr] = tsm ? static_cast<uint8_t>(v & (kTsm | kPsrasy | kPsrsync)) : 0;
  for (auto& up : units_) {
    setClock(*up);
    reschedule(*up);
  }
}

void Timers::writeTimsk(Unit& u, uint8_t v) {
  const uint8_t enabled = static_cast<uint8_t>(v & ~avr_->data[u.spec->timsk]);
  avr_->data[u.spec->timsk] = v;
  // A flag set while its interrupt was off is taken once enabled (simavr 1.6 forgets it).
  auto take = [&](avr_int_vector_t* vec, int bit) {
    if (vec && ((enabled >> bit) & 1) && avr_regbit_get(avr_, vec->raised) && !vec->pending)
      avr_raise_interrupt(avr_, vec);
  };
  take(u.overflow, 0);
  for (int ch = 0; ch < u.spec->channels; ++ch) take(u.compare[ch], ch + 1);
  take(u.capture, kTifrCaptureBit);
}

void Timers::writeTifr(Unit& u, uint16_t addr, uint8_t v) {
  const uint8_t clear = flagsWrittenOne(avr_, addr, v);
  auto clearFlag = [&](avr_int_vector_t* vec, int bit) {
    if (vec && ((clear >> bit) & 1) && avr_regbit_get(avr_, vec->raised)) avr_clear_interrupt(avr_, vec);
  };
  clearFlag(u.overflow, 0);
  for (int ch = 0; ch < u.spec->channels; ++ch) clearFlag(u.compare[ch], ch + 1);
  clearFlag(u.capture, kTifrCaptureBit);
}

}  // namespace sim
