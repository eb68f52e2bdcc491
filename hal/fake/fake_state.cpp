// The fake HAL's clock, scheduled input and ESC phase hooks (fake_state.hpp).
#include "fake_state.hpp"

#include <stdexcept>
#include <utility>

namespace hal::fake::detail {

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

}  // namespace hal::fake::detail
