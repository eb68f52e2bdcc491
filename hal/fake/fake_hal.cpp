// Fake HAL backend for host tests: implements hal.hpp on plain memory and a simulated
// millisecond clock, controlled and observed through fake.hpp. Host only (STL allowed).
//
// Differences from the AVR backend, on purpose:
//  - the UART receive buffer is unbounded (the AVR ring buffer holds 64 bytes and marks what it
//    loses as damage): tests may feed whole scripts at once, and damage with feedDamage();
//  - transmitting takes no time and never waits (so the wait hook is never called);
//  - an EEPROM address outside 0..4095 throws std::out_of_range (the AVR would wrap around
//    silently): such an access is a bug in the code under test;
//  - an ADC conversion takes no simulated time (104 us on the AVR).
#include <stdexcept>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "hal/fake.hpp"
#include "hal/hal.hpp"

namespace {

using hal::kAdcChannels;  // hal/board.hpp

struct ScheduledInput {
  uint32_t at_ms;
  std::string text;
};

struct FakeState {
  uint32_t now_ms = 0;
  uint32_t time_limit_ms = 0;
  std::function<void(uint32_t)> tick_hook;

  uint16_t adc_counts[kAdcChannels] = {};
  std::function<uint16_t(uint8_t)> adc_source;
  uint32_t adc_conversions = 0;

  uint16_t pulse_us[hal::kEscChannels] = {};
  uint32_t esc_write_alls = 0;
  uint16_t frame_hz = 0;

  uint8_t eeprom[hal::Eeprom::kSize];
  uint32_t eeprom_writes = 0;

  std::deque<int16_t> rx;  // bytes and hal::Uart::kRxDamaged marks
  std::vector<ScheduledInput> scheduled;  // in the order they were fed
  std::string tx;
  hal::Uart::WaitHook wait_hook = nullptr;
  uint16_t rx_damage = 0;

  uint8_t reset_flags = hal::Watchdog::kPowerOn;
  bool watchdog_started = false;
  uint32_t watchdog_kicks = 0;
  uint16_t stack_size = 2048;
  uint16_t stack_untouched = 1536;

  FakeState() {
    for (auto& b : eeprom) b = 0xFF;
  }
};

FakeState& state() {
  static FakeState s;
  return s;
}

void pushInput(const std::string& text) {
  for (char c : text) state().rx.push_back(static_cast<uint8_t>(c));
}

void deliverDueInput() {
  auto& s = state();
  // Stable: inputs due at the same time arrive in the order they were scheduled.
  std::vector<ScheduledInput> later;
  for (auto& item : s.scheduled) {
    if (item.at_ms <= s.now_ms) {
      pushInput(item.text);
    } else {
      later.push_back(std::move(item));
    }
  }
  s.scheduled = std::move(later);
}

// One simulated millisecond: time, then due input, then the plant.
void stepOneMs() {
  auto& s = state();
  ++s.now_ms;
  if (!s.scheduled.empty()) deliverDueInput();
  if (s.tick_hook) s.tick_hook(s.now_ms);
}

// A wait by the code under test: guarded by the time limit.
void waitMs(uint32_t ms) {
  auto& s = state();
  for (uint32_t i = 0; i < ms; ++i) {
    if (s.time_limit_ms != 0 && s.now_ms >= s.time_limit_ms) {
      throw std::runtime_error("fake HAL: time limit");
    }
    stepOneMs();
  }
}

uint16_t clampCounts(uint32_t counts) { return counts > 1023 ? 1023 : static_cast<uint16_t>(counts); }

void checkEepromAddress(uint32_t addr, uint32_t length) {
  if (addr + length > hal::Eeprom::kSize) {
    throw std::out_of_range("fake HAL: EEPROM access at " + std::to_string(addr) + " length " +
                            std::to_string(length) + " is outside 0..4095");
  }
}

}  // namespace

namespace hal {

// ---- Clock ----
void Clock::init() {}
uint32_t Clock::millis() { return state().now_ms; }
void Clock::delayMs(uint16_t ms) { waitMs(ms); }
void Clock::sleepUntilInterrupt() { waitMs(1); }

// ---- Adc ----
void Adc::init() {}
uint16_t Adc::readCounts(uint8_t channel) {
  auto& s = state();
  if (channel >= kAdcChannels) {
    throw std::out_of_range("fake HAL: ADC channel " + std::to_string(channel) +
                            " does not exist (0..15)");
  }
  ++s.adc_conversions;
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
  return true;
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

namespace hal::fake {

void reset() { state() = FakeState(); }

void setAdcMillivolts(uint8_t channel, uint16_t mv) {
  setAdcCounts(channel, static_cast<uint16_t>((static_cast<uint32_t>(mv) * 1023u + 2500u) / 5000u));
}

void setAdcCounts(uint8_t channel, uint16_t counts) {
  if (channel >= kAdcChannels) {
    throw std::out_of_range("fake HAL: ADC channel " + std::to_string(channel) +
                            " does not exist (0..15)");
  }
  state().adc_counts[channel] = clampCounts(counts);
}

void setAdcSource(std::function<uint16_t(uint8_t channel)> source) {
  state().adc_source = std::move(source);
}

uint32_t adcConversions() { return state().adc_conversions; }

uint16_t pulseUs(uint8_t channel) { return Esc::pulseUs(channel); }
uint32_t escWriteAlls() { return state().esc_write_alls; }
uint16_t frameRateHz() { return state().frame_hz; }

uint8_t* eeprom() { return state().eeprom; }
uint32_t eepromWrites() { return state().eeprom_writes; }
void resetEepromWrites() { state().eeprom_writes = 0; }

void feedInput(const std::string& text) { pushInput(text); }

void feedDamage() {
  state().rx.push_back(hal::Uart::kRxDamaged);
  ++state().rx_damage;
}

void setResetFlags(uint8_t flags) { state().reset_flags = flags; }
bool watchdogStarted() { return state().watchdog_started; }
uint32_t watchdogKicks() { return state().watchdog_kicks; }
void setStack(uint16_t size_bytes, uint16_t untouched_bytes) {
  state().stack_size = size_bytes;
  state().stack_untouched = untouched_bytes;
}
hal::Uart::WaitHook waitHook() { return state().wait_hook; }

void feedInputAt(uint32_t at_ms, const std::string& text) {
  if (at_ms <= state().now_ms) {
    pushInput(text);
  } else {
    state().scheduled.push_back({at_ms, text});
  }
}

const std::string& output() { return state().tx; }

std::string takeOutput() {
  std::string out;
  out.swap(state().tx);
  return out;
}

uint32_t nowMs() { return state().now_ms; }

void advanceMs(uint32_t ms) {
  for (uint32_t i = 0; i < ms; ++i) stepOneMs();
}

void setTickHook(std::function<void(uint32_t now_ms)> hook) { state().tick_hook = std::move(hook); }

void setTimeLimitMs(uint32_t limit_ms) { state().time_limit_ms = limit_ms; }

}  // namespace hal::fake
