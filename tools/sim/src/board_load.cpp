// Loading a board's flash and EEPROM (sim/board.hpp, FlashImages): the application (an AVR ELF
// or Intel HEX) and a bootloader behind it.
#include "sim/board.hpp"

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

extern "C" {
#include <simavr/avr_eeprom.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
}

namespace sim {
namespace {

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
    try {
      a.hex = readHexFlash(app, "application");
    } catch (const BoardError& e) {
      // Not ELF and not Intel HEX: say both, so a truncated or foreign .elf is not reported as
      // a broken HEX file only.
      throw BoardError(fmt::format("{}: neither an AVR ELF file (it does not start with the ELF magic "
                                   "0x7F 'E' 'L' 'F') nor Intel HEX; give the .elf the AVR build "
                                   "wrote, or a .hex of it (avr-objcopy -O ihex). As Intel HEX: {}",
                                   app, e.what()));
    }
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

}  // namespace sim
