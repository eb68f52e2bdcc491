// Thin static HAL: every peripheral is a struct of static functions, one implementation per
// backend chosen at link time (hal/avr for the ATmega2560, hal/fake for host tests).
// No virtual calls, no vtables, no heap.
//
// Pinout (Arduino Mega2560):
//   A0  load-cell amplifier (INA125P through the 3rd-order RC low-pass)
//   A1  battery divider 100k / 47k
//   ESC 0  D6  PH3 OC4A      ESC 2  D8  PH5 OC4C
//   ESC 1  D7  PH4 OC4B      ESC 3  D11 PB5 OC1A
//   UART0 (USB) 115200 8N1
// The ESC pins are timer compare outputs that are not external-interrupt pins (see
// CONVENTIONS.md: simavr polls INT pins held low every cycle).
#pragma once
#include <stdint.h>

#ifdef __AVR__
#include <avr/pgmspace.h>
#define TC_PSTR(s) PSTR(s)
#else
#define TC_PSTR(s) (s)
#endif

namespace hal {

constexpr uint8_t kAdcLoadCell = 0;
constexpr uint8_t kAdcBattery = 1;
constexpr uint8_t kEscChannels = 4;
constexpr uint16_t kEscDefaultFrameHz = 50;
constexpr uint16_t kEscMinFrameHz = 50;
constexpr uint16_t kEscMaxFrameHz = 400;
constexpr uint16_t kEscPulseMinUs = 500;
constexpr uint16_t kEscPulseMaxUs = 2500;

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
  static uint16_t pulseUs(uint8_t channel);
};

// 4 KB EEPROM. updateByte reads first and skips bytes that already hold the value.
struct Eeprom {
  static constexpr uint16_t kSize = 4096;
  static uint8_t readByte(uint16_t addr);
  static void updateByte(uint16_t addr, uint8_t value);
  static void readBlock(uint16_t addr, void* dst, uint16_t length);
  static void updateBlock(uint16_t addr, const void* src, uint16_t length);
};

// UART0, interrupt-driven receive ring buffer (64 bytes), blocking transmit.
struct Uart {
  static void init(uint32_t baud = 115200);
  static bool available();
  static int16_t read();  // -1 when nothing received
  static void write(uint8_t byte);
  static void print(const char* text);          // string in RAM
  static void printP(const char* progmem_text);  // string made with TC_PSTR
};

}  // namespace hal
