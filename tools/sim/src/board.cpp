#include "sim/board.hpp"
#include "sim/lsan_simavr.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "sim/ext_int.hpp"
#include "sim/pin_change.hpp"
#include "sim/pin_names.hpp"
#include "sim/ports.hpp"
#include "sim/timers.hpp"
#include "sim/twi.hpp"

extern "C" {
#include <simavr/avr_adc.h>
#include <simavr/avr_eeprom.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_irq.h>
}

namespace sim {

std::string speedText(double realtime_factor) {
  if (!(realtime_factor > 0)) return "0x real time";
  // Rounded to two significant digits, shown without exponent or trailing zeros.
  const int magnitude = static_cast<int>(std::floor(std::log10(realtime_factor)));
  const double rounded = std::round(realtime_factor / std::pow(10.0, magnitude - 1)) * std::pow(10.0, magnitude - 1);
  const int shown = static_cast<int>(std::floor(std::log10(rounded)));  // 9.96 became 10
  const int decimals = shown >= 1 ? 0 : 1 - shown;
  return fmt::format("{:.{}f}x real time", rounded, decimals);
}

namespace {

// ATmega2560 UART0 registers (data space addresses).
constexpr uint16_t kUcsr0a = 0xC0;
constexpr uint16_t kUcsr0b = 0xC1;
constexpr uint16_t kUbrr0l = 0xC4;
constexpr uint16_t kUbrr0h = 0xC5;
constexpr uint8_t kRxen0Bit = 4;
constexpr uint8_t kU2x0Bit = 1;
constexpr uint16_t kMcusr = 0x54;  // I/O 0x34
constexpr uint8_t kPorf = 0x01, kExtrf = 0x02, kBorf = 0x04;
constexpr uint16_t kEecr = 0x3F;   // I/O 0x1F
constexpr uint8_t kEepeBit = 1, kEempeBit = 2;
constexpr uint16_t kSramStart = 0x200;

}  // namespace

Board::Board(const std::string& elf_path) : Board(FlashImages{"", elf_path}) {}

Board::Board(const FlashImages& images) {
  load(images);
  wire();
}

void Board::wire() {
  // The chip's ports, external interrupts and timers in place of simavr 1.6's (sim/timers.hpp).
  ports_ = std::make_unique<Ports>(avr_);
  ext_int_ = std::make_unique<ExtInt>(avr_);
  timers_ = std::make_unique<Timers>(avr_, *ports_, [this](const std::string& why) { stop(why); });
  twi_ = std::make_unique<Twi>(avr_);
  pin_change_ = std::make_unique<PinChange>(avr_);
  esc_pins_ = boardEscPins();
  wireEscPins(true);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_OUT_TRIGGER),
                          &Board::onAdcTrigger, this);

  uint32_t flags = 0;
  avr_ioctl(avr_, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~(AVR_UART_FLAG_POLL_SLEEP | AVR_UART_FLAG_STDIO);
  avr_ioctl(avr_, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                          &Board::onUartOut, this);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                          &Board::onUartXon, this);
  avr_irq_register_notify(avr_io_getirq(avr_, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                          &Board::onUartXoff, this);
}

Board::~Board() {
  // Their IRQs and handlers live in the core: before avr_terminate.
  if (ports_) wireEscPins(false);
  twi_.reset();
  pin_change_.reset();
  timers_.reset();
  ext_int_.reset();
  ports_.reset();
  if (avr_) {
    avr_terminate(avr_);
    std::free(avr_);
  }
}

void Board::setTickHook(TickHook hook, uint64_t period_cycles) {
  tick_hook_ = std::move(hook);
  tick_period_ = period_cycles > 0 ? period_cycles : 1;
  armTick();
}

void Board::armTick() {
  if (tick_armed_ || !tick_hook_) return;
  tick_armed_ = true;
  avr_cycle_timer_register(avr_, tick_period_, &Board::tickTimer, this);
}

// --- reset and flash ---

void Board::reset() {
  // The DTR pulse of a port being opened: bytes still queued for the old program are gone with
  // it (the host's side of the line was flushed).
  input_.clear();
  reset(ResetKind::kExternal);
}

uint32_t Board::resetAddress() const { return boot_address_; }

bool Board::inBootloader() const { return boot_address_ != 0 && avr_->pc >= boot_address_; }

std::vector<uint8_t> Board::flash() const {
  return std::vector<uint8_t>(avr_->flash, avr_->flash + kFlashBytes);
}

uint64_t Board::tickTimer(avr_t*, uint64_t when, void* param) {
  auto* self = static_cast<Board*>(param);
  if (self->tick_hook_) self->tick_hook_(cyclesToSeconds(when));
  return when + self->tick_period_;
}

// --- reset ---

// simavr adds 1 + how_long cycles after this callback; nothing waits on the wall clock.
void Board::onSleep(avr_t* avr, uint64_t how_long_cycles) {
  auto* self = static_cast<Board*>(avr->custom.data);
  self->slept_cycles_ += 1 + how_long_cycles;
  ++self->sleeps_;
}

void Board::setProfiling(bool on) {
  profiling_ = on;
  if (on && profile_.empty()) profile_.assign(kFlashBytes / 2, 0);
}

void Board::onCoreReset(avr_t* avr) {
  auto* self = static_cast<Board*>(avr->custom.data);
  if (self->core_reset_) self->core_reset_(avr);
  self->afterReset();
}

void Board::afterReset() {
  ++resets_;
  last_reset_cycle_ = avr_->cycle;
  // At reset every pin becomes an input: a pulse in progress ends here (sim::Ports releases
  // what was driven, and the ESC measurement sees the falling edge).
  if (ports_) ports_->afterReset();
  if (timers_) timers_->afterReset();
  if (ext_int_) ext_int_->afterReset();
  // avr_reset() cancelled every cycle timer, the harness's too.
  if (tick_armed_) avr_cycle_timer_register(avr_, tick_period_, &Board::tickTimer, this);
  rx_armed_ = false;
  xoff_ = false;
  armRx();
  if (twi_) twi_->afterReset();
  for (auto& listener : reset_listeners_) listener(avr_->cycle);
}

void Board::reset(ResetKind kind) {
  if (kind == ResetKind::kPowerOn) {
    // SRAM holds no data after power-up: fill it with deterministic noise.
    uint32_t x = 0x2545F491u;
    for (uint32_t a = kSramStart; a <= avr_->ramend; ++a) {
      x ^= x << 13;
      x ^= x >> 17;
      x ^= x << 5;
      avr_->data[a] = static_cast<uint8_t>(x);
    }
  }
  avr_reset(avr_);  // runs onCoreReset
  avr_->data[kMcusr] = kind == ResetKind::kPowerOn    ? kPorf
                       : kind == ResetKind::kExternal ? kExtrf
                                                      : kBorf;
}

// --- flash ---

void Board::patchFlash(uint32_t byte_address, const std::vector<uint8_t>& bytes) {
  if (byte_address % 2 != 0 || byte_address + bytes.size() > avr_->flashend + 1)
    throw std::invalid_argument(fmt::format("patchFlash: 0x{:05X}+{} is not inside the flash",
                                            byte_address, bytes.size()));
  for (std::size_t i = 0; i < bytes.size(); ++i) avr_->flash[byte_address + i] = bytes[i];
}

std::vector<uint8_t> Board::flash(uint32_t byte_address, std::size_t length) const {
  if (byte_address + length > avr_->flashend + 1)
    throw std::invalid_argument(fmt::format("flash: 0x{:05X}+{} is not inside the flash",
                                            byte_address, length));
  return std::vector<uint8_t>(avr_->flash + byte_address, avr_->flash + byte_address + length);
}

void Board::watchPc(uint32_t byte_address, std::function<void(uint64_t cycle)> probe) {
  pc_watches_.push_back(PcWatch{byte_address, std::move(probe)});
}

// --- ADC ---

void Board::onAdcTrigger(avr_irq_t*, uint32_t value, void* param) {
  auto* self = static_cast<Board*>(param);
  avr_adc_mux_t mux;
  std::memset(&mux, 0, sizeof mux);
  static_assert(sizeof(mux) >= sizeof(value), "mux descriptor fits the IRQ value");
  std::memcpy(&mux, &value, sizeof value);
  if (!self->adc_source_) return;
  auto feed = [&](int channel) {
    double mv = self->adc_source_(channel);
    if (mv < 0) mv = 0;
    if (mv > 5500) mv = 5500;
    avr_raise_irq(avr_io_getirq(self->avr_, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + channel),
                  static_cast<uint32_t>(mv + 0.5));
  };
  if (mux.kind == ADC_MUX_SINGLE && mux.src < 8) {
    feed(mux.src);
  } else if (mux.kind == ADC_MUX_DIFF && mux.src < 8 && mux.diff < 8) {
    feed(mux.src);
    feed(mux.diff);
  }
}

// --- UART ---

void Board::onUartOut(avr_irq_t*, uint32_t value, void* param) {
  auto* self = static_cast<Board*>(param);
  const auto byte = static_cast<uint8_t>(value);
  self->output_.push_back(static_cast<char>(byte));
  for (auto& listener : self->output_listeners_) listener(byte);
}

void Board::onUartXon(avr_irq_t*, uint32_t, void* param) {
  static_cast<Board*>(param)->xoff_ = false;
}

void Board::onUartXoff(avr_irq_t*, uint32_t value, void* param) {
  if (value) static_cast<Board*>(param)->xoff_ = true;
}

uint64_t Board::cyclesPerByte() const {
  const uint32_t ubrr = avr_->data[kUbrr0l] | ((avr_->data[kUbrr0h] & 0x0F) << 8);
  const bool u2x = (avr_->data[kUcsr0a] >> kU2x0Bit) & 1;
  const uint64_t per_bit = static_cast<uint64_t>(ubrr + 1) * (u2x ? 8 : 16);
  const uint64_t per_byte = per_bit * 10;  // start + 8 data + stop
  return per_byte < 160 ? 160 : per_byte;
}

void Board::sendText(const std::string& text) {
  for (char c : text) input_.push_back(static_cast<uint8_t>(c));
  armRx();
}

void Board::sendFramingError(uint8_t byte) {
  input_.push_back(static_cast<uint16_t>(byte | UART_INPUT_FE));
  armRx();
}

void Board::armRx() {
  if (rx_armed_ || input_.empty()) return;
  rx_armed_ = true;
  avr_cycle_timer_register(avr_, cyclesPerByte(), &Board::rxTimer, this);
}

uint64_t Board::rxTimer(avr_t* avr, uint64_t when, void* param) {
  auto* self = static_cast<Board*>(param);
  if (self->input_.empty()) {
    self->rx_armed_ = false;
    return 0;
  }
  const bool rx_enabled = (avr->data[kUcsr0b] >> kRxen0Bit) & 1;
  if (rx_enabled && !self->xoff_) {
    const uint16_t item = self->input_.front();
    self->input_.pop_front();
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT), item);
  }
  if (self->input_.empty()) {
    self->rx_armed_ = false;
    return 0;
  }
  return when + self->cyclesPerByte();
}

// --- EEPROM ---

std::vector<uint8_t> Board::eeprom() const {
  std::vector<uint8_t> image(kEepromBytes, 0xFF);
  avr_eeprom_desc_t d{image.data(), 0, static_cast<uint32_t>(image.size())};
  avr_ioctl(avr_, AVR_IOCTL_EEPROM_GET, &d);
  return image;
}

void Board::setEeprom(const std::vector<uint8_t>& image) {
  if (image.size() != kEepromBytes)
    throw std::invalid_argument(
        fmt::format("EEPROM image has {} bytes; the ATmega2560 has {}", image.size(), kEepromBytes));
  std::vector<uint8_t> copy = image;
  avr_eeprom_desc_t d{copy.data(), 0, static_cast<uint32_t>(copy.size())};
  avr_ioctl(avr_, AVR_IOCTL_EEPROM_SET, &d);
}

void Board::setEepromWriteTime(double seconds) {
  eeprom_write_cycles_ = secondsToCycles(seconds);
  if (!eecr_hooked_ && eeprom_write_cycles_ > 0) {
    // After simavr's own EECR handler (it writes the byte and clears EEPE at once).
    avr_register_io_write(avr_, kEecr, &Board::onEecrWrite, this);
    eecr_hooked_ = true;
  }
}

void Board::onEecrWrite(avr_t* avr, uint16_t, uint8_t value, void* param) {
  auto* self = static_cast<Board*>(param);
  const uint8_t write = (1u << kEepeBit) | (1u << kEempeBit);
  if (self->eeprom_write_cycles_ == 0 || (value & write) != write) return;
  avr->data[kEecr] = static_cast<uint8_t>(avr->data[kEecr] | (1u << kEepeBit));
  avr_cycle_timer_register(avr, self->eeprom_write_cycles_, &Board::eepeClear, self);
}

uint64_t Board::eepeClear(avr_t* avr, uint64_t, void*) {
  avr->data[kEecr] = static_cast<uint8_t>(avr->data[kEecr] & ~(1u << kEepeBit));
  return 0;
}

// --- running ---

uint64_t Board::cycle() const { return avr_->cycle; }

void Board::stop(const std::string& why) {
  // From inside the core (a cycle timer, a register write): the CPU stops at once and run()
  // throws. Later runs throw the same.
  if (stop_reason_.empty()) stop_reason_ = why;
  avr_->state = cpu_Crashed;
}

void Board::run(uint64_t cycles) {
  const auto wall0 = std::chrono::steady_clock::now();
  avr_t* const avr = avr_;
  const uint64_t start = avr->cycle;
  const uint64_t end = start + cycles;
  int state = cpu_Running;
  if (pc_watches_.empty() && !profiling_) {
    // The hot loop of every simulation: one call per instruction, nothing else.
    while (avr->cycle < end) {
      state = avr_run(avr);
      if (state == cpu_Done || state == cpu_Crashed) break;
    }
  } else {
    while (avr->cycle < end) {
      for (const PcWatch& w : pc_watches_)
        if (avr->pc == w.byte_address) w.probe(avr->cycle);
      const uint32_t pc = avr->pc;
      const uint64_t cycle_before = avr->cycle, slept_before = slept_cycles_;
      state = avr_run(avr);
      if (profiling_) profile_[pc / 2] += (avr->cycle - cycle_before) - (slept_cycles_ - slept_before);
      if (state == cpu_Done || state == cpu_Crashed) break;
    }
  }
  simulated_s_ += cyclesToSeconds(avr->cycle - start);
  if (!stop_reason_.empty()) {
    wall_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    throw BoardError(fmt::format("{} (t = {:.6f} s, pc 0x{:05X})", stop_reason_, timeS(), avr->pc));
  }
  if (state == cpu_Done || state == cpu_Crashed) {
    throw BoardError(fmt::format(
        "the firmware {} at t = {:.6f} s (pc 0x{:05X}); {}",
        state == cpu_Crashed ? "crashed" : "stopped (sleep with interrupts off, or main returned)",
        timeS(), avr->pc,
        state == cpu_Crashed ? "run it under simavr -g and avr-gdb to see where"
                             : "the image must loop forever with interrupts on"));
  }
  wall_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
}

bool Board::runUntil(const std::function<bool()>& done, uint64_t budget_cycles,
                     uint64_t check_cycles) {
  if (done()) return true;
  const uint64_t end = cycle() + budget_cycles;
  while (cycle() < end) {
    const uint64_t left = end - cycle();
    run(left < check_cycles ? left : check_cycles);
    if (done()) return true;
  }
  return false;
}

}  // namespace sim
