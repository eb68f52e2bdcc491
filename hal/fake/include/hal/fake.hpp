// Controls and observes the fake HAL backend from host tests. Host only (uses the STL).
//
// Time only moves when the code under test waits (Clock::delayMs, sleepUntilInterrupt) or
// the test calls advanceMs(). Every simulated millisecond: scheduled input whose time has
// come is delivered to the UART receive buffer, then the tick hook (if any) runs, so a test
// can model a plant that reacts to the ESC pulses.
#pragma once
#include <stdint.h>

#include <functional>
#include <string>
#include <vector>

#include "hal/hal.hpp"

namespace hal::fake {

// Everything back to power-on: time 0, ADC 0 counts, pulses 0, EEPROM erased (0xFF), write
// counter 0, UART empty, frame rate 0, hooks cleared.
void reset();

// ADC: a fixed value per channel, or a source function consulted on every conversion.
void setAdcMillivolts(uint8_t channel, uint16_t mv);  // counts = round(mv * 1023 / 5000)
void setAdcCounts(uint8_t channel, uint16_t counts);
void setAdcSource(std::function<uint16_t(uint8_t channel)> source);  // empty = fixed values
uint32_t adcConversions();

// ESC outputs as the code last wrote them (0 before Esc::init).
uint16_t pulseUs(uint8_t channel);
uint32_t escWriteAlls();  // Esc::writeAll calls since reset()
uint16_t frameRateHz();

// EEPROM bytes and the number of physical byte writes (updateByte of an equal byte does not
// count).
uint8_t* eeprom();
uint32_t eepromWrites();
void resetEepromWrites();

// UART.
void feedInput(const std::string& text);                     // now
void feedInputAt(uint32_t at_ms, const std::string& text);   // when the clock reaches at_ms
// A damage mark (what the AVR receiver reports for lost or garbled bytes), now.
void feedDamage();
const std::string& output();                                 // everything written so far
std::string takeOutput();                                    // returns and clears it

// The wait hook the code under test registered (nullptr: none).
hal::Uart::WaitHook waitHook();

// Watchdog and stack: the reset flags the next boot reports (default kPowerOn), whether the
// watchdog was started and how often it was kicked; the stack figures Stack:: returns.
void setResetFlags(uint8_t flags);
bool watchdogStarted();
uint32_t watchdogKicks();
void setStack(uint16_t size_bytes, uint16_t untouched_bytes);

// Time.
uint32_t nowMs();
void advanceMs(uint32_t ms);
void setTickHook(std::function<void(uint32_t now_ms)> hook);
// Guards against code under test that waits forever: past this many simulated ms, the next
// wait throws std::runtime_error("fake HAL: time limit"). 0 = no limit (default).
void setTimeLimitMs(uint32_t limit_ms);

}  // namespace hal::fake
