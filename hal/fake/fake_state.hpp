// The fake HAL's state, shared by its translation units (fake_state.cpp: the clock, input and
// phase-hook machinery; fake_hal.cpp: hal.hpp's devices; fake_control.cpp: fake.hpp's controls
// for tests). Internal to hal/fake: tests use hal/fake.hpp.
#pragma once

#include <deque>
#include <functional>
#include <string>
#include <vector>

#include "hal/fake.hpp"
#include "hal/hal.hpp"

namespace hal::fake::detail {

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

FakeState& state();
void pushInput(const std::string& text);
void deliverDueInput();
uint32_t framePeriodUs();
void schedulePhase(uint64_t t_us);
void callDuePhaseHooks();
void stepOneMs();
void waitMs(uint32_t ms);
uint16_t clampCounts(uint32_t counts);
void checkEepromAddress(uint32_t addr, uint32_t length);

}  // namespace hal::fake::detail
