// The board as data (Arduino Mega2560, ATmega2560 at 16 MHz): which pin does what, in one
// table each, checked at compile time (after modm's board headers). hal/avr/esc.cpp derives its
// registers and pin masks from kEscPins; the firmware prints pin names from it
// (escPinName / escArduinoPin); docs/hardware.md describes the same table.
//
//   A0  load-cell amplifier (INA125P through the 3rd-order RC low-pass)
//   A1  battery divider 100k / 47k
//   ESC 0  D6  PH3 OC4A      ESC 2  D8  PH5 OC4C
//   ESC 1  D7  PH4 OC4B      ESC 3  D11 PB5 OC1A
//   UART0 (USB) 115200 8N1, double speed
//   TWI   SDA D20 PD1, SCL D21 PD0: the MPU-6050 IMU at 0x68 (closed loop, docs/sim.md)
// The ESC pins are timer compare outputs that are not external-interrupt pins (simavr polls
// INT pins held low every cycle: docs/hardware.md).
#pragma once
#include <stdint.h>

#include "hal/mega_pins.hpp"

namespace hal {

constexpr uint32_t kCpuHz = 16000000UL;  // the crystal; the AVR backend asserts F_CPU == this

// ---- memories (ATmega2560) ----
constexpr uint32_t kFlashBytes = 256UL * 1024;
constexpr uint16_t kEepromBytes = 4096;
// The byte the boot code paints the free SRAM with (hal/avr/system.cpp): the stack never used is
// what still holds it, counted by hal::Stack on the chip and by the simulator's stack scenario.
constexpr uint8_t kStackPaint = 0xC5;

// ---- ADC channels ----
constexpr uint8_t kAdcLoadCell = 0;  // A0
constexpr uint8_t kAdcBattery = 1;   // A1
constexpr uint8_t kAdcChannels = 16;  // A0..A15
static_assert(kAdcLoadCell < kAdcChannels && kAdcBattery < kAdcChannels, "ADC pins exist");
static_assert(kAdcLoadCell != kAdcBattery, "one signal per ADC pin");

// ---- ESC outputs: 16-bit timers in fast PWM mode 14 (TOP = ICRn) ----
struct EscPin {
  uint8_t timer;        // 16-bit timer n (1, 3, 4 or 5)
  char compare;         // its compare unit 'A'..'C': register OCRnx, pin OCnx
  char port;            // the AVR port of that pin ('B', 'H', ...)
  uint8_t bit;          // its bit in the port
  uint8_t arduino_pin;  // the Mega2560 header's digital pin number (6 = D6)
};

constexpr EscPin kEscPins[] = {
    {4, 'A', 'H', 3, 6},   // ESC 0: D6  PH3 OC4A
    {4, 'B', 'H', 4, 7},   // ESC 1: D7  PH4 OC4B
    {4, 'C', 'H', 5, 8},   // ESC 2: D8  PH5 OC4C
    {1, 'A', 'B', 5, 11},  // ESC 3: D11 PB5 OC1A
};
constexpr uint8_t kEscChannels = sizeof kEscPins / sizeof kEscPins[0];

constexpr uint16_t kEscDefaultFrameHz = 50;
constexpr uint16_t kEscMinFrameHz = 50;
constexpr uint16_t kEscMaxFrameHz = 400;
// What Esc::writePulse will put on a pin at all: a clamp around any ESC protocol's range (the
// throttle range, 1000..2000 us, is tc::kThrottleMinUs/MaxUs; the firmware stays inside it).
constexpr uint16_t kPulseClampMinUs = 500;
constexpr uint16_t kPulseClampMaxUs = 2500;
constexpr uint8_t kEscPrescaler = 8;  // clk / 8: CSn1
constexpr uint32_t kEscTicksPerSecond = kCpuHz / kEscPrescaler;

// The Arduino pin number of an ESC output (D6 -> 6); 0xFF for no such channel.
constexpr uint8_t escArduinoPin(uint8_t channel) {
  return channel < kEscChannels ? kEscPins[channel].arduino_pin : 0xFF;
}

namespace board {

// Compile-time helpers over the tables (also used by hal/avr/esc.cpp for its register values).
constexpr bool escPinsUnique(uint8_t i = 0, uint8_t j = 1) {
  return i >= kEscChannels ? true
         : j >= kEscChannels ? escPinsUnique(static_cast<uint8_t>(i + 1), static_cast<uint8_t>(i + 2))
         : (kEscPins[i].timer == kEscPins[j].timer && kEscPins[i].compare == kEscPins[j].compare) ||
                   kEscPins[i].arduino_pin == kEscPins[j].arduino_pin
               ? false
               : escPinsUnique(i, static_cast<uint8_t>(j + 1));
}
// The DDR bits of `port` the ESC outputs use.
constexpr uint8_t escPortMask(char port, uint8_t i = 0) {
  return i >= kEscChannels ? 0
                           : static_cast<uint8_t>((kEscPins[i].port == port ? 1u << kEscPins[i].bit : 0u) |
                                                  escPortMask(port, static_cast<uint8_t>(i + 1)));
}
// TCCRnA's COMnx1 bits (non-inverting output) of timer n's ESC outputs: A bit 7, B 5, C 3.
constexpr uint8_t escCompareBits(uint8_t timer, uint8_t i = 0) {
  return i >= kEscChannels
             ? 0
             : static_cast<uint8_t>((kEscPins[i].timer == timer ? 0x80u >> (2 * (kEscPins[i].compare - 'A')) : 0u) |
                                    escCompareBits(timer, static_cast<uint8_t>(i + 1)));
}
// Data-space address of OCRnx (ATmega2560: timer 1 at 0x80, 3 at 0x90, 4 at 0xA0, 5 at 0x120;
// OCRnA 8 bytes above, B 10, C 12).
constexpr uint16_t escCompareAddress(uint8_t channel) {
  return static_cast<uint16_t>((kEscPins[channel].timer == 1   ? 0x80
                                : kEscPins[channel].timer == 3 ? 0x90
                                : kEscPins[channel].timer == 4 ? 0xA0
                                                               : 0x120) +
                               8 + 2 * (kEscPins[channel].compare - 'A'));
}
// The timers the ESC outputs use: every one is started and set to the same frame.
constexpr bool escUsesTimer(uint8_t timer, uint8_t i = 0) {
  return i < kEscChannels && (kEscPins[i].timer == timer || escUsesTimer(timer, static_cast<uint8_t>(i + 1)));
}
constexpr bool escPinsValid(uint8_t i = 0) {
  return i >= kEscChannels ||
         ((kEscPins[i].timer == 1 || kEscPins[i].timer == 3 || kEscPins[i].timer == 4 ||
           kEscPins[i].timer == 5) &&
          kEscPins[i].compare >= 'A' && kEscPins[i].compare <= 'C' && kEscPins[i].bit < 8 &&
          escPinsValid(static_cast<uint8_t>(i + 1)));
}

// UART: the divisor hal/avr/uart.cpp sets (double speed, U2X0: 8 clocks per bit) and the baud
// rate it gives.
constexpr uint16_t uartDivisor(uint32_t baud) {
  return static_cast<uint16_t>((kCpuHz + 4 * baud) / (8 * baud) - 1);
}
constexpr uint32_t uartActualBaud(uint32_t baud) { return kCpuHz / (8u * (uartDivisor(baud) + 1u)); }
// |actual - wanted| in 1/10000 of the wanted rate.
constexpr uint32_t uartErrorBasisPoints(uint32_t baud) {
  return (uartActualBaud(baud) > baud ? uartActualBaud(baud) - baud : baud - uartActualBaud(baud)) *
         10000u / baud;
}

}  // namespace board

constexpr uint32_t kUartBaud = 115200;
// The Mega2560's stock STK500v2 bootloader talks on UART0 at this rate (avrdude -b).
constexpr uint32_t kBootloaderBaud = 115200;
// 115200 from 16 MHz is 117647 baud, +2.1 %: the Mega2560's USB bridge (ATmega16U2, also
// 16 MHz, same divisor) runs at the same rate, so the two ends agree, and a double-speed
// receiver tolerates +3.5/-4.6 % (ATmega2560 datasheet, table 22-3). 2.5 % bounds it; a
// crystal or baud rate that is further off fails the build here, not on the bench.
constexpr uint32_t kUartMaxErrorBasisPoints = 250;

// ---- TWI (I2C) bus and the IMU on it ----
// The ATmega2560's one TWI: SDA PD1 (D20), SCL PD0 (D21), both also INT1 / INT0, so no image
// may use those as level-triggered interrupts. An MPU-6050 with AD0 low answers at 0x68.
struct TwiPins {
  char port;             // 'D'
  uint8_t sda_bit;       // PD1
  uint8_t scl_bit;       // PD0
  uint8_t sda_arduino_pin;
  uint8_t scl_arduino_pin;
};
constexpr TwiPins kTwiPins = {'D', 1, 0, 20, 21};
constexpr uint8_t kImuI2cAddress = 0x68;  // 7-bit; SLA+W = 0xD0, SLA+R = 0xD1
constexpr uint8_t kImuWhoAmI = 0x68;      // what its WHO_AM_I register (0x75) reads
constexpr uint32_t kTwiFastHz = 400000;   // I2C fast mode, the MPU-6050's highest rate

// ---- RC receiver input (fly, docs/fly.md "Wiring a receiver") ----
// Port K's pin-change interrupt (PCINT2: PCINT16..23 are PK0..PK7, the Mega's A8..A15, free
// of every other use here): a PPM sum on A8, or one pulse per channel on A8..A15 (channel 1 on
// A8). Edges are timestamped by Timer5 (free-running, 0.5 us; Timers 1 and 4 carry the ESC
// frames, Timer0 the millisecond clock).
struct RcPins {
  char port;                // 'K'
  uint8_t ppm_bit;          // PK0: the PPM sum
  uint8_t channels;         // PWM: one channel per bit from bit 0
  uint8_t first_arduino_pin;  // A8 is digital pin 62 on the Mega2560
};
constexpr RcPins kRcPins = {'K', 0, 8, 62};
constexpr uint8_t kRcTimer = 5;
constexpr uint32_t kRcTicksPerSecond = kCpuHz / 8;  // Timer5 at clk / 8: 0.5 us

namespace board {
// SCL = F_CPU / (16 + 2 * TWBR * 4^TWPS) (ATmega2560 datasheet, 24.5.2): the TWBR value for a
// bus rate with TWPS = 0, and the rate it gives.
constexpr uint8_t twiBitRateRegister(uint32_t scl_hz) {
  return static_cast<uint8_t>((kCpuHz / scl_hz - 16u) / 2u);
}
constexpr uint32_t twiSclHz(uint8_t twbr, uint8_t twps = 0) {
  return kCpuHz / (16u + 2u * twbr * (1u << (2u * twps)));
}
}  // namespace board

static_assert(kTwiPins.sda_bit != kTwiPins.scl_bit, "SDA and SCL are two pins");
static_assert(board::twiSclHz(board::twiBitRateRegister(kTwiFastHz)) == kTwiFastHz,
              "400 kHz is exact from 16 MHz (TWBR 12)");
static_assert((kImuI2cAddress >> 7) == 0, "a 7-bit I2C address");

namespace board {
// Each table's Arduino pin numbers are the header's (hal/mega_pins.hpp).
constexpr bool escPinsOnHeader(uint8_t i = 0) {
  return i >= kEscChannels || (megaPinOf(kEscPins[i].port, kEscPins[i].bit) == kEscPins[i].arduino_pin &&
                               escPinsOnHeader(static_cast<uint8_t>(i + 1)));
}
}  // namespace board
static_assert(board::escPinsOnHeader(), "each ESC pin's D number is the Mega header's for its port pin");
static_assert(megaPinOf(kTwiPins.port, kTwiPins.sda_bit) == kTwiPins.sda_arduino_pin &&
                  megaPinOf(kTwiPins.port, kTwiPins.scl_bit) == kTwiPins.scl_arduino_pin,
              "SDA and SCL are the Mega header's D20 and D21");

static_assert(kEscChannels == 4, "four ESC outputs: one per calibration slot (tc::kMotorSlots)");
static_assert(!board::escUsesTimer(kRcTimer), "the receiver's timestamps come from a timer no ESC uses");
static_assert(kRcPins.ppm_bit < kRcPins.channels && kRcPins.channels <= 8, "PPM and PWM pins on port K");
static_assert(board::escPinsValid(), "each ESC pin is a compare output A..C of timer 1, 3, 4 or 5");
static_assert(board::escPinsUnique(), "no two ESCs share a compare output or an Arduino pin");
static_assert(kEscTicksPerSecond == 2000000UL, "0.5 us ticks: OCRnx = 2 * pwm_us - 1");
static_assert(kEscTicksPerSecond / kEscMinFrameHz - 1 <= 0xFFFFu, "TOP fits ICRn at the slowest frame");
static_assert(kEscTicksPerSecond / kEscMaxFrameHz >= 2u * kPulseClampMaxUs,
              "the longest pulse fits in the fastest frame");
static_assert(kEscMinFrameHz <= kEscDefaultFrameHz && kEscDefaultFrameHz <= kEscMaxFrameHz,
              "the default frame rate is a valid one");
static_assert(board::uartErrorBasisPoints(kUartBaud) < kUartMaxErrorBasisPoints,
              "UART baud rate error too large for this clock");

}  // namespace hal
