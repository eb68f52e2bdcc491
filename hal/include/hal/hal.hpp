// Thin static HAL: every peripheral is a struct of static functions, one implementation per
// backend chosen at link time (hal/avr for the ATmega2560, hal/fake for host tests).
// No virtual calls, no vtables, no heap.
//
// The board (which pin does what, clock, baud rate) is data in hal/board.hpp, checked at
// compile time.
#pragma once
#include <stdint.h>

#include "hal/board.hpp"

namespace hal {

// Millisecond clock (Timer0, 1 kHz interrupt) and delays.
struct Clock {
  static void init();
  static uint32_t millis();
  // Busy time passes asleep (idle mode) so the simulator can skip ahead.
  static void delayMs(uint16_t ms);
  // Sleeps (idle mode) until the next interrupt: at the latest the next 1 ms tick.
  static void sleepUntilInterrupt();
};

// 10-bit ADC, AVcc (5 V) reference.
struct Adc {
  static void init();
  // One conversion of `channel` (0..15), 0..1023. Sleeps while converting.
  static uint16_t readCounts(uint8_t channel);
};

// Four ESC outputs on 16-bit timers, fast PWM mode 14 (TOP = ICRn), 0.5 us ticks.
struct Esc {
  // Starts all four outputs at 1000 us, `frame_hz` frames per second.
  static void init(uint16_t frame_hz = kEscDefaultFrameHz);
  // 50..400 Hz; returns false (nothing changed) outside that range.
  static bool setFrameRate(uint16_t frame_hz);
  static uint16_t frameRateHz();
  // Pulse width for one channel, clamped to 500..2500 us. Takes effect at the next frame.
  static void writePulse(uint8_t channel, uint16_t pwm_us);
  // All four at once (read_run's frame): writePulse of each channel, back to back.
  static void writeAll(const uint16_t (&pwm_us)[kEscChannels]);
  static uint16_t pulseUs(uint8_t channel);
};

// 4 KB EEPROM. updateByte reads first and skips bytes that already hold the value; it kicks the
// watchdog (a byte write takes 3.4 ms on the chip).
struct Eeprom {
  static constexpr uint16_t kSize = kEepromBytes;
  static uint8_t readByte(uint16_t addr);
  static void updateByte(uint16_t addr, uint8_t value);
  static void readBlock(uint16_t addr, void* dst, uint16_t length);
  static void updateBlock(uint16_t addr, const void* src, uint16_t length);
};

// UART0, 8N1, both directions interrupt-driven through ring buffers (docs/console.md).
//  Receive: 64-byte ring. Bytes that are lost (ring full, hardware overrun) or garbled
//  (framing or parity error) are never dropped silently: read() returns kRxDamaged once at the
//  place they went missing, so the console rejects the line they belonged to.
//  Transmit: 128-byte ring drained by the data-register-empty interrupt. write() returns at
//  once while the ring has room; when it is full it waits (idle sleep) for room, running the
//  wait hook meanwhile (read_run keeps its ESC frames and failsafe on time from there) and
//  kicking the watchdog while the transmitter makes progress.
struct Uart {
  static constexpr int16_t kNothing = -1;     // read(): nothing received
  static constexpr int16_t kRxDamaged = 0x100;  // read(): bytes were lost or garbled here
  using WaitHook = void (*)();

  static void init(uint32_t baud = kUartBaud);
  static bool available();  // a byte or a damage mark is waiting
  static int16_t read();    // a byte 0..255, kRxDamaged or kNothing
  static void write(uint8_t byte);
  static void print(const char* text);          // string in RAM
  static void printP(const char* progmem_text);  // string made with TC_FLASH_TEXT
  // Called (repeatedly) while write() waits for room; nullptr for none. Must not print.
  static void setWaitHook(WaitHook hook);
  static uint16_t rxDamageCount();  // damage marks produced since init (saturates)
};

// Watchdog in system-reset mode, about 64 ms (WDTO_60MS: 8192 cycles of the 128 kHz
// oscillator; longer when that oscillator runs slow). Boot code in .init3 saves the reset
// flags (MCUSR), clears them and switches the watchdog off before anything else: after a
// watchdog reset the chip restarts with the watchdog on at 16 ms. start() arms it; kick()
// restarts its count. Kicks belong where the program makes progress, never in an interrupt.
struct Watchdog {
  // resetFlags() bits: the ATmega2560's MCUSR flags, plus kWasRunning when the program had
  // started (and so SRAM kept its marker) before this reset. A bootloader that clears MCUSR,
  // like the stock Mega2560 one, leaves only kWasRunning to go by.
  static constexpr uint8_t kPowerOn = 0x01;
  static constexpr uint8_t kExternal = 0x02;
  static constexpr uint8_t kBrownOut = 0x04;
  static constexpr uint8_t kWatchdog = 0x08;
  static constexpr uint8_t kJtag = 0x10;
  static constexpr uint8_t kWasRunning = 0x80;
  static constexpr uint16_t kTimeoutMs = 64;

  static void start();
  static void kick();
  static uint8_t resetFlags();
};

// Stack headroom: the boot code paints all SRAM above the static data (.data, .bss,
// .noinit) with a pattern; the stack grows down into it from the top. untouchedBytes() counts
// the painted bytes still intact from the bottom: the headroom never used since reset.
struct Stack {
  static uint16_t sizeBytes();  // SRAM above the static data
  // Of those, the bytes never written since reset. Scans up to 2 KB (about 1.5 ms); `yield`,
  // if given, is called every 64 bytes (read_run keeps its frames on time from there).
  static uint16_t untouchedBytes(void (*yield)() = nullptr);
};

}  // namespace hal
