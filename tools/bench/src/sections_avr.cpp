// Benchmarks 2 (compute) and 3 (footprint): the AVR probe in libsimavr, avr-size and avr-nm on
// the real firmware images.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include <fmt/format.h>

#include "bench/avr_probe.hpp"
#include "bench/sections.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/record_v2.hpp"

namespace bench {

namespace {

constexpr uint64_t kCycleTarget = 1000;
constexpr uint64_t kModelsSramTarget = 1024;

std::string probePath(const AvrPaths& paths) {
  return paths.probe_elf.empty() ? builtinProbePath() : paths.probe_elf;
}

// Runs a command, returns its stdout; throws with the command line if it fails.
std::string run(const std::string& cmd) {
  std::unique_ptr<FILE, int (*)(FILE*)> p(popen((cmd + " 2>/dev/null").c_str(), "r"), pclose);
  if (!p) throw std::runtime_error("cannot run: " + cmd);
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p.get())) > 0) out.append(buf, n);
  const int rc = pclose(p.release());
  if (rc != 0)
    throw std::runtime_error("'" + cmd + "' failed (exit " + std::to_string(rc) +
                             "); is binutils-avr installed?");
  return out;
}

struct SizeInfo {
  uint64_t text = 0, data = 0, bss = 0, noinit = 0, eeprom = 0;
  uint64_t flash() const { return text + data; }
  uint64_t sram() const { return data + bss + noinit; }
};

SizeInfo avrSize(const std::string& elf) {
  std::istringstream in(run("avr-size -A '" + elf + "'"));
  SizeInfo s;
  std::string name;
  uint64_t size = 0, addr = 0;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream l(line);
    if (!(l >> name >> size >> addr)) continue;
    if (name == ".text") s.text = size;
    else if (name == ".data") s.data = size;
    else if (name == ".bss") s.bss = size;
    else if (name == ".noinit") s.noinit = size;
    else if (name == ".eeprom") s.eeprom = size;
  }
  return s;
}

// Size of a data symbol (avr-nm -S -C), 0 if absent.
uint64_t symbolSize(const std::string& elf, const std::string& demangled) {
  std::istringstream in(run("avr-nm -S -C '" + elf + "'"));
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream l(line);
    std::string addr, size, type;
    if (!(l >> addr >> size >> type)) continue;
    std::string name;
    std::getline(l, name);
    if (!name.empty() && name.front() == ' ') name.erase(0, 1);
    if (name == demangled) return std::stoull(size, nullptr, 16);
  }
  return 0;
}

}  // namespace

std::string AvrPaths::elf(const std::string& image) const {
  const std::string tree = avr_build.empty() ? std::string(THRUSTCAL_SOURCE_DIR) + "/build/avr" : avr_build;
  return tree + "/firmware/" + image + "/" + image + ".elf";
}

Section computeSection(const AvrPaths& paths) {
  Section s;
  s.key = "compute";
  Table t("2. Compute: simulated ATmega2560 cycles (simavr, 16 MHz) for one four-motor update, "
          "100-450 g commands, draining bus",
          {"update", "mean", "min", "max", "target", "met?"});
  const std::string probe = probePath(paths);
  if (probe.empty() || !std::filesystem::exists(probe)) {
    t.addRow({"not available", "", "", "", "<= 1000", "-"});
    t.addNote("the AVR probe was not built: avr-g++ was missing when the host tree was configured "
              "(install gcc-avr avr-libc, re-run cmake)");
    s.json = {{"available", false}, {"reason", "AVR probe not built (avr-g++ missing)"}};
    s.tables.push_back(std::move(t));
    return s;
  }
  const ProbeResult r = runProbe(probe);
  struct RowSpec {
    int label;
    const char* key;
    const char* name;
    bool target;
  };
  const RowSpec rows[] = {
      {3, "thesis_controller", "thesis option 2.1: 4 x (sag-compensated reading + forceToPwm)", false},
      {4, "thesis_battery_median", "thesis battery reading: median of 101 (4 pushes + median)", false},
      {1, "v2_read_run", "v2 as read_run flies it: filter + 4 x forceToPwmV2 (sag prediction)", true},
      {2, "v2_frame", "v2 one call: filter + forceToPwmV2Frame (no sag prediction)", true},
  };
  for (const RowSpec& row : rows) {
    auto it = r.sections.find(row.label);
    if (it == r.sections.end()) throw std::runtime_error(std::string("the AVR probe did not measure ") + row.name);
    const CycleStat& c = it->second;
    const bool met = c.max <= kCycleTarget;
    t.addRow({row.name, std::to_string(c.mean), std::to_string(c.min), std::to_string(c.max),
              row.target ? "<= 1000 (max)" : "-", row.target ? verdict(met) : "-"});
    s.json["updates"][row.key] = {{"name", row.name}, {"frames", c.count}, {"mean_cycles", c.mean},
                                  {"min_cycles", c.min}, {"max_cycles", c.max}};
    if (row.target) {
      s.json["met"][row.key] = met;
      s.targets.push_back({fmt::format("2. {}", row.name), fmt::format("{} cycles max", c.max),
                           "<= 1000 cycles", met});
    }
  }
  const CycleStat& th = r.sections.at(3);
  const CycleStat& med = r.sections.at(4);
  t.addRow({"thesis total (reading + controller)", std::to_string(th.mean + med.mean), "", "", "-", "-"});
  const uint16_t failures = r.values.count(0x83) ? r.values.at(0x83) : 0xFFFF;
  if (failures != 0) t.addNote(fmt::format("WARNING: {} model fits failed inside the probe", failures));
  t.addNote(fmt::format("probe: {} (core/ built with avr-g++ -Os as in the AVR tree), net of {} "
                        "cycles of marker overhead, {} frames each",
                        probe, r.overhead_cycles, th.count));
  t.addNote("read_run also pushes the 4 battery readings into the median of 101 on v2 frames "
            "(for its status line): that cost is outside the v2 rows");
  s.json["available"] = true;
  s.json["target_max_cycles"] = kCycleTarget;
  s.json["probe_elf"] = probe;
  s.tables.push_back(std::move(t));
  return s;
}

Section footprintSection(const AvrPaths& paths) {
  Section s;
  s.key = "footprint";
  Table t("3. Footprint: AVR images (avr-size), SRAM of the four motors' models (sizeof on the "
          "AVR), EEPROM per motor",
          {"item", "bytes", "of", "target", "met?"});
  for (const char* image : {"gather_store", "read_run"}) {
    const std::string elf = paths.elf(image);
    if (!std::filesystem::exists(elf)) {
      t.addRow({std::string(image) + ".elf", "missing", "", "-", "-"});
      t.addNote(fmt::format("{} not found: build the AVR tree (cmake -DCMAKE_TOOLCHAIN_FILE="
                            "toolchain-avr.cmake; --target {}) or pass --avr-build DIR", elf, image));
      s.json["images"][image] = {{"available", false}, {"elf", elf}};
      continue;
    }
    const SizeInfo z = avrSize(elf);
    t.addRow({fmt::format("{} flash (.text + .data)", image), std::to_string(z.flash()), "262144", "-", "-"});
    t.addRow({fmt::format("{} static SRAM (.data + .bss)", image), std::to_string(z.sram()), "8192", "-", "-"});
    s.json["images"][image] = {{"available", true}, {"elf", elf}, {"flash_bytes", z.flash()},
                               {"sram_static_bytes", z.sram()}, {"text", z.text}, {"data", z.data},
                               {"bss", z.bss}};
    if (std::string(image) == "read_run") {
      const uint64_t app = symbolSize(elf, "(anonymous namespace)::app");
      if (app) {
        t.addRow({"read_run app object (ReadRunApp, incl. the four slots)", std::to_string(app), "", "-", "-"});
        s.json["images"][image]["app_object_bytes"] = app;
      }
    }
  }
  const std::string probe = probePath(paths);
  if (!probe.empty() && std::filesystem::exists(probe)) {
    const ProbeResult r = runProbe(probe);
    const uint64_t v2 = r.values.at(0x80), v1 = r.values.at(0x81), slot = r.values.at(0x82);
    const uint64_t v2_symbol = symbolSize(probe, "bench_models_v2");
    t.addRow({fmt::format("four v2 models (4 x sizeof(tc::ModelV2) = 4 x {})", v2), std::to_string(4 * v2),
              "", "<= 1024", verdict(4 * v2 <= kModelsSramTarget)});
    t.addRow({fmt::format("four thesis calibrations (4 x sizeof(tc::MotorCalibration) = 4 x {})", v1),
              std::to_string(4 * v1), "", "-", "-"});
    t.addRow({fmt::format("read_run's four slots, v1 or v2 (4 x sizeof(rr::SlotModel) = 4 x {})", slot),
              std::to_string(4 * slot), "", "<= 1024", verdict(4 * slot <= kModelsSramTarget)});
    if (v2_symbol && v2_symbol != 4 * v2)
      t.addNote(fmt::format("WARNING: avr-nm says bench_models_v2 is {} bytes, sizeof says {}", v2_symbol, 4 * v2));
    t.addNote("read_run keeps the thesis model flyable per slot: each slot is a union sized for v1, "
              "so the image reserves the v1 size even when all four fly v2");
    s.json["models_sram"] = {{"sizeof_model_v2", v2}, {"sizeof_motor_calibration", v1},
                             {"sizeof_slot_model", slot}, {"four_v2_bytes", 4 * v2},
                             {"four_v1_bytes", 4 * v1}, {"read_run_four_slots_bytes", 4 * slot},
                             {"nm_bench_models_v2_bytes", v2_symbol}, {"target_bytes", kModelsSramTarget}};
    s.targets.push_back({"3. SRAM of four v2 models (sizeof on the AVR)", fmt::format("{} bytes", 4 * v2),
                         "<= 1024 bytes", 4 * v2 <= kModelsSramTarget});
    s.targets.push_back({"3. SRAM of read_run's four slots (v1/v2 union)", fmt::format("{} bytes", 4 * slot),
                         "<= 1024 bytes", 4 * slot <= kModelsSramTarget});
    s.json["met"] = {{"four_v2_models", 4 * v2 <= kModelsSramTarget},
                     {"read_run_slots", 4 * slot <= kModelsSramTarget}};
  } else {
    t.addRow({"models' SRAM: not available (AVR probe not built, avr-g++ missing)", "", "", "<= 1024", "-"});
  }
  if (std::filesystem::exists(paths.elf("gather_store")) && std::filesystem::exists(paths.elf("read_run")))
    addStackHeadroom(paths, t, s.json, s.targets);
  t.addRow({"EEPROM per motor, thesis v1 record", std::to_string(tc::kRecordBytes), "1024", "-", "-"});
  t.addRow({fmt::format("EEPROM per motor, v2 (two copies of {})", tc::kRecordV2Bytes),
            std::to_string(2 * tc::kRecordV2Bytes), "1024", "-", "-"});
  s.json["eeprom_per_motor"] = {{"v1_bytes", tc::kRecordBytes}, {"v2_bytes", 2 * tc::kRecordV2Bytes},
                                {"v2_copy_bytes", tc::kRecordV2Bytes}, {"slot_bytes", 1024}};
  s.tables.push_back(std::move(t));
  return s;
}

}  // namespace bench
