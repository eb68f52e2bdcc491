// fake.hpp's controls: what a test sets (ADC, TWI slave, input, stack, RC edges) and observes
// (pulses, EEPROM, output, watchdog) on the fake HAL.
#include <stdexcept>
#include <string>
#include <utility>

#include "fake_state.hpp"

using namespace hal::fake::detail;

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
