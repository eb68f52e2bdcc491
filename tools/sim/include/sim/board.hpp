// A simulated Arduino Mega2560 (ATmega2560 at 16 MHz in libsimavr 1.6) running an unchanged
// firmware ELF, with its pins wired to the host:
//   ESC 0..3  by default the board table's pins (hal::kEscPins: D6 D7 D8 D11, timer compare
//             outputs), or any four pins (setEscPins): every edge is timestamped with the
//             simulated cycle it happened at (a compare output's: its timer tick); the high time
//             is the pulse width, whatever drives the pin (a timer or the firmware's PORTx).
//   A0..A15   answered in millivolts from an AdcSource when a conversion starts.
//   UART0     bytes out are collected (and passed to listeners); bytes in are paced at the
//             line rate (one byte per character time at the firmware's baud) and held back
//             while the receiver is off or simavr's input FIFO signals XOFF.
//   EEPROM    4 KiB, moved in and out whole; writes are instant (simavr) unless
//             setEepromWriteTime() asks for the chip's 3.4 ms per byte.
//   Reset     a watchdog reset (simavr's) or one the host asks for (external, brown-out,
//             power-on) restarts the firmware in the same board: every pin is released (a pulse
//             in progress ends there), the reset flags say why, SRAM survives except at power-on.
//   Flash     the application alone (started at 0, as the HIL tests always did), or behind a
//             bootloader (Intel HEX, e.g. Debian's STK500v2 for the Mega2560 at byte 0x3E000):
//             then every reset() starts at the bootloader, as a board whose BOOTRST fuse is
//             programmed (simavr ignores the fuses, so the harness sets the reset vector).
//   PCINT     the chip's three pin-change interrupt groups (sim/pin_change.hpp), not simavr 1.6's
//             one; inputs driven from outside (Ports::setInput, sim/rc_receiver.hpp) trigger them.
//   TWI       the chip's TWI (sim/twi.hpp: status codes, TWINT, timing from TWBR/TWPS, its
//             interrupt), not simavr 1.6's; I2C parts (sim/mpu6050.hpp) connect to twi().irq().
//   Timers    the chip's Timer/Counters 0-5 (sim/timers.hpp: every waveform and compare-output
//             mode, double-buffered OCRnx, input capture), its ports with compare-output pins
//             (sim/ports.hpp) and INT0-7 (sim/ext_int.hpp), not simavr 1.6's. What they do not
//             model (an external timer clock, Timer2's asynchronous mode, a reserved mode) stops
//             the run: run() throws BoardError naming the timer and the setting.
// A periodic tick (default 1 ms simulated) lets a plant model advance in step with the CPU.
//
// Time is simulated cycles only: the firmware's idle sleep skips ahead (the sleep callback is
// a no-op), nothing waits on the wall clock, and the same ELF + inputs give the same run.
#pragma once
#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "hal/board.hpp"

struct avr_t;
struct avr_irq_t;

namespace sim {

class Twi;
class PinChange;
class Ports;
class ExtInt;
class Timers;

// The board's facts come from the table the firmware is built from (hal/board.hpp).
using hal::kCpuHz;
using hal::kEepromBytes;
using hal::kFlashBytes;
constexpr int kEscChannels = hal::kEscChannels;

inline uint64_t secondsToCycles(double s) { return static_cast<uint64_t>(s * kCpuHz + 0.5); }
inline double cyclesToSeconds(uint64_t c) { return static_cast<double>(c) / kCpuHz; }
// A real-time factor as the speed reports print it, two significant digits: "0.26x real
// time", "7.1x real time", "160x real time".
std::string speedText(double realtime_factor);

// Why the chip reset (the MCUSR flag the reset sets).
enum class ResetKind { kPowerOn, kExternal, kBrownOut };

// The firmware stopped (crashed, or returned from main with interrupts off) or could not be
// loaded; what() says which and what to do.
class BoardError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What one ESC input pin has seen.
struct EscPin {
  double last_pulse_us = 0;      // width of the last complete high pulse
  double last_period_us = 0;     // rising edge to rising edge
  uint64_t last_rise_cycle = 0;  // cycle of the last rising edge
  uint64_t last_fall_cycle = 0;
  uint64_t pulses = 0;           // complete pulses seen
  bool high = false;
};

// What the board's flash holds at power-on.
struct FlashImages {
  // Intel HEX of a bootloader; its lowest address is the boot section start (0x3E000 for the
  // Mega2560's STK500v2). "" = no bootloader: reset starts the application at address 0.
  std::string bootloader_hex;
  // The application: an ELF (.elf; its .mmcu tag and .eeprom section are honoured) or an
  // Intel HEX flash image (anything else). "" = application flash erased (0xFF), as on a board
  // that holds only its bootloader.
  std::string application;
};

class Board {
 public:
  // Millivolts on ADC channel `channel` (0..15) at the moment a conversion starts.
  using AdcSource = std::function<double(int channel)>;
  // Called every tick with the simulated time in seconds.
  using TickHook = std::function<void(double t_s)>;
  // Called for every complete ESC pulse: channel, width in us, time of its falling edge.
  using PulseListener = std::function<void(int channel, double width_us, double t_s)>;
  using ByteListener = std::function<void(uint8_t byte)>;
  // Called after every reset (watchdog or reset()), with the cycle it happened at.
  using ResetListener = std::function<void(uint64_t cycle)>;

  // Loads `elf_path` into a fresh ATmega2560 (the MCU and clock in the ELF's .mmcu tag win if
  // present; otherwise atmega2560 at 16 MHz, 5 V). Throws BoardError if the file cannot be read
  // or is not an AVR ELF. The EEPROM starts erased (all 0xFF) unless the ELF has an .eeprom
  // section.
  explicit Board(const std::string& elf_path);
  // A board from a bootloader and/or an application (see FlashImages). Throws BoardError when
  // a file cannot be read, is not for the atmega2560, or the application overlaps the
  // bootloader.
  explicit Board(const FlashImages& images);
  ~Board();
  Board(const Board&) = delete;
  Board& operator=(const Board&) = delete;

  // --- wiring ---
  void setAdcSource(AdcSource source) { adc_source_ = std::move(source); }
  // Replaces the tick hook and its period (cycles > 0). The first call arms the timer.
  void setTickHook(TickHook hook, uint64_t period_cycles = kCpuHz / 1000);
  void addPulseListener(PulseListener listener) { pulse_listeners_.push_back(std::move(listener)); }
  void addOutputListener(ByteListener listener) { output_listeners_.push_back(std::move(listener)); }
  void addResetListener(ResetListener listener) { reset_listeners_.push_back(std::move(listener)); }
  // Forgets the ADC source, the tick hook and the pulse listeners (not the output listeners):
  // a new plant is about to be wired to this board.
  void clearPlantWiring() {
    adc_source_ = nullptr;
    tick_hook_ = nullptr;
    pulse_listeners_.clear();
  }

  // --- TWI (I2C master) ---
  Twi& twi() { return *twi_; }
  PinChange& pinChange() { return *pin_change_; }

  // --- the chip's ports and timers ---
  Ports& ports() { return *ports_; }
  Timers& timers() { return *timers_; }

  // --- ESC pins ---
  // The pins that carry ESC outputs 0..3 (an attitude rig's motors 0..3): default the board
  // table (hal::kEscPins), or any four distinct pins (sim/pin_names.hpp parses "D3,D5,D6,D2").
  // What was measured on the old pins is forgotten (nothing changes if they are the same).
  void setEscPins(const std::array<hal::MegaPin, kEscChannels>& pins);
  const std::array<hal::MegaPin, kEscChannels>& escPins() const { return esc_pins_; }
  const EscPin& escPin(int channel) const { return esc_.at(channel); }
  // Width of the last pulse on `channel`, or 0 if no pulse ended within `max_age_s` (a dead
  // output: an ESC disarms on that).
  double escPulseUs(int channel, double max_age_s = 0.1) const;

  // --- UART0 ---
  // Queues bytes for the firmware's receiver; they arrive at the line rate while the board runs.
  void sendText(const std::string& text);
  // Queues one byte that arrives with a framing error (a garbled character: FE0 set).
  void sendFramingError(uint8_t byte);
  std::size_t pendingInput() const { return input_.size(); }
  // Everything the firmware has written to UART0 since reset.
  const std::string& output() const { return output_; }

  // --- EEPROM ---
  std::vector<uint8_t> eeprom() const;
  // Loads a whole image (exactly kEepromBytes bytes; throws std::invalid_argument otherwise).
  void setEeprom(const std::vector<uint8_t>& image);
  // Each EEPROM byte write keeps EEPE set this long (the chip: 3.4 ms; simavr: 0).
  void setEepromWriteTime(double seconds);

  // --- flash (fault injection) ---
  // Overwrites program memory at a byte address (even), e.g. with "rjmp ." to hang a function.
  void patchFlash(uint32_t byte_address, const std::vector<uint8_t>& bytes);
  std::vector<uint8_t> flash(uint32_t byte_address, std::size_t length) const;
  // Calls `probe` whenever an instruction at `byte_address` is about to execute.
  void watchPc(uint32_t byte_address, std::function<void(uint64_t cycle)> probe);

  // --- reset ---
  // Resets the chip as `kind` does; runs the reset listeners.
  void reset(ResetKind kind);
  int resets() const { return resets_; }  // watchdog and requested resets since construction
  uint64_t lastResetCycle() const { return last_reset_cycle_; }

  // --- reset and flash ---
  // An external reset (what the DTR pulse of a USB-serial adapter does to an Arduino): the CPU
  // and every peripheral restart at the reset vector (the bootloader when there is one); the
  // flash (including what a bootloader wrote to it), the EEPROM, simulated time and the wiring
  // are kept; input not yet delivered to the UART is dropped. ESC outputs fall silent until
  // the firmware drives them again.
  void reset();
  // Byte address the CPU starts at after reset (the boot section, or 0).
  uint32_t resetAddress() const;
  bool hasBootloader() const { return boot_address_ != 0; }
  // True while the CPU executes the boot section (the bootloader), false in the application.
  bool inBootloader() const;
  // The whole flash (kFlashBytes), e.g. to compare with what avrdude wrote.
  std::vector<uint8_t> flash() const;

  // --- running ---
  uint64_t cycle() const;
  double timeS() const { return cyclesToSeconds(cycle()); }
  // Runs `cycles` simulated cycles. Throws BoardError if the firmware crashes or stops.
  void run(uint64_t cycles);
  void runFor(double seconds) { run(secondsToCycles(seconds)); }
  // Runs until `done()` is true (checked before starting and every `check_cycles`) or
  // `budget_cycles` pass. Returns whether done() became true.
  bool runUntil(const std::function<bool()>& done, uint64_t budget_cycles,
                uint64_t check_cycles = kCpuHz / 1000);

  // Where the simulated time goes. The idle sleep: cycles simavr skipped while the CPU slept
  // (since construction; the awake cycles of a stretch are its cycles minus these). The
  // profile (while on): each instruction's awake cycles added at its word address, pc / 2 (an
  // interrupt's entry counts at the instruction it interrupted; asleep cycles never count).
  uint64_t sleptCycles() const { return slept_cycles_; }
  uint64_t sleeps() const { return sleeps_; }  // how many stretches of idle sleep that was
  void setProfiling(bool on);
  const std::vector<uint64_t>& awakeCyclesByWord() const { return profile_; }

  // Wall time spent inside run() and the simulated time covered; their ratio is the real-time
  // factor (simulated seconds per wall second).
  double wallSeconds() const { return wall_s_; }
  double simulatedSeconds() const { return simulated_s_; }
  double realtimeFactor() const { return wall_s_ > 0 ? simulated_s_ / wall_s_ : 0.0; }

  avr_t* avr() { return avr_; }

 private:
  static void onEscEdge(avr_irq_t* irq, uint32_t value, void* param);
  void wireEscPins(bool on);
  void stop(const std::string& why);
  static void onAdcTrigger(avr_irq_t* irq, uint32_t value, void* param);
  static void onUartOut(avr_irq_t* irq, uint32_t value, void* param);
  static void onUartXon(avr_irq_t* irq, uint32_t value, void* param);
  static void onUartXoff(avr_irq_t* irq, uint32_t value, void* param);
  static uint64_t tickTimer(avr_t* avr, uint64_t when, void* param);
  static uint64_t rxTimer(avr_t* avr, uint64_t when, void* param);
  static void onCoreReset(avr_t* avr);
  static void onSleep(avr_t* avr, uint64_t how_long_cycles);
  static void onEecrWrite(avr_t* avr, uint16_t addr, uint8_t value, void* param);
  static uint64_t eepeClear(avr_t* avr, uint64_t when, void* param);
  void afterReset();

  void load(const FlashImages& images);
  void wire();
  void armTick();
  void escEdge(int channel, bool level);
  void armRx();
  uint64_t cyclesPerByte() const;

  avr_t* avr_ = nullptr;
  AdcSource adc_source_;
  TickHook tick_hook_;
  uint64_t tick_period_ = kCpuHz / 1000;
  bool tick_armed_ = false;
  std::vector<PulseListener> pulse_listeners_;
  std::vector<ByteListener> output_listeners_;
  std::vector<ResetListener> reset_listeners_;
  void (*core_reset_)(avr_t*) = nullptr;
  int resets_ = 0;
  uint64_t last_reset_cycle_ = 0;
  uint64_t eeprom_write_cycles_ = 0;
  bool eecr_hooked_ = false;
  struct PcWatch {
    uint32_t byte_address;
    std::function<void(uint64_t)> probe;
  };
  std::vector<PcWatch> pc_watches_;
  std::array<EscPin, kEscChannels> esc_{};
  std::array<hal::MegaPin, kEscChannels> esc_pins_{};
  struct EdgeParam {
    Board* board;
    int channel;
  };
  std::array<EdgeParam, kEscChannels> edge_params_{};
  std::deque<uint16_t> input_;  // bytes, | 0x8000 (simavr's UART_INPUT_FE) for a framing error
  bool rx_armed_ = false;
  bool xoff_ = false;
  std::string output_;
  double wall_s_ = 0;
  double simulated_s_ = 0;
  uint64_t slept_cycles_ = 0;
  uint64_t sleeps_ = 0;
  bool profiling_ = false;
  std::vector<uint64_t> profile_;  // awake cycles by word address (setProfiling)
  std::vector<avr_irq_t*> irqs_;
  uint32_t boot_address_ = 0;  // 0: no bootloader
  std::string stop_reason_;     // a peripheral stopped the run (what it does not model)
  std::unique_ptr<Ports> ports_;
  std::unique_ptr<ExtInt> ext_int_;
  std::unique_ptr<Timers> timers_;
  std::unique_ptr<Twi> twi_;
  std::unique_ptr<PinChange> pin_change_;
};

}  // namespace sim
