// Fake HAL backend for host tests: implements hal.hpp on plain memory and a simulated
// millisecond clock, controlled and observed through fake.hpp. Host only (STL allowed).
//
// Differences from the AVR backend, on purpose:
//  - the UART receive buffer is unbounded (the AVR ring buffer holds 64 bytes and marks what it
//    loses as damage): tests may feed whole scripts at once, and damage with feedDamage();
//  - transmitting takes no time and never waits (so the wait hook is never called);
//  - an EEPROM address outside 0..4095 throws std::out_of_range (the AVR would wrap around
//    silently): such an access is a bug in the code under test;
//  - an ADC conversion takes no simulated time (104 us on the AVR) unless a test sets one
//    (setAdcConversionUs): then conversions move a microsecond clock within the millisecond,
//    and every whole millisecond they fill runs as a wait does;
//  - a TWI transfer takes none either: it ends inside its start call (about 0.5 ms for a
//    15-byte read at 400 kHz on the AVR), unless the fake holds SDA low;
//  - time moves in whole milliseconds, so the ESC phase hook runs up to 1 ms after its time.
#include <stdexcept>
#include <string>
#include <utility>

#include "fake_state.hpp"

using namespace hal::fake::detail;

namespace hal {

// ---- Clock ----
void Clock::init() {}
uint32_t Clock::millis() { return state().now_ms; }
uint32_t Clock::micros() { return state().now_ms * 1000u + state().sub_us; }
void Clock::delayMs(uint16_t ms) { waitMs(ms); }
void Clock::sleepUntilInterrupt() { waitMs(1); }
void Clock::sleepUnless(bool (*pending)()) {
  if (pending == nullptr || !pending()) waitMs(1);  // work pending: back at once, no time passes
}
void Clock::sleepUntil(bool (*ready)()) {
  while (!ready()) waitMs(1);  // the time limit ends a wait for what never comes
}

// ---- Adc ----
void Adc::init() {}
uint16_t Adc::readCounts(uint8_t channel) {
  auto& s = state();
  if (channel >= kAdcChannels) {
    throw std::out_of_range("fake HAL: ADC channel " + std::to_string(channel) +
                            " does not exist (0..15)");
  }
  ++s.adc_conversions;
  if (s.adc_conversion_us != 0) {  // the conversion takes its time, then reads
    s.sub_us = static_cast<uint16_t>(s.sub_us + s.adc_conversion_us);
    while (s.sub_us >= 1000) {
      s.sub_us = static_cast<uint16_t>(s.sub_us - 1000);
      waitMs(1);
    }
  }
  if (s.adc_source) return clampCounts(s.adc_source(channel));
  return s.adc_counts[channel];
}

// ---- Esc ----
void Esc::init(uint16_t frame_hz) {
  auto& s = state();
  if (!setFrameRate(frame_hz)) s.frame_hz = kEscDefaultFrameHz;
  for (auto& p : s.pulse_us) p = 1000;
}

bool Esc::setFrameRate(uint16_t frame_hz) {
  if (frame_hz < kEscMinFrameHz || frame_hz > kEscMaxFrameHz) return false;
  state().frame_hz = frame_hz;
  schedulePhase(static_cast<uint64_t>(state().now_ms) * 1000u);
  return true;
}

void Esc::setPhaseHook(uint16_t at_us, PhaseHook hook) {
  auto& s = state();
  s.phase_hook = hook;
  s.phase_us = at_us;
  schedulePhase(static_cast<uint64_t>(s.now_ms) * 1000u);
}

uint16_t Esc::frameTimeUs() {
  const uint32_t period = framePeriodUs();
  return period == 0 ? 0
                     : static_cast<uint16_t>((static_cast<uint64_t>(state().now_ms) * 1000u + state().sub_us) % period);
}

uint16_t Esc::frameRateHz() { return state().frame_hz; }

void Esc::writePulse(uint8_t channel, uint16_t pwm_us) {
  if (channel >= kEscChannels) return;  // same as the AVR backend: ignored
  if (pwm_us < kPulseClampMinUs) pwm_us = kPulseClampMinUs;
  if (pwm_us > kPulseClampMaxUs) pwm_us = kPulseClampMaxUs;
  state().pulse_us[channel] = pwm_us;
}

void Esc::writeAll(const uint16_t (&pwm_us)[kEscChannels]) {
  ++state().esc_write_alls;
  for (uint8_t ch = 0; ch < kEscChannels; ++ch) writePulse(ch, pwm_us[ch]);
}

uint16_t Esc::pulseUs(uint8_t channel) {
  return channel < kEscChannels ? state().pulse_us[channel] : 0;
}

// ---- Twi ----
namespace {

hal::Twi::Result endTransfer(hal::Twi::Result result, uint8_t status) {
  state().twi_result = result;
  state().twi_status = status;
  state().twi_end_frame_us = hal::Esc::frameTimeUs();
  return result;
}

// Serves a transfer as the chip would, at once: false while the bus is held (it never ends).
bool serveTransfer(uint8_t address, uint8_t reg, uint8_t value, uint8_t read_length) {
  auto& s = state();
  if (s.twi_result == hal::Twi::Result::kBusy) return false;
  s.twi_received = 0;
  if (read_length != 0) ++s.twi_reads;
  if (s.twi_sda_low) {  // START never completes
    s.twi_result = hal::Twi::Result::kBusy;
    return true;
  }
  if (!s.twi_slave || s.twi_nack || address != s.twi_address) {
    endTransfer(hal::Twi::Result::kNack, 0x20);
    return true;
  }
  reg &= 0x7F;
  if (read_length == 0) {
    s.twi_registers[reg] = value;
    s.twi_writes.push_back({reg, value});
    endTransfer(hal::Twi::Result::kDone, 0x28);
    return true;
  }
  if (s.twi_read_hook) s.twi_read_hook(reg, read_length);
  for (uint8_t i = 0; i < read_length; ++i) {
    const uint8_t r = static_cast<uint8_t>((reg + i) & 0x7F);
    s.twi_rx[i] = s.twi_registers[r];
    if (r == s.twi_clear_on_read) s.twi_registers[r] = 0;
  }
  s.twi_received = read_length;
  endTransfer(hal::Twi::Result::kDone, 0x58);
  return true;
}

}  // namespace

void Twi::init(uint32_t scl_hz) {
  auto& s = state();
  s.twi_scl_hz = scl_hz;
  s.twi_result = Result::kIdle;
  s.twi_status = 0xF8;
}

bool Twi::startWrite(uint8_t address, uint8_t reg, uint8_t value) {
  return serveTransfer(address, reg, value, 0);
}

bool Twi::startRead(uint8_t address, uint8_t reg, uint8_t length) {
  if (length == 0 || length > kMaxRead) return false;
  return serveTransfer(address, reg, 0, length);
}

Twi::Result Twi::result() { return state().twi_result; }
uint8_t Twi::lastStatus() { return state().twi_status; }
uint16_t Twi::endFrameTimeUs() { return state().twi_end_frame_us; }

uint8_t Twi::readData(uint8_t* dst, uint8_t length) {
  auto& s = state();
  const uint8_t n = s.twi_received < length ? s.twi_received : length;
  for (uint8_t i = 0; i < n; ++i) dst[i] = s.twi_rx[i];
  return n;
}

void Twi::abort() {
  auto& s = state();
  if (s.twi_result == Result::kBusy) {
    s.twi_result = Result::kAborted;
    ++s.twi_aborts;
  }
}

bool Twi::recoverBus() {
  auto& s = state();
  abort();
  ++s.twi_recoveries;
  if (s.twi_sda_low && s.twi_release_clocks != 0 && s.twi_release_clocks <= kRecoveryClocks) {
    s.twi_sda_low = false;
  }
  return !s.twi_sda_low;
}

// ---- Eeprom ----
uint8_t Eeprom::readByte(uint16_t addr) {
  checkEepromAddress(addr, 1);
  return state().eeprom[addr];
}

void Eeprom::updateByte(uint16_t addr, uint8_t value) {
  checkEepromAddress(addr, 1);
  auto& s = state();
  if (s.eeprom[addr] == value) return;
  s.eeprom[addr] = value;
  ++s.eeprom_writes;
}

void Eeprom::readBlock(uint16_t addr, void* dst, uint16_t length) {
  checkEepromAddress(addr, length);
  auto* out = static_cast<uint8_t*>(dst);
  for (uint16_t i = 0; i < length; ++i) out[i] = state().eeprom[addr + i];
}

void Eeprom::updateBlock(uint16_t addr, const void* src, uint16_t length) {
  checkEepromAddress(addr, length);
  const auto* in = static_cast<const uint8_t*>(src);
  for (uint16_t i = 0; i < length; ++i) updateByte(static_cast<uint16_t>(addr + i), in[i]);
}

// ---- Uart ----
void Uart::init(uint32_t) {}
bool Uart::available() { return !state().rx.empty(); }

int16_t Uart::read() {
  auto& rx = state().rx;
  if (rx.empty()) return kNothing;
  const int16_t item = rx.front();
  rx.pop_front();
  return item;
}

void Uart::write(uint8_t byte) { state().tx.push_back(static_cast<char>(byte)); }
void Uart::print(const char* text) {
  if (text) state().tx.append(text);
}
void Uart::printP(const char* progmem_text) { print(progmem_text); }
void Uart::setWaitHook(WaitHook hook) { state().wait_hook = hook; }
uint16_t Uart::rxDamageCount() { return state().rx_damage; }

// ---- Watchdog, Stack ----
void Watchdog::start() { state().watchdog_started = true; }
void Watchdog::kick() { ++state().watchdog_kicks; }
uint8_t Watchdog::resetFlags() { return state().reset_flags; }
uint16_t Stack::sizeBytes() { return state().stack_size; }
uint16_t Stack::untouchedBytes(void (*yield)()) {
  if (yield != nullptr) yield();
  return state().stack_untouched;
}

}  // namespace hal

namespace hal {

void Rc::init(uint8_t mask) {
  auto& s = state();
  s.rc_mask = mask;
  s.rc_queue.clear();
  s.rc_lost = 0;
}

bool Rc::nextEdge(Edge& edge) {
  auto& s = state();
  if (s.rc_queue.empty()) return false;
  edge = s.rc_queue.front();
  s.rc_queue.pop_front();
  return true;
}

uint16_t Rc::lostEdges() { return state().rc_lost; }

}  // namespace hal
