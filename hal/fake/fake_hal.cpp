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
  uint16_t sub_us = 0;            // microseconds into the present millisecond (conversions)
  uint16_t adc_conversion_us = 0;
  uint32_t time_limit_ms = 0;
  std::function<void(uint32_t)> tick_hook;

  uint16_t adc_counts[kAdcChannels] = {};
  std::function<uint16_t(uint8_t)> adc_source;
  uint32_t adc_conversions = 0;

  uint16_t pulse_us[hal::kEscChannels] = {};
  uint32_t esc_write_alls = 0;
  uint16_t frame_hz = 0;
  hal::Esc::PhaseHook phase_hook = nullptr;
  uint16_t phase_us = 0;
  uint64_t next_phase_us = 0;  // simulated time of the next hook call
  uint32_t phase_hook_calls = 0;

  // TWI
  bool twi_slave = false;
  uint8_t twi_address = 0;
  uint8_t twi_registers[128] = {};
  int16_t twi_clear_on_read = -1;
  bool twi_nack = false;
  bool twi_sda_low = false;
  uint8_t twi_release_clocks = 0;
  std::function<void(uint8_t, uint8_t)> twi_read_hook;
  std::vector<hal::fake::TwiWrite> twi_writes;
  uint32_t twi_reads = 0;
  uint32_t twi_aborts = 0;
  uint32_t twi_recoveries = 0;
  uint32_t twi_scl_hz = 0;
  hal::Twi::Result twi_result = hal::Twi::Result::kIdle;
  uint16_t twi_end_frame_us = 0;
  uint8_t twi_status = 0xF8;
  uint8_t twi_rx[hal::Twi::kMaxRead] = {};
  uint8_t twi_received = 0;

  uint8_t eeprom[hal::Eeprom::kSize];
  uint32_t eeprom_writes = 0;

  // RC
  uint8_t rc_mask = 0;
  uint8_t rc_level = 0xFF;  // the port's pins now (pull-ups: idle high)
  std::deque<hal::Rc::Edge> rc_queue;
  uint16_t rc_lost = 0;

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

uint32_t framePeriodUs() {
  const uint16_t hz = state().frame_hz;
  return hz == 0 ? 0 : 1000000u / hz;
}

// The next phase after `t_us`: the present frame's, if it is still ahead (as the chip's compare
// interrupt, enabled mid-frame, comes later in that frame).
void schedulePhase(uint64_t t_us) {
  auto& s = state();
  const uint32_t period = framePeriodUs();
  if (period == 0) return;
  uint32_t at_us = s.phase_us < 1 ? 1 : s.phase_us;
  if (at_us > period - 1) at_us = period - 1;
  s.next_phase_us = t_us / period * period + at_us;
  if (s.next_phase_us <= t_us) s.next_phase_us += period;
}

void callDuePhaseHooks() {
  auto& s = state();
  const uint64_t now_us = static_cast<uint64_t>(s.now_ms) * 1000u;
  const uint32_t period = framePeriodUs();
  while (s.phase_hook != nullptr && period != 0 && s.next_phase_us <= now_us) {
    s.next_phase_us += period;
    ++s.phase_hook_calls;
    s.phase_hook();
  }
}

// One simulated millisecond: time, then the ESC phase hook, due input, then the plant.
void stepOneMs() {
  auto& s = state();
  ++s.now_ms;
  callDuePhaseHooks();
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
void setAdcConversionUs(uint16_t us) { state().adc_conversion_us = us; }

uint16_t pulseUs(uint8_t channel) { return Esc::pulseUs(channel); }
uint32_t phaseHookCalls() { return state().phase_hook_calls; }

void twiAttach(uint8_t address) {
  state().twi_slave = true;
  state().twi_address = address;
}
uint8_t* twiRegisters() { return state().twi_registers; }
void twiClearOnRead(uint8_t reg) { state().twi_clear_on_read = reg & 0x7F; }
void twiSetNack(bool on) { state().twi_nack = on; }
void twiHoldSdaLow(uint8_t release_after_clocks) {
  state().twi_sda_low = true;
  state().twi_release_clocks = release_after_clocks;
}
void setTwiReadHook(std::function<void(uint8_t reg, uint8_t length)> hook) {
  state().twi_read_hook = std::move(hook);
}
const std::vector<TwiWrite>& twiWrites() { return state().twi_writes; }
uint32_t twiReads() { return state().twi_reads; }
uint32_t twiAborts() { return state().twi_aborts; }
uint32_t twiRecoveries() { return state().twi_recoveries; }
uint32_t twiSclHz() { return state().twi_scl_hz; }
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


void rcEdge(uint8_t pins, uint16_t ticks) {
  auto& s = state();
  s.rc_level = pins;
  if (s.rc_mask == 0) return;
  if (s.rc_queue.size() >= hal::Rc::kQueueEdges - 1) {  // as the chip's ring: one slot kept free
    if (s.rc_lost != 0xFFFF) ++s.rc_lost;
    return;
  }
  s.rc_queue.push_back({static_cast<uint8_t>(pins & s.rc_mask), ticks});
}

uint16_t rcPpmFrame(uint16_t from_ticks, const std::vector<uint16_t>& channels_us, uint32_t frame_us) {
  constexpr uint32_t kSeparatorUs = 400;
  const uint8_t others = static_cast<uint8_t>(state().rc_level & ~1u);
  uint32_t t = from_ticks;
  uint32_t used_us = 0;
  for (uint16_t ch : channels_us) {  // each channel: a separator's start to the next one's
    rcEdge(others, static_cast<uint16_t>(t));
    rcEdge(static_cast<uint8_t>(others | 1u), static_cast<uint16_t>(t + 2 * kSeparatorUs));
    t += 2u * ch;
    used_us += ch;
  }
  rcEdge(others, static_cast<uint16_t>(t));  // the last separator, then the sync gap
  rcEdge(static_cast<uint8_t>(others | 1u), static_cast<uint16_t>(t + 2 * kSeparatorUs));
  const uint32_t gap_us = frame_us > used_us ? frame_us - used_us : 3000;
  return static_cast<uint16_t>(t + 2u * gap_us);
}

uint16_t rcPwmFrame(uint16_t from_ticks, const std::vector<uint16_t>& channels_us) {
  uint32_t t = from_ticks;
  uint8_t level = state().rc_level;
  for (std::size_t i = 0; i < channels_us.size() && i < 8; ++i) {
    const uint8_t bit = static_cast<uint8_t>(1u << i);
    level = static_cast<uint8_t>(level | bit);
    rcEdge(level, static_cast<uint16_t>(t));
    t += 2u * channels_us[i];
    level = static_cast<uint8_t>(level & ~bit);
    rcEdge(level, static_cast<uint16_t>(t));
    t += 2u * 50;  // 50 us to the next channel's pulse
  }
  return static_cast<uint16_t>(t);
}

uint8_t rcMask() { return state().rc_mask; }
std::size_t rcQueued() { return state().rc_queue.size(); }

}  // namespace hal::fake

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
