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
  // Microseconds since init, 4 us resolution (Timer0's count within the millisecond); wraps
  // after 71 minutes. For timing inside a measurement (gather_store's step logs).
  static uint32_t micros();
  // Busy time passes asleep (idle mode) so the simulator can skip ahead.
  static void delayMs(uint16_t ms);
  // Sleeps (idle mode) until the next interrupt: at the latest the next 1 ms tick.
  static void sleepUntilInterrupt();
  // The same, unless `pending()` (called with interrupts off) says there is work already. It
  // closes the window between a loop's last check and its sleep: news an interrupt brings in
  // that window would otherwise wait for the next interrupt, up to the 1 ms tick (fly: the end
  // of an IMU read, which must reach the motors within its frame).
  static void sleepUnless(bool (*pending)());
  // Sleeps until `ready()` holds, asking it (interrupts off) after every interrupt: a loop with
  // frequent interrupts that bring it nothing (fly: 16 per IMU read) stays asleep through them.
  static void sleepUntil(bool (*ready)());
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

  // A flight loop aligned with the frames (fly, docs/fly.md): `hook` is called from the timer
  // interrupt once per frame, `at_us` after each frame's rising edge (1 .. frame period - 1;
  // nullptr: none). It runs with interrupts off, so it must be short: fly starts its IMU read
  // there, on time whatever the main loop is doing. Set it after init / setFrameRate (a new
  // frame rate keeps the phase's timer tick, not its microseconds).
  using PhaseHook = void (*)();
  static void setPhaseHook(uint16_t at_us, PhaseHook hook);
  // Where the present frame is: microseconds since its rising edge, 0 .. frame period - 1.
  static uint16_t frameTimeUs();
};

// The TWI (I2C) as a master, driven by its interrupt (TWI_vect), after the ATmega2560
// datasheet ch. 24: one transfer at a time, started here and run by the interrupt while the
// CPU does other work; result() says when it has ended and how.
//  - register write: START, SLA+W, register, value, STOP (status 08 18 28 28);
//  - register read of 1..kMaxRead bytes: START, SLA+W, register, repeated START, SLA+R, the
//    bytes (each acknowledged but the last), STOP (status 08 18 28 10 40 50.. 58).
// Time-outs are the caller's: a slave that holds a line low never lets a transfer end, so the
// caller decides how long is too long (fly: the next frame) and calls abort(), then
// recoverBus(). Pins and rates: hal/board.hpp (kTwiPins, kTwiFastHz). Safe to start from an
// interrupt (Esc's phase hook) and from the main loop, not from both at once.
struct Twi {
  static constexpr uint8_t kMaxRead = 16;
  static constexpr uint8_t kRecoveryClocks = 9;  // SCL clocks that free any slave mid-byte

  enum class Result : uint8_t {
    kIdle,      // nothing started since init
    kBusy,      // a transfer runs
    kDone,      // the last transfer ended well (STOP sent)
    kNack,      // no acknowledge to the address or a written byte (status 0x20, 0x30, 0x48)
    kLost,      // arbitration lost: another master, or a slave holding SDA low (0x38)
    kBusError,  // an illegal START/STOP (0x00) or a status the transfer cannot have
    kAborted,   // abort() ended it
  };

  // Master at `scl_hz` (TWPS 0, TWBR from hal::board::twiBitRateRegister); ends any transfer.
  static void init(uint32_t scl_hz = kTwiFastHz);
  // Start a transfer; false (nothing started) while one runs or for a length outside 1..kMaxRead.
  static bool startWrite(uint8_t address, uint8_t reg, uint8_t value);
  static bool startRead(uint8_t address, uint8_t reg, uint8_t length);
  static Result result();
  // The TWSR status code the last transfer ended on (0x58, 0x28 when well; 0x20 for an absent
  // slave, ...); 0xF8 before any.
  static uint8_t lastStatus();
  // Copies up to `length` bytes of the last read's data (valid after kDone); returns how many.
  static uint8_t readData(uint8_t* dst, uint8_t length);
  // Where in the ESC frame (Esc::frameTimeUs's clock) the last transfer ended, taken by the
  // interrupt that ended it: a loop paced by the frames times its computation from the read's
  // end, however late it saw it (fly's status, docs/fly.md).
  static uint16_t endFrameTimeUs();
  // Ends the present transfer at once (TWI off and on again: the pins are let go); result()
  // is kAborted when one was running.
  static void abort();
  // Bus recovery (I2C spec 3.1.16): TWI off, up to kRecoveryClocks SCL clocks as an open-drain
  // GPIO while a slave holds SDA low, a STOP, TWI on again. True when both lines are high after.
  static bool recoverBus();
};

// RC receiver input (hal/board.hpp kRcPins): every change of the watched port-K pins, with the
// port's state after it and a timestamp in 0.5 us ticks of a free-running 16-bit timer no ESC
// uses (it wraps every 32.8 ms: a decoder measures the intervals between edges, never longer
// ones), queued by the pin-change interrupt for the main loop. Decoding (PPM sum, one pulse per
// channel), ranges and failsafe are the caller's (fly: rc_input.hpp).
struct Rc {
  struct Edge {
    uint8_t pins;    // the watched pins' levels after the change, bit i = channel pin i
    uint16_t ticks;  // when, in 0.5 us ticks
  };
  static constexpr uint8_t kQueueEdges = 32;  // ~1.5 PPM frames of edges

  // Watch the pins in `mask` (bit i: A8 + i); 0 stops watching. Pins watched are inputs with
  // their pull-ups on (an unplugged receiver reads high and still: no edges).
  static void init(uint8_t mask);
  // The oldest queued change; false when there is none.
  static bool nextEdge(Edge& edge);
  // Changes lost because the queue was full (saturates): a decoder treats them as noise.
  static uint16_t lostEdges();
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

// On the chip, the two checks the main loop's sleep makes at every wake (each interrupt wakes
// it: ~25 a frame in fly, most of them the TWI's bytes) read their state inline instead of
// calling into the HAL: a call and return are more than the check itself.
#if defined(__AVR__)
namespace detail {
extern volatile uint8_t g_uart_rx_head;  // hal/avr/uart.cpp's receive ring, written by its ISR
extern volatile uint8_t g_uart_rx_tail;
extern volatile bool g_uart_rx_gap;
extern volatile Twi::Result g_twi_state;  // hal/avr/twi.cpp
}  // namespace detail
inline bool Uart::available() {
  return detail::g_uart_rx_head != detail::g_uart_rx_tail || detail::g_uart_rx_gap;
}
inline Twi::Result Twi::result() { return detail::g_twi_state; }
#endif

}  // namespace hal
