// Power loss while gather_store writes a model v2 record, on the REAL images in simavr.
//
// (a) gather_store.elf on the plant bench (tools/plant, one varied KV1100 + 9x4.7 motor on
//     slot 0): cal, sweep on a full 3S LiPo, `store v2` (the old model, copy A), drain the pack
//     to 25 % charge, tare, sweep, `store v2` again (refines: the new model, copy B). Every
//     physical EEPROM byte write of that second store is recorded from the simulated CPU's
//     EECR (EEPE strobe: address EEAR, value EEDR), in order.
// (b) For EVERY cut point k = 0..N (N = writes of the second store) the EEPROM image "old image
//     + the first k writes" is what a power loss after write k leaves. read_run.elf boots on it
//     and must arm motor 0 and fly the old or the new model: its start-up line must be the old
//     or the new model's, and for two force commands the PWM it sends (status line and the
//     measured pulse on D6) must be tc::forceToPwmV2 of that same model at its filtered bus
//     voltage. The record's design also fixes WHEN it switches (the new copy becomes valid
//     with its last CRC byte), so cuts 0..N-1 must fly the old model and cut N the new one.
//
// read_run runs on a bare board: 0 mV on A0 and a constant battery on A1, so its bus filter
// settles to one value and the expected PWMs are exact (the reciprocal it keeps may be one LSB
// off 2^28 / mV: 1 us of tolerance). Budgets are simulated seconds; the bench part (two sweeps
// of 81 steps at 200 ms) is cached next to the test binary per gather_store build, because
// ctest runs every test in its own process.
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
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <gelf.h>
#include <unistd.h>

#include "eeprom_write_recorder.hpp"
#include "plant/bench.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/record_v2.hpp"

namespace {

namespace fs = std::filesystem;

std::string imagePath(const std::string& name) {
  return (fs::path(THRUSTCAL_AVR_BUILD_DIR) / "firmware" / name / (name + ".elf")).string();
}

#define REQUIRE_IMAGE(name)                                                                     \
  do {                                                                                          \
    if (!fs::exists(imagePath(name)))                                                           \
      GTEST_SKIP() << "no AVR image " << imagePath(name)                                        \
                   << ": build the AVR tree first (tools/test.sh does; or cmake --preset avr && " \
                      "cmake --build build/avr), or set THRUSTCAL_AVR_BUILD_DIR";               \
  } while (0)

// ---- EEPROM as codec Storage over a byte vector ----------------------------------------------

struct ImageStorage {
  static std::vector<uint8_t>* image;
  static uint8_t readByte(uint16_t addr) { return (*image)[addr]; }
  static void updateByte(uint16_t addr, uint8_t value) { (*image)[addr] = value; }
};
std::vector<uint8_t>* ImageStorage::image = nullptr;

tc::RecordV2Read readSlot0(std::vector<uint8_t> image, tc::ModelV2& out) {
  ImageStorage::image = &image;
  const tc::RecordV2Read r = tc::readModelV2<ImageStorage>(0, out);
  ImageStorage::image = nullptr;
  return r;
}

using hil_power::EepromWrite;
using hil_power::EepromWriteRecorder;

// ---- stack high-water mark ---------------------------------------------------------------------

// Data-space address of an ELF symbol (e.g. __bss_end), or 0 when absent.
uint16_t elfDataSymbol(const std::string& path, const char* name) {
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

std::string secondStoreName(SecondStore how) {
  return how == SecondStore::kRefine ? "Refine" : "MotorSwap";
}

void PrintTo(SecondStore how, std::ostream* os) { *os << secondStoreName(how); }

constexpr uint64_t kMotorSeed = 21;
constexpr uint64_t kSwappedMotorSeed = 22;
constexpr double kSwappedVariation = 0.08;  // clearly another motor: PWMs several us apart
constexpr char kCacheVersion[] = "hil_power-5";

std::vector<std::string> mustCommand(sim::Console& con, const std::string& line, double budget_s) {
  auto lines = con.command(line, budget_s);
  for (const auto& l : lines)
    if (l.rfind("error:", 0) == 0)
      throw std::runtime_error(fmt::format("gather_store rejected \"{}\": {}\n{}", line, l,
                                           con.tail()));
  return lines;
}

std::string storeLine(const std::vector<std::string>& lines) {
  for (const auto& l : lines)
    if (l.rfind("stored model v2", 0) == 0) return l;
  return {};
}

int wroteBytes(const std::string& line) {
  std::smatch m;
  static const std::regex re(R"(wrote (\d+) bytes?$)");
  return std::regex_search(line, m, re) ? std::stoi(m[1]) : -1;
}

plant::BenchParams benchFor(uint64_t seed, double variation) {
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = sim::motorForSeed("kv1100_9x4.7", seed, variation);
  params.load_cell.seed = seed * 1000003ULL + 17;
  params.battery_sensor.seed = seed * 1000003ULL + 29;
  return params;
}

// gather_store booted on `rig` (EEPROM already set): motor 0, plate, cal, one sweep.
void calibrateAndSweep(sim::BenchRig& rig, sim::Console& con, const plant::BenchParams& params) {
  con.waitPrompt(10.0);
  mustCommand(con, "motor 0", 5);
  mustCommand(con, "plate 60", 5);
  mustCommand(con, fmt::format("cal {}", static_cast<int>(std::lround(params.actuator.mountWeight_g()))),
              15);
  mustCommand(con, "sweep", 81 * 0.45 + 15);
  (void)rig;
}

StoreRecording recordOnTheBench(SecondStore how) {
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

uint64_t fileHash(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return std::hash<std::string>{}(s.str() + kCacheVersion);
}

std::string hexBytes(const std::vector<uint8_t>& v) {
  std::string s;
  for (uint8_t b : v) s += fmt::format("{:02x}", b);
  return s;
}

bool parseHexBytes(const std::string& s, std::vector<uint8_t>& out) {
  if (s.size() != 2 * sim::kEepromBytes) return false;
  out.resize(sim::kEepromBytes);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<uint8_t>(std::stoul(s.substr(2 * i, 2), nullptr, 16));
  return true;
}

// Cache file: "old HEX", "final HEX", "reported N", "first LINE", "second LINE", "w ADDR VALUE"...
bool loadCache(const fs::path& path, StoreRecording& r) {
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

void saveCache(const fs::path& path, const StoreRecording& r) {
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

const StoreRecording& recording(SecondStore how) {
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

std::vector<uint8_t> cutImage(const StoreRecording& rec, std::size_t k) {
  std::vector<uint8_t> image = rec.old_image;
  for (std::size_t i = 0; i < k; ++i) image[rec.writes[i].addr] = rec.writes[i].value;
  return image;
}

// ---- read_run's view ---------------------------------------------------------------------------

std::string fixed(int32_t value, int decimals) {  // fw::printFixed for value >= 0
  int32_t scale = 1;
  for (int i = 0; i < decimals; ++i) scale *= 10;
  return fmt::format("{}.{:0{}}", value / scale, value % scale, decimals);
}

// What read_run's start-up report says about a v2 slot flying `m`, up to any copy warning.
std::string reportFor(const tc::ModelV2& m) {
  std::string s = fmt::format(
      "motor 0: ok, model v2 (effective voltage), start {} us, max {} g at {} V",
      fixed(static_cast<int32_t>((static_cast<uint32_t>(m.start_q4_us) * 10u + 8u) >> 4), 1),
      tc::headroomDg(m, m.rest_mv) / 10u, fixed(m.rest_mv, 3));
  if (m.second_mv != 0) s += fmt::format(", refined at {} V", fixed(m.second_mv, 3));
  return s;
}

uint16_t expectedPwm(const tc::ModelV2& m, int grams, uint16_t bus_mv) {
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
BootResult bootAndFly(const std::vector<uint8_t>& image, const std::vector<int>& forces_g) {
  BootResult r;
  sim::Board board(imagePath("read_run"));
  board.setAdcSource([](int ch) { return ch == 1 ? kBatteryPinMv : 0.0; });
  board.setEeprom(image);
  sim::Console con(board, "rr> ");
  r.report = con.waitPrompt(5.0);
  static const std::regex status_re(
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
      std::smatch m;
      if (std::regex_search(l, m, status_re)) {
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

// ---- tests -----------------------------------------------------------------------------------

class StoreV2PowerCut : public ::testing::TestWithParam<SecondStore> {};

TEST_P(StoreV2PowerCut, TheSecondStoreWritesOnlyTheSpareCopyBodyThenSequenceThenCrc) {
  REQUIRE_IMAGE("gather_store");
  // given / when: the recorded second store
  const StoreRecording& rec = recording(GetParam());
  ASSERT_FALSE(rec.writes.empty()) << "no EEPROM write observed on EECR: " << rec.second_store_line;
  // then: it wrote the new model into copy B and said how many bytes it wrote
  EXPECT_NE(rec.first_store_line.find("copy A, sequence 1): fitted from one sweep"),
            std::string::npos)
      << rec.first_store_line;
  EXPECT_NE(rec.second_store_line.find(GetParam() == SecondStore::kRefine
                                           ? "copy B, sequence 2): refined with this sweep"
                                           : "copy B, sequence 2): fitted from one sweep"),
            std::string::npos)
      << rec.second_store_line;
  EXPECT_EQ(rec.reported_bytes, static_cast<int>(rec.writes.size())) << rec.second_store_line;
  // replaying the writes on the old image gives exactly the final image
  EXPECT_EQ(cutImage(rec, rec.writes.size()), rec.final_image);
  // every write lies in copy B, each byte once, in the record's order: body, sequence, CRC
  const uint16_t base = tc::copyAddressV2(0, 1);
  auto phase = [&](uint16_t addr) {
    const uint16_t off = static_cast<uint16_t>(addr - base);
    if (off == tc::kRecordV2SeqOffset || off == tc::kRecordV2SeqOffset + 1) return 1;
    return off >= tc::kRecordV2CrcOffset ? 2 : 0;
  };
  std::vector<bool> seen(sim::kEepromBytes, false);
  int last_phase = 0;
  for (const auto& w : rec.writes) {
    ASSERT_GE(w.addr, base);
    ASSERT_LT(w.addr, base + tc::kRecordV2Bytes);
    EXPECT_FALSE(seen[w.addr]) << "byte " << w.addr << " written twice";
    seen[w.addr] = true;
    EXPECT_GE(phase(w.addr), last_phase) << "byte " << w.addr << " out of order";
    last_phase = phase(w.addr);
  }
  EXPECT_EQ(phase(rec.writes.back().addr), 2) << "the last write must be a CRC byte";
  RecordProperty("second_store_v2_bytes", std::to_string(rec.writes.size()));
  // storing again writes nothing: the firmware says so and the EECR saw no write
  EXPECT_EQ(rec.third_store_writes, 0) << rec.third_store_line;
  EXPECT_NE(rec.third_store_line.find(GetParam() == SecondStore::kRefine
                                          ? "error: motor 0 already holds a model v2 refined by a "
                                            "sweep at"
                                          : "motor 0 already holds this model v2 (copy B, sequence "
                                            "2): nothing to write; wrote 0 bytes"),
            std::string::npos)
      << rec.third_store_line;
  // and the stack of `store v2` (fit or refine, then the two-copy write) fits the SRAM left
  // by the static data with room to spare
  EXPECT_GE(rec.free_sram_bytes, 256) << "static " << rec.static_sram_bytes << " B, stack "
                                      << rec.peak_stack_bytes << " B";
  RecordProperty("static_sram_bytes", std::to_string(rec.static_sram_bytes));
  RecordProperty("store_v2_peak_stack_bytes", std::to_string(rec.peak_stack_bytes));
  RecordProperty("free_sram_bytes", std::to_string(rec.free_sram_bytes));
  std::printf("%s: second store v2 wrote %zu bytes; SRAM static %d B, peak stack %d B, never "
              "touched %d B\n",
              secondStoreName(GetParam()).c_str(), rec.writes.size(), rec.static_sram_bytes,
              rec.peak_stack_bytes, rec.free_sram_bytes);
  RecordProperty("bench_wall_s", fmt::format("{:.2f}", rec.wall_s));
}

TEST_P(StoreV2PowerCut, EveryCutLeavesReadRunArmedAndFlyingTheOldOrTheNewModel) {
  REQUIRE_IMAGE("gather_store");
  REQUIRE_IMAGE("read_run");
  // given: the old and the new model, as the codec decodes the images before and after
  const StoreRecording& rec = recording(GetParam());
  ASSERT_FALSE(rec.writes.empty());
  tc::ModelV2 old_model, new_model;
  ASSERT_EQ(readSlot0(rec.old_image, old_model).copy, 0);
  const tc::RecordV2Read after = readSlot0(rec.final_image, new_model);
  ASSERT_EQ(after.copy, 1);
  ASSERT_EQ(after.sequence, 2u);
  const std::string old_report = reportFor(old_model), new_report = reportFor(new_model);
  ASSERT_NE(old_report, new_report);
  // Two forces where the models' PWMs differ most at read_run's bus voltage (measured on the
  // k = 0 boot). After a motor swap they differ by several us, so each PWM also tells the
  // models apart; a refine moves the PWMs by about 1 us only (the one-sweep model is already
  // close on this plant), there the start-up line tells them apart and the PWM check shows
  // that the model read_run reports is the one it flies.
  const BootResult probe = bootAndFly(rec.old_image, {100});
  ASSERT_EQ(probe.flown.size(), 1u);
  ASSERT_GT(probe.flown[0].bus_mv, 6000) << "no status line for motor 0";
  const uint16_t bus_mv = static_cast<uint16_t>(probe.flown[0].bus_mv);
  std::vector<std::pair<int, int>> by_gap;  // (|old - new| us, grams)
  for (int g = 50; g <= 400; g += 25)
    by_gap.push_back({std::abs(expectedPwm(old_model, g, bus_mv) - expectedPwm(new_model, g, bus_mv)), g});
  std::sort(by_gap.rbegin(), by_gap.rend());
  if (GetParam() == SecondStore::kMotorSwap) {
    ASSERT_GE(by_gap[1].first, 3) << "old and new model fly within 2 us of each other: the PWM "
                                     "check could not tell them apart";
  }
  RecordProperty("old_new_pwm_gap_us", std::to_string(by_gap[0].first));
  const std::vector<int> forces = {by_gap[0].second, by_gap[1].second};

  // when / then: every cut point
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = rec.writes.size();
  std::size_t flew_new = 0;
  double simulated_s = 0;
  bool seen_new = false;
  for (std::size_t k = 0; k <= n; ++k) {
    SCOPED_TRACE(fmt::format("cut after {} of {} writes", k, n));
    const BootResult b = bootAndFly(cutImage(rec, k), forces);
    simulated_s += b.simulated_s;
    // start-up report: motor 0 armed with one of the two models; the others not calibrated
    std::string line;
    for (const auto& l : b.report)
      if (l.rfind("motor 0:", 0) == 0) line = l;
    const bool is_old = line.rfind(old_report, 0) == 0;
    const bool is_new = line.rfind(new_report, 0) == 0;
    ASSERT_TRUE(is_old || is_new) << "read_run said: '" << line << "'\nold: '" << old_report
                                  << "'\nnew: '" << new_report << "'";
    const std::string tail = line.substr((is_new ? new_report : old_report).size());
    // a half-written spare copy may be reported, never anything else
    EXPECT_TRUE(tail.empty() || std::regex_match(tail, std::regex("; warning: copy B .*, flying "
                                                                  "copy A - recalibrate to "
                                                                  "restore the spare copy")))
        << line;
    EXPECT_NE(std::find(b.report.begin(), b.report.end(), "calibrated motors: 1 of 4"),
              b.report.end());
    const tc::ModelV2& flown_model = is_new ? new_model : old_model;
    // the PWMs it sends are that model's
    ASSERT_EQ(b.flown.size(), forces.size());
    for (const auto& f : b.flown) {
      ASSERT_GT(f.pwm_us, 0) << "no status line after f 0 " << f.grams;
      const int expected = expectedPwm(flown_model, f.grams, static_cast<uint16_t>(f.bus_mv));
      EXPECT_NEAR(f.pwm_us, expected, 1) << f.grams << " g";
      EXPECT_NEAR(f.pulse_us, f.pwm_us + 0.5, 1.0) << f.grams << " g on D6";
    }
    // the switch happens once, with the last CRC byte
    if (is_new) ++flew_new;
    EXPECT_FALSE(seen_new && is_old) << "went back to the old model";
    seen_new = seen_new || is_new;
    EXPECT_EQ(is_new, k == n);
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(flew_new, 1u);
  RecordProperty("cut_points", std::to_string(n + 1));
  RecordProperty("cuts_wall_s", fmt::format("{:.2f}", wall_s));
  RecordProperty("cuts_simulated_s", fmt::format("{:.1f}", simulated_s));
  std::printf("%s: %zu cut points booted in %.2f s wall (%.1f s simulated), old/new PWM gap "
              "up to %d us\n",
              secondStoreName(GetParam()).c_str(), n + 1, wall_s, simulated_s, by_gap[0].first);
}

INSTANTIATE_TEST_SUITE_P(SecondStore, StoreV2PowerCut,
                         ::testing::Values(SecondStore::kRefine, SecondStore::kMotorSwap),
                         [](const ::testing::TestParamInfo<SecondStore>& info) {
                           return secondStoreName(info.param);
                         });

// ---- v1 -> v2: `store v2` over a thesis record -------------------------------------------------
//
// The thesis (v1) record fills its slot and its CRC covers every byte, so the first byte model
// v2 writes into the slot destroys it. gather_store (tc::storeModelV2) writes the model first
// into a spare copy in another slot (slot 1, erased here), then into slot 0's copy A, then
// erases the spare. For EVERY cut point read_run must boot flying the thesis record or model
// v2, whole: the start-up line is one of the two, and the PWM it sends is that model's.

struct ThesisToV2Recording {
  std::vector<uint8_t> old_image;    // after `store 1`
  std::vector<uint8_t> final_image;  // after `store v2`
  std::vector<EepromWrite> writes;   // physical writes of `store v2`, in order
  std::vector<std::string> store_lines;
};

const ThesisToV2Recording& thesisToV2Recording() {
  static std::unique_ptr<ThesisToV2Recording> r;
  if (r) return *r;
  r = std::make_unique<ThesisToV2Recording>();
  const plant::BenchParams params = benchFor(kMotorSeed, 0.03);
  sim::BenchRig rig(imagePath("gather_store"), params, 0);
  sim::Console con(rig.board, "gs> ");
  calibrateAndSweep(rig, con, params);
  mustCommand(con, "store 1", 10);
  r->old_image = rig.board.eeprom();
  EepromWriteRecorder recorder(rig.board);
  recorder.recording = true;
  r->store_lines = mustCommand(con, "store v2", 10);
  recorder.recording = false;
  r->writes = recorder.writes;
  r->final_image = rig.board.eeprom();
  return *r;
}

StoreRecording asStoreRecording(const ThesisToV2Recording& rec) {
  StoreRecording s;
  s.old_image = rec.old_image;
  s.final_image = rec.final_image;
  s.writes = rec.writes;
  return s;
}

struct V1Status {
  int pwm_us = -1;
  int battery_mv = -1;  // compensated (v1) or filtered (v2)
  double pulse_us = -1;
};

// Boots read_run on `image`, commands `grams` to motor 0 and reads its status line.
std::pair<std::vector<std::string>, V1Status> bootAndCommand(const std::vector<uint8_t>& image, int grams) {
  sim::Board board(imagePath("read_run"));
  board.setAdcSource([](int ch) { return ch == 1 ? kBatteryPinMv : 0.0; });
  board.setEeprom(image);
  sim::Console con(board, "rr> ");
  std::pair<std::vector<std::string>, V1Status> out;
  out.first = con.waitPrompt(5.0);
  con.command(fmt::format("f 0 {}", grams), 2.0);
  for (int i = 0; i < 5; ++i) {
    con.send("");
    board.runFor(0.3);
  }
  static const std::regex status_re(R"(^motor 0: \d+\.\d g, (\d+) us, battery (\d+)\.(\d{3}) V (filtered|compensated))");
  for (const auto& l : con.command("status", 2.0)) {
    std::smatch m;
    if (std::regex_search(l, m, status_re)) {
      out.second.pwm_us = std::stoi(m[1]);
      out.second.battery_mv = std::stoi(m[2]) * 1000 + std::stoi(m[3]);
    }
  }
  out.second.pulse_us = board.escPulseUs(0);
  return out;
}

std::string v1ReportFor(const tc::MotorCalibration& cal) {
  uint16_t grams = cal.first.maxGrams();
  if (cal.hasSecondCurve() && cal.second.maxGrams() < grams) grams = cal.second.maxGrams();
  return fmt::format("motor 0: ok, V1 {} V, V2 {}, max {} g, model v1 (thesis option 2.1)",
                     fixed(cal.first.start_mv, 3),
                     cal.hasSecondCurve() ? fixed(cal.second.start_mv, 3) + " V"
                                          : std::string("none (single curve, no voltage compensation)"),
                     grams);
}

TEST(ThesisToV2PowerCut, EveryCutLeavesReadRunFlyingTheThesisRecordOrModelV2Whole) {
  REQUIRE_IMAGE("gather_store");
  REQUIRE_IMAGE("read_run");
  // given: the recorded store and both calibrations as the codec decodes them
  const ThesisToV2Recording& rec = thesisToV2Recording();
  ASSERT_FALSE(rec.writes.empty());
  std::string stored;
  for (const auto& l : rec.store_lines)
    if (l.rfind("stored model v2", 0) == 0) stored = l;
  EXPECT_NE(stored.find("(EEPROM 0..1023, copy A, sequence 1)"), std::string::npos) << stored;
  EXPECT_NE(stored.find("; replaced the thesis record"), std::string::npos) << stored;
  EXPECT_NE(std::find(rec.store_lines.begin(), rec.store_lines.end(),
                      "# power-fail safe: the old calibration stayed loadable (a copy in motor 1's slot) "
                      "until the new one was complete"),
            rec.store_lines.end());
  const StoreRecording as_store = asStoreRecording(rec);
  EXPECT_EQ(cutImage(as_store, rec.writes.size()), rec.final_image);
  auto v1 = std::make_unique<tc::MotorCalibration>();
  {
    std::vector<uint8_t> image = rec.old_image;
    ImageStorage::image = &image;
    ASSERT_EQ(tc::readRecord<ImageStorage>(0, *v1), tc::DecodeStatus::kOk);
    ImageStorage::image = nullptr;
  }
  tc::ModelV2 v2;
  ASSERT_EQ(readSlot0(rec.final_image, v2).copy, 0);
  const std::string old_report = v1ReportFor(*v1), new_report = reportFor(v2);
  // the writes: the spare in slot 1 first (its last byte a CRC byte), then slot 0, then the
  // spare's version byte
  const uint16_t spare = tc::spareAddressV2(0, 1);
  ASSERT_GE(rec.writes.size(), 3u);
  EXPECT_GE(rec.writes.front().addr, spare);
  EXPECT_LT(rec.writes.front().addr, spare + tc::kRecordV2Bytes);
  EXPECT_EQ(rec.writes.back().addr, spare);
  EXPECT_EQ(rec.writes.back().value, 0xFF);

  // when / then: every cut point
  constexpr int kGrams = 250;
  const std::size_t n = rec.writes.size();
  std::size_t first_new = n + 1;
  for (std::size_t k = 0; k <= n; ++k) {
    SCOPED_TRACE(fmt::format("cut after {} of {} writes", k, n));
    const auto [report, status] = bootAndCommand(cutImage(as_store, k), kGrams);
    std::string line;
    for (const auto& l : report)
      if (l.rfind("motor 0:", 0) == 0) line = l;
    const bool is_old = line == old_report;
    const bool is_new = line.rfind(new_report, 0) == 0;
    ASSERT_TRUE(is_old || is_new) << "read_run said: '" << line << "'\nold: '" << old_report << "'\nnew: '"
                                  << new_report << "'";
    EXPECT_NE(std::find(report.begin(), report.end(), "calibrated motors: 1 of 4"), report.end());
    ASSERT_GT(status.pwm_us, 0) << "no status line";
    tc::BusVoltageFilter bus;
    bus.reset(static_cast<uint16_t>(status.battery_mv));
    const int expected = is_new ? tc::forceToPwmV2(v2, kGrams * 10, bus).pwm_us
                                : tc::forceToPwm(*v1, kGrams, static_cast<uint16_t>(status.battery_mv)).pwm_us;
    EXPECT_NEAR(status.pwm_us, expected, is_new ? 1 : 0);
    EXPECT_NEAR(status.pulse_us, status.pwm_us + 0.5, 1.0);
    if (is_new && first_new > n) first_new = k;
    EXPECT_FALSE(first_new <= n && is_old) << "went back to the thesis record";
  }
  // the switch happens once, with the spare's last CRC byte, long before slot 0 is touched
  EXPECT_LE(first_new, tc::kRecordV2Bytes);
  RecordProperty("cut_points", std::to_string(n + 1));
  RecordProperty("switch_at_write", std::to_string(first_new));
  std::printf("v1 -> v2: %zu cut points, model v2 flies from write %zu on\n", n + 1, first_new);
}

}  // namespace
