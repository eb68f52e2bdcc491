// Shared by the power-cut tests of model v2's store (store_v2_power_cut_test.cpp: v2 -> v2,
// thesis_to_v2_power_cut_test.cpp: v1 -> v2): gather_store on the plant bench in simavr with
// every physical EEPROM write of a store recorded from the simulated EECR (cached next to the
// test binary per gather_store build, since ctest runs each test in its own process), and
// read_run booted on a cut image: its start-up report and the PWM it flies.
#pragma once

#include <gtest/gtest.h>

#include <fmt/format.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <gelf.h>
#include <unistd.h>

#include "eeprom_write_recorder.hpp"
#include "hil_support.hpp"
#include "plant/bench.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#include "text_match.hpp"
#include "thrustcal/eeprom_image.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/record_v2.hpp"


namespace power_cut {

namespace fs = std::filesystem;

// The images as every HIL test finds them (THRUSTCAL_AVR_BUILD_DIR, the environment variable of
// that name first), and HIL_REQUIRE_IMAGE to skip without them: tests/hil/hil_support.hpp.
using hil::imagePath;

// ---- EEPROM image: slot 0's v2 record ----------------------------------------------------------

inline tc::RecordV2Read readSlot0(const std::vector<uint8_t>& image, tc::ModelV2& out) {
  const tc::EepromImage::Use use(image);
  return tc::readModelV2<tc::EepromImage>(0, out);
}

using hil_power::EepromWrite;
using hil_power::EepromWriteRecorder;

// ---- stack high-water mark ---------------------------------------------------------------------

// Data-space address of an ELF symbol (e.g. __bss_end), or 0 when absent.
inline uint16_t elfDataSymbol(const std::string& path, const char* name) {
  uint32_t value = 0;
  elf_version(EV_CURRENT);
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return 0;
  Elf* elf = elf_begin(fd, ELF_C_READ, nullptr);
  for (Elf_Scn* scn = elf ? elf_nextscn(elf, nullptr) : nullptr; scn; scn = elf_nextscn(elf, scn)) {
    GElf_Shdr sh;
    if (!gelf_getshdr(scn, &sh) || sh.sh_type != SHT_SYMTAB || sh.sh_entsize == 0) continue;
    Elf_Data* data = elf_getdata(scn, nullptr);
    for (std::size_t i = 0; data && i < sh.sh_size / sh.sh_entsize; ++i) {
      GElf_Sym sym;
      if (!gelf_getsym(data, static_cast<int>(i), &sym)) continue;
      const char* sym_name = elf_strptr(elf, sh.sh_link, sym.st_name);
      if (sym_name && std::string(sym_name) == name) value = static_cast<uint32_t>(sym.st_value);
    }
  }
  if (elf) elf_end(elf);
  ::close(fd);
  return static_cast<uint16_t>(value & 0xFFFF);  // SRAM symbols live at 0x800000 + address
}

constexpr avr_io_addr_t kSpl = 0x5D, kSph = 0x5E;
constexpr uint16_t kRamEnd = 0x21FF;  // ATmega2560
constexpr uint8_t kPaint = 0xA5;

// Paints the free SRAM between the end of .bss and the stack pointer; stackLowWater() then
// finds the lowest byte the stack reached since.
class StackPaint {
 public:
  StackPaint(avr_t* avr, uint16_t bss_end) : avr_(avr), bss_end_(bss_end) {
    const uint16_t sp = static_cast<uint16_t>(avr->data[kSpl] | (avr->data[kSph] << 8));
    for (uint16_t a = bss_end; a < sp; ++a) avr->data[a] = kPaint;
  }
  // Bytes between .bss and the deepest stack byte (never touched), and the stack's depth.
  uint16_t untouchedBytes() const {
    uint16_t a = bss_end_;
    while (a <= kRamEnd && avr_->data[a] == kPaint) ++a;
    return static_cast<uint16_t>(a - bss_end_);
  }
  uint16_t peakStackBytes() const {
    return static_cast<uint16_t>(kRamEnd + 1 - bss_end_ - untouchedBytes());
  }

 private:
  avr_t* avr_;
  uint16_t bss_end_;
};

// ---- (a) the bench part: old image and the second store's writes ------------------------------

struct StoreRecording {
  std::vector<uint8_t> old_image;    // after the first store v2
  std::vector<uint8_t> final_image;  // after the second
  std::vector<EepromWrite> writes;   // physical writes of the second store, in order
  int reported_bytes = -1;           // gather_store's "wrote N bytes"
  std::string first_store_line, second_store_line;
  std::string third_store_line;  // `store v2` once more, same sweep
  int third_store_writes = -1;   // its physical writes (EEPE strobes)
  int static_sram_bytes = -1;    // .data + .bss (__bss_end - 0x200)
  int peak_stack_bytes = -1;     // deepest stack during the second store v2
  int free_sram_bytes = -1;      // SRAM the stack never reached
  double wall_s = 0, simulated_s = 0;
};

// What the second `store v2` is.
enum class SecondStore {
  kRefine,     // thesis workflow: the same motor swept again on the drained pack: refines
  kMotorSwap,  // another motor (a swapped propeller) on the same full pack: replaces
};

inline std::string secondStoreName(SecondStore how) {
  return how == SecondStore::kRefine ? "Refine" : "MotorSwap";
}

inline void PrintTo(SecondStore how, std::ostream* os) { *os << secondStoreName(how); }

constexpr uint64_t kMotorSeed = 21;
constexpr uint64_t kSwappedMotorSeed = 22;
constexpr double kSwappedVariation = 0.08;  // clearly another motor: PWMs several us apart
constexpr char kCacheVersion[] = "hil_power-5";

inline std::vector<std::string> mustCommand(sim::Console& con, const std::string& line, double budget_s) {
  auto lines = con.command(line, budget_s);
  for (const auto& l : lines)
    if (l.rfind("error:", 0) == 0)
      throw std::runtime_error(fmt::format("gather_store rejected \"{}\": {}\n{}", line, l,
                                           con.tail()));
  return lines;
}

inline std::string storeLine(const std::vector<std::string>& lines) {
  for (const auto& l : lines)
    if (l.rfind("stored model v2", 0) == 0) return l;
  return {};
}

inline int wroteBytes(const std::string& line) {
  tc::test::Groups m;
  static const tc::test::Pattern re(R"(wrote (\d+) bytes?$)");
  return re.foundIn(line, &m) ? std::stoi(m[1]) : -1;
}

inline plant::BenchParams benchFor(uint64_t seed, double variation) {
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = sim::motorForSeed("kv1100_9x4.7", seed, variation);
  params.load_cell.seed = seed * 1000003ULL + 17;
  params.battery_sensor.seed = seed * 1000003ULL + 29;
  return params;
}

// gather_store booted on `rig` (EEPROM already set): motor 0, plate, cal, one sweep.
inline void calibrateAndSweep(sim::BenchRig& rig, sim::Console& con, const plant::BenchParams& params) {
  con.waitPrompt(10.0);
  mustCommand(con, "motor 0", 5);
  mustCommand(con, "plate 60", 5);
  mustCommand(con, fmt::format("cal {}", static_cast<int>(std::lround(params.actuator.mountWeight_g()))),
              15);
  mustCommand(con, "sweep", 81 * 0.45 + 15);
  (void)rig;
}

inline StoreRecording recordOnTheBench(SecondStore how) {
  StoreRecording r;
  const plant::BenchParams params = benchFor(kMotorSeed, 0.03);
  auto rig = std::make_unique<sim::BenchRig>(imagePath("gather_store"), params, 0);
  auto con = std::make_unique<sim::Console>(rig->board, "gs> ");
  calibrateAndSweep(*rig, *con, params);
  r.first_store_line = storeLine(mustCommand(*con, "store v2", 10));
  r.old_image = rig->board.eeprom();
  r.wall_s += rig->board.wallSeconds();
  r.simulated_s += rig->board.simulatedSeconds();

  if (how == SecondStore::kRefine) {
    // Another voltage: the same pack drained to 25 % (about 11.2 V resting, 1.4 V below).
    rig->bench.power().setSoc(0.25);
    if (!rig->board.runUntil([&] { return rig->bench.actuator().rpm() < 20.0; },
                             sim::secondsToCycles(30)))
      throw std::runtime_error("the propeller still turns 30 s after the sweep");
    rig->board.runFor(0.5);
    mustCommand(*con, "tare", 15);
    mustCommand(*con, "sweep", 81 * 0.45 + 15);
  } else {
    // Power off, another motor on the plate, power on: the same EEPROM, a fresh board.
    const plant::BenchParams swapped = benchFor(kSwappedMotorSeed, kSwappedVariation);
    con.reset();
    rig = std::make_unique<sim::BenchRig>(imagePath("gather_store"), swapped, 0);
    rig->board.setEeprom(r.old_image);
    con = std::make_unique<sim::Console>(rig->board, "gs> ");
    calibrateAndSweep(*rig, *con, swapped);
  }
  EepromWriteRecorder recorder(rig->board);
  const uint16_t bss_end = elfDataSymbol(imagePath("gather_store"), "__bss_end");
  if (bss_end < 0x200) throw std::runtime_error("gather_store.elf has no __bss_end symbol");
  const StackPaint paint(rig->board.avr(), bss_end);
  recorder.recording = true;
  r.second_store_line = storeLine(mustCommand(*con, "store v2", 10));
  recorder.recording = false;
  r.static_sram_bytes = bss_end - 0x200;
  r.peak_stack_bytes = paint.peakStackBytes();
  r.free_sram_bytes = paint.untouchedBytes();
  r.writes = recorder.writes;
  r.final_image = rig->board.eeprom();
  // The same command again: nothing new to write (motor swap: the same model; refine: that
  // sweep already refined it, refused).
  recorder.writes.clear();
  recorder.recording = true;
  const auto third = con->command("store v2", 10);
  recorder.recording = false;
  r.third_store_line = third.empty() ? std::string() : third.front();
  r.third_store_writes = static_cast<int>(recorder.writes.size());
  r.reported_bytes = wroteBytes(r.second_store_line);
  r.wall_s += rig->board.wallSeconds();
  r.simulated_s += rig->board.simulatedSeconds();
  return r;
}

inline uint64_t fileHash(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return std::hash<std::string>{}(s.str() + kCacheVersion);
}

inline std::string hexBytes(const std::vector<uint8_t>& v) {
  std::string s;
  for (uint8_t b : v) s += fmt::format("{:02x}", b);
  return s;
}

inline bool parseHexBytes(const std::string& s, std::vector<uint8_t>& out) {
  if (s.size() != 2 * sim::kEepromBytes) return false;
  out.resize(sim::kEepromBytes);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<uint8_t>(std::stoul(s.substr(2 * i, 2), nullptr, 16));
  return true;
}

// Cache file: "old HEX", "final HEX", "reported N", "first LINE", "second LINE", "w ADDR VALUE"...
inline bool loadCache(const fs::path& path, StoreRecording& r) {
  std::ifstream in(path);
  if (!in) return false;
  std::string key, rest;
  while (in >> key) {
    std::getline(in, rest);
    if (!rest.empty() && rest[0] == ' ') rest.erase(0, 1);
    if (key == "old") {
      if (!parseHexBytes(rest, r.old_image)) return false;
    } else if (key == "final") {
      if (!parseHexBytes(rest, r.final_image)) return false;
    } else if (key == "reported") {
      r.reported_bytes = std::stoi(rest);
    } else if (key == "sram") {
      std::istringstream(rest) >> r.static_sram_bytes >> r.peak_stack_bytes >> r.free_sram_bytes;
    } else if (key == "third") {
      std::istringstream in3(rest);
      in3 >> r.third_store_writes;
      std::getline(in3, r.third_store_line);
      if (!r.third_store_line.empty() && r.third_store_line[0] == ' ') r.third_store_line.erase(0, 1);
    } else if (key == "first") {
      r.first_store_line = rest;
    } else if (key == "second") {
      r.second_store_line = rest;
    } else if (key == "w") {
      unsigned addr = 0, value = 0;
      std::istringstream(rest) >> addr >> value;
      r.writes.push_back({static_cast<uint16_t>(addr), static_cast<uint8_t>(value)});
    } else if (key == "end") {
      return !r.old_image.empty() && !r.final_image.empty();
    }
  }
  return false;  // no "end": cut short
}

inline void saveCache(const fs::path& path, const StoreRecording& r) {
  const fs::path tmp = path.string() + "." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << "old " << hexBytes(r.old_image) << "\nfinal " << hexBytes(r.final_image)
        << "\nreported " << r.reported_bytes << "\nsram " << r.static_sram_bytes << " "
        << r.peak_stack_bytes << " " << r.free_sram_bytes << "\nthird " << r.third_store_writes
        << " " << r.third_store_line << "\nfirst " << r.first_store_line << "\nsecond "
        << r.second_store_line << "\n";
    for (const auto& w : r.writes) out << "w " << w.addr << " " << unsigned(w.value) << "\n";
    out << "end\n";
  }
  fs::rename(tmp, path);
}

inline const StoreRecording& recording(SecondStore how) {
  static std::unique_ptr<StoreRecording> cached[2];
  std::unique_ptr<StoreRecording>& r = cached[how == SecondStore::kRefine ? 0 : 1];
  if (r) return *r;
  r = std::make_unique<StoreRecording>();
  const fs::path cache =
      fs::path(HIL_POWER_CACHE_DIR) / fmt::format("hil_power_{}_{:016x}.txt", secondStoreName(how),
                                                  fileHash(imagePath("gather_store")));
  if (!loadCache(cache, *r)) {
    *r = recordOnTheBench(how);
    saveCache(cache, *r);
  }
  return *r;
}

inline std::vector<uint8_t> cutImage(const StoreRecording& rec, std::size_t k) {
  std::vector<uint8_t> image = rec.old_image;
  for (std::size_t i = 0; i < k; ++i) image[rec.writes[i].addr] = rec.writes[i].value;
  return image;
}

// ---- read_run's view ---------------------------------------------------------------------------

inline std::string fixed(int32_t value, int decimals) {  // fw::printFixed for value >= 0
  int32_t scale = 1;
  for (int i = 0; i < decimals; ++i) scale *= 10;
  return fmt::format("{}.{:0{}}", value / scale, value % scale, decimals);
}

// What read_run's start-up report says about a v2 slot flying `m`, up to any copy warning.
inline std::string reportFor(const tc::ModelV2& m) {
  std::string s = fmt::format(
      "motor 0: ok, model v2 (effective voltage), start {} us, max {} g at {} V",
      fixed(static_cast<int32_t>((static_cast<uint32_t>(m.start_q4_us) * 10u + 8u) >> 4), 1),
      tc::headroomDg(m, m.rest_mv) / 10u, fixed(m.rest_mv, 3));
  if (m.second_mv != 0) s += fmt::format(", refined at {} V", fixed(m.second_mv, 3));
  return s;
}

inline uint16_t expectedPwm(const tc::ModelV2& m, int grams, uint16_t bus_mv) {
  tc::BusVoltageFilter bus;
  bus.reset(bus_mv);
  return tc::forceToPwmV2(m, static_cast<uint16_t>(grams * 10), bus).pwm_us;
}

constexpr double kBatteryPinMv = 3500.0;  // A1: about 10.95 V on the thesis divider

struct FlownCommand {
  int grams = 0;
  int pwm_us = -1;        // read_run's status line
  int bus_mv = -1;        // its filtered bus voltage
  double pulse_us = -1;   // measured on ESC 0
};

struct BootResult {
  std::vector<std::string> report;  // lines before the first prompt
  std::vector<FlownCommand> flown;
  double simulated_s = 0;
};

// Boots read_run on `image`, then for each force: "f 0 G", 1.5 s of keep-alive lines (the
// bus filter and the commanded-force filter settle), "status".
inline BootResult bootAndFly(const std::vector<uint8_t>& image, const std::vector<int>& forces_g) {
  BootResult r;
  sim::Board board(imagePath("read_run"));
  board.setAdcSource([](int ch) { return ch == 1 ? kBatteryPinMv : 0.0; });
  board.setEeprom(image);
  sim::Console con(board, "rr> ");
  r.report = con.waitPrompt(5.0);
  static const tc::test::Pattern status_re(
      R"(^motor 0: (\d+\.\d) g, (\d+) us, battery (\d+)\.(\d{3}) V filtered)");  // force in decigrams
  for (int g : forces_g) {
    FlownCommand f;
    f.grams = g;
    con.command(fmt::format("f 0 {}", g), 2.0);
    for (int i = 0; i < 5; ++i) {
      con.send("");
      board.runFor(0.3);
    }
    for (const auto& l : con.command("status", 2.0)) {
      tc::test::Groups m;
      if (status_re.foundIn(l, &m)) {
        f.pwm_us = std::stoi(m[2]);
        f.bus_mv = std::stoi(m[3]) * 1000 + std::stoi(m[4]);
      }
    }
    f.pulse_us = board.escPulseUs(0);
    r.flown.push_back(f);
  }
  r.simulated_s = board.simulatedSeconds();
  return r;
}

}  // namespace power_cut
