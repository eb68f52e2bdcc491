#include "sim/board.hpp"
#include "sim/lsan_simavr.hpp"

#include <fmt/format.h>

#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <sys/stat.h>

#include "hex/intel_hex.hpp"
#include "sim/pin_change.hpp"
#include "sim/twi.hpp"

extern "C" {
#include <simavr/avr_adc.h>
#include <simavr/avr_eeprom.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_irq.h>
}

namespace sim {
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


// simavr logs "Loaded N .text" and friends for every image; keep errors only.
void quietLogger(avr_t* avr, const int level, const char* format, va_list ap) {
  (void)avr;
  if (level <= LOG_ERROR) {
    std::vfprintf(stderr, format, ap);
  }
}

// True when the file starts with the ELF magic (an application can be .elf or Intel HEX).
bool isElfFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  return in.gcount() == 4 && std::memcmp(magic, "\x7f" "ELF", 4) == 0;
}

// An Intel HEX flash image: the bytes (0xFF where the file says nothing) and the range the
// file covers, [lo, hi) (lo == hi: no data).
struct HexFlash {
  std::vector<uint8_t> bytes;
  uint32_t lo = 0, hi = 0;
};

HexFlash readHexFlash(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw BoardError(fmt::format("{}: cannot read the {} (Intel HEX); check the path", path, what));
  std::ostringstream text;
  text << in.rdbuf();
  HexFlash h;
  try {
    // Parsed twice with different fills: a byte the file covers reads the same both times.
    h.bytes = hex::parseIntelHex(text.str(), kFlashBytes, path, 0xFF);
    const std::vector<uint8_t> zero_fill = hex::parseIntelHex(text.str(), kFlashBytes, path, 0x00);
    bool any = false;
    for (uint32_t a = 0; a < kFlashBytes; ++a) {
      if (h.bytes[a] != zero_fill[a]) continue;
      if (!any) h.lo = a;
      any = true;
      h.hi = a + 1;
    }
  } catch (const hex::HexError& e) {
    throw BoardError(fmt::format("the {} is not a usable Intel HEX flash image: {}", what, e.what()));
  }
  return h;
}

// Frees what elf_read_firmware allocated.
struct ElfFirmware {
  elf_firmware_t* fw = static_cast<elf_firmware_t*>(std::calloc(1, sizeof(elf_firmware_t)));
  ~ElfFirmware() {
    std::free(fw->flash);
    std::free(fw->eeprom);
    std::free(fw);
  }
};

// The application image, an AVR ELF (its MCU and F_CPU checked) or Intel HEX, and where it
// ends. An empty path: no application (a bare bootloader).
struct AppImage {
  std::unique_ptr<ElfFirmware> elf;
  HexFlash hex;
  uint32_t end = 0;  // first byte past the application
};

AppImage readApplication(const std::string& app) {
  AppImage a;
  if (app.empty()) return a;
  struct stat st {};
  if (::stat(app.c_str(), &st) != 0)
    throw BoardError(fmt::format("{}: no such firmware image; build it first (cmake --build "
                                 "build/avr) or pass the right --elf path",
                                 app));
  if (!isElfFile(app)) {
    a.hex = readHexFlash(app, "application");
    a.end = a.hex.hi;
    return a;
  }
  a.elf = std::make_unique<ElfFirmware>();
  elf_firmware_t* fw = a.elf->fw;
  if (elf_read_firmware(app.c_str(), fw) != 0)
    throw BoardError(fmt::format("{}: not a readable AVR ELF file (is it the .elf, not the .hex?)",
                                 app));
  if (fw->mmcu[0] == '\0') std::strcpy(fw->mmcu, "atmega2560");
  if (std::strcmp(fw->mmcu, "atmega2560") != 0)
    throw BoardError(fmt::format("{}: built for {}, but the virtual board is an atmega2560 "
                                 "(rebuild with the AVR toolchain file)",
                                 app, fw->mmcu));
  if (fw->frequency == 0) fw->frequency = kCpuHz;
  a.end = fw->flashbase + fw->flashsize;
  return a;
}

// The bootloader (Intel HEX, empty path: none), checked to lie above the application `app`,
// which ends at app_end.
HexFlash readBootloader(const std::string& path, const std::string& app, uint32_t app_end) {
  HexFlash boot;
  if (path.empty()) return boot;
  boot = readHexFlash(path, "bootloader");
  if (boot.hi == boot.lo) throw BoardError(fmt::format("{}: the bootloader file holds no data", path));
  if (boot.lo == 0)
    throw BoardError(fmt::format("{}: this \"bootloader\" starts at address 0; pass it as the "
                                 "application (--hex) instead",
                                 path));
  if (app_end > boot.lo)
    throw BoardError(fmt::format(
        "{}: the application reaches byte 0x{:05X}, into the boot section at 0x{:05X} ({}); "
        "it cannot be flashed behind this bootloader",
        app, app_end - 1, boot.lo, path));
  return boot;
}

void eraseEeprom(avr_t* avr) {
  std::vector<uint8_t> erased(kEepromBytes, 0xFF);
  avr_eeprom_desc_t d{erased.data(), 0, static_cast<uint32_t>(erased.size())};
  avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
}

// Puts the application and the bootloader into the core's flash; with a bootloader every
// reset enters it (BOOTRST). Returns the CPU frequency to run at (the ELF's F_CPU).
uint32_t loadImages(avr_t* avr, AppImage& app, HexFlash& boot, const std::string& app_path) {
  uint32_t frequency = kCpuHz;
  if (app.elf) {
    avr_load_firmware(avr, app.elf->fw);
    frequency = app.elf->fw->frequency;
    if (frequency != kCpuHz)
      fmt::print(stderr, "warning: {} says F_CPU = {} Hz; the plant assumes {} Hz timing\n", app_path,
                 frequency, kCpuHz);
  } else if (app.hex.hi > 0) {
    avr_loadcode(avr, app.hex.bytes.data(), app.hex.hi, 0);
  }
  if (boot.hi > boot.lo) {
    avr_loadcode(avr, boot.bytes.data() + boot.lo, boot.hi - boot.lo, boot.lo);
    avr->reset_pc = boot.lo;  // BOOTRST: every reset enters the bootloader
    avr->pc = boot.lo;
    avr->codeend = avr->flashend + 1;
  }
  return frequency;
}

}  // namespace

Board::Board(const std::string& elf_path) : Board(FlashImages{"", elf_path}) {}

Board::Board(const FlashImages& images) {
  load(images);
  wire();
}

void Board::load(const FlashImages& images) {
  avr_global_logger_set(quietLogger);
  AppImage app = readApplication(images.application);
  HexFlash boot = readBootloader(images.bootloader_hex, images.application, app.end);
  avr_ = avr_make_mcu_by_name(app.elf ? app.elf->fw->mmcu : "atmega2560");
  if (!avr_)
    throw BoardError("libsimavr does not know the atmega2560; reinstall libsimavr-dev/simavr");
  avr_init(avr_);
  avr_->log = LOG_ERROR;
  // Every later reset (the watchdog's, or reset()) passes through onCoreReset: the harness's
  // cycle timers are gone then and the pins released.
  avr_->custom.data = this;
  core_reset_ = avr_->reset;
  avr_->reset = &Board::onCoreReset;
  avr_->sleep = &Board::onSleep;  // idle sleep skips ahead instead of waiting on the wall clock
  eraseEeprom(avr_);
  avr_->frequency = loadImages(avr_, app, boot, images.application);
  if (boot.hi > boot.lo) boot_address_ = boot.lo;
  if (avr_->vcc == 0) avr_->vcc = 5000;
  if (avr_->avcc == 0) avr_->avcc = 5000;
  if (avr_->aref == 0) avr_->aref = 5000;
}

void Board::wire() {
  twi_ = std::make_unique<Twi>(avr_);
  pin_change_ = std::make_unique<PinChange>(avr_);
  for (int ch = 0; ch < kEscChannels; ++ch) {
    edge_params_[ch] = EdgeParam{this, ch};
    avr_irq_t* irq =
        avr_io_getirq(avr_, AVR_IOCTL_IOPORT_GETIRQ(hal::kEscPins[ch].port), hal::kEscPins[ch].bit);
    avr_irq_register_notify(irq, &Board::onEscEdge, &edge_params_[ch]);
  }
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
  twi_.reset();  // its IRQs live in the core's pool: before avr_terminate
  pin_change_.reset();
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
  static_cast<Board*>(avr->custom.data)->slept_cycles_ += 1 + how_long_cycles;
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
  // At reset every pin becomes an input: a pulse in progress ends here (simavr does not raise
  // the pin change itself).
  for (int ch = 0; ch < kEscChannels; ++ch)
    if (esc_[ch].high) escEdge(ch, false);
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

// --- ESC ---

void Board::onEscEdge(avr_irq_t*, uint32_t value, void* param) {
  auto* p = static_cast<EdgeParam*>(param);
  p->board->escEdge(p->channel, value != 0);
}

void Board::escEdge(int channel, bool level) {
  EscPin& pin = esc_[channel];
  if (level == pin.high) return;
  const uint64_t now = avr_->cycle;
  pin.high = level;
  if (level) {
    if (pin.last_rise_cycle != 0)
      pin.last_period_us = static_cast<double>(now - pin.last_rise_cycle) * 1e6 / kCpuHz;
    pin.last_rise_cycle = now;
  } else {
    pin.last_fall_cycle = now;
    if (pin.last_rise_cycle != 0) {
      pin.last_pulse_us = static_cast<double>(now - pin.last_rise_cycle) * 1e6 / kCpuHz;
      ++pin.pulses;
      for (auto& listener : pulse_listeners_)
        listener(channel, pin.last_pulse_us, cyclesToSeconds(now));
    }
  }
}

double Board::escPulseUs(int channel, double max_age_s) const {
  const EscPin& pin = esc_.at(channel);
  if (pin.pulses == 0) return 0;
  if (cyclesToSeconds(cycle() - pin.last_fall_cycle) > max_age_s) return 0;
  return pin.last_pulse_us;
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
