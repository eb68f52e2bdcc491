// Controls and observes the fake HAL backend from host tests. Host only (uses the STL).
//
// Time only moves when the code under test waits (Clock::delayMs, sleepUntilInterrupt,
// sleepUnless with nothing pending) or
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
// Simulated time per conversion (0, the default: none). With it, Clock::micros() advances
// within the millisecond and each whole millisecond runs the tick (gather_store's step logs).
void setAdcConversionUs(uint16_t us);

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

// ESC frame phase (Esc::setPhaseHook): frames start at multiples of the frame period since
// reset(); the hook runs once per frame when simulated time passes the frame's start + its
// phase (at most one step late: time moves in whole milliseconds). Esc::frameTimeUs() is the
// microseconds since the present frame's start at the present millisecond.
uint32_t phaseHookCalls();

// TWI: one register-map slave at an address (none at first: every transfer is a NACK). A
// transfer ends inside its start call (kDone, kNack) unless SDA is held low: then it never
// ends until Twi::abort(); Twi::recoverBus() frees the bus when the hold lets go within its
// clocks. lastStatus() is the datasheet's code a chip would have ended on (0x58, 0x28, 0x20,
// 0x48).
void twiAttach(uint8_t address);
uint8_t* twiRegisters();                // the slave's 128 registers, 0x00..0x7F
void twiClearOnRead(uint8_t reg);       // this register reads, then is 0 (MPU-6050 INT_STATUS)
void twiSetNack(bool on);               // the slave stops answering its address
// A slave holds SDA low from now on, letting go after `release_after_clocks` SCL clocks of a
// bus recovery (0: never).
void twiHoldSdaLow(uint8_t release_after_clocks);
// Called when a read is served, before the bytes are copied (a test's sensor model refreshes
// the registers there).
void setTwiReadHook(std::function<void(uint8_t reg, uint8_t length)> hook);
struct TwiWrite {
  uint8_t reg;
  uint8_t value;
};
const std::vector<TwiWrite>& twiWrites();  // register writes the slave took, in order
uint32_t twiReads();                       // reads started (whatever became of them)
uint32_t twiAborts();
uint32_t twiRecoveries();
uint32_t twiSclHz();                       // the rate Twi::init was given (0 before)

// RC receiver input (Rc): the test queues the edges a receiver makes, with their pin levels
// and 0.5 us ticks; rcMask() is what Rc::init watches. The helpers queue whole frames from the
// given tick: a PPM sum on bit 0 (a 400 us low separator before each channel, idle high; the
// channel is the time from one separator's start to the next; a sync gap fills the frame to
// `frame_us`), or one pulse per channel on bits 0..n-1 one after another. They return the tick
// after the frame.
void rcEdge(uint8_t pins, uint16_t ticks);
uint16_t rcPpmFrame(uint16_t from_ticks, const std::vector<uint16_t>& channels_us, uint32_t frame_us = 22500);
uint16_t rcPwmFrame(uint16_t from_ticks, const std::vector<uint16_t>& channels_us);
uint8_t rcMask();
std::size_t rcQueued();  // edges not taken yet

// Time.
uint32_t nowMs();
void advanceMs(uint32_t ms);
void setTickHook(std::function<void(uint32_t now_ms)> hook);
// Guards against code under test that waits forever: past this many simulated ms, the next
// wait throws std::runtime_error("fake HAL: time limit"). 0 = no limit (default).
void setTimeLimitMs(uint32_t limit_ms);

}  // namespace hal::fake
