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
#include "thrustcal/source_tree.hpp"

namespace bench {

namespace {

constexpr uint64_t kCycleTarget = 1000;
constexpr uint64_t kModelsSramTarget = 1024;
// tools/bench/avr/probe.cpp's labels.
constexpr int kLabelV2Frame = 1, kLabelV2Steady = 2, kLabelThesis = 3, kLabelThesisMedian = 4,
              kLabelV2Reading = 5, kLabelShaping = 6;

std::string shown(const std::string& path) { return shownPath(path); }

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

std::string sourcePath(const std::string& rel) { return thrustcal::sourceTree() + "/" + rel; }

std::string shownPath(const std::string& path) {
  const std::string root = thrustcal::sourceTree() + "/";
  return path.rfind(root, 0) == 0 ? path.substr(root.size()) : path;
}

ImageSize imageSize(const std::string& elf) {
  const SizeInfo z = avrSize(elf);
  return {z.flash(), z.sram()};
}

std::string AvrPaths::elf(const std::string& image) const {
  const std::string tree = avr_build.empty() ? sourcePath("build/avr") : avr_build;
  return tree + "/firmware/" + image + "/" + image + ".elf";
}

namespace {

// Where the cycles of V2Frame::fly go: the frame's steps, by the labels of its assembly.
Table breakdownTable(const ProbeResult& r, const std::string& probe, nlohmann::json& json) {
  Table b("2b. Compute breakdown: V2Frame::fly, cycles per frame by step (mean over the frames above)",
          {"step", "cycles", "share"});
  const std::vector<ProfileRange> ranges = {
      {"call: save registers", "_ZN2tc7V2Frame3flyEjh"},
      {"reading check, limits, filter constant", "tc_v2fly_check"},
      {"bus filter: first-order step + Newton reciprocal", "tc_v2fly_filter"},
      {"sag filter (the commands' bench sag, filtered)", "tc_v2fly_sag"},
      {"prediction: 1/V at the commands (3 products)", "tc_v2fly_predict"},
      {"  (rare paths: stop, clamp to the curve)", "tc_v2fly_rare_a"},
      {"per motor: command, model, fine/coarse run", "tc_v2fly_lane"},
      {"per motor: knot position (16x16)", "tc_v2fly_knot"},
      {"per motor: drive between the knots (16x16, rounded)", "tc_v2fly_interp"},
      {"per motor: bench sag at the command (2 x 8x8)", "tc_v2fly_sagpt"},
      {"per motor: duty = drive / V + start (16x16)", "tc_v2fly_duty"},
      {"per motor: limits, store pulse and flags, next", "tc_v2fly_limits"},
      {"  (rare paths: bus not valid, limits hit)", "tc_v2fly_rare_b"},
      {"return: total sag, restore registers", "tc_v2fly_out"},
  };
  const auto by_range = cyclesByRange(r, probe, ranges, "_ZN2tc7V2Frame3flyEjh");
  const CycleStat& frame = r.sections.at(kLabelV2Frame);
  uint64_t total = 0;
  for (const auto& [name, cycles] : by_range) total += cycles;
  for (const auto& [name, cycles] : by_range) {
    const double per_frame = frame.count ? static_cast<double>(cycles) / frame.count : 0.0;
    b.addRow({name, fixed(per_frame, 1), total ? fmt::format("{:.1f} %", 100.0 * cycles / total) : "-"});
    json["breakdown"].push_back({{"step", name}, {"cycles_per_frame", per_frame}});
  }
  b.addRow({"total (the function alone, without the caller's argument setup)",
            fixed(frame.count ? static_cast<double>(total) / frame.count : 0.0, 1), "100 %"});
  b.addNote("cycles attributed to the address of each instruction (simavr, one instruction per step) and "
            "summed between the assembly's tc_v2fly_* labels; per motor rows are for all four motors");
  return b;
}

// Equal dynamics (`dyn on`): the force API shapes each command before the v2 frame; its cycles
// and read_run's v2 frame with them.
void addShapingRows(const ProbeResult& r, Table& t, nlohmann::json& json) {
  auto shaping = r.sections.find(kLabelShaping);
  if (shaping == r.sections.end()) throw std::runtime_error("the AVR probe did not measure the shaping (dyn on)");
  const CycleStat& sh = shaping->second;
  const CycleStat& v2 = r.sections.at(kLabelV2Frame);
  t.addRow({"equal dynamics (dyn on): DynShaper::stepAll, 4 motors", std::to_string(sh.mean), std::to_string(sh.min),
            std::to_string(sh.max), "-", "-"});
  t.addRow({"v2 as read_run flies it with dyn on (the frame + the shaping)", std::to_string(v2.mean + sh.mean), "",
            std::to_string(v2.max + sh.max), "-", "-"});
  json["updates"]["dyn_shaping"] = {{"name", "equal dynamics (dyn on): DynShaper::stepAll, 4 motors"},
                                    {"frames", sh.count}, {"mean_cycles", sh.mean},
                                    {"min_cycles", sh.min}, {"max_cycles", sh.max}};
  json["v2_read_run_with_dyn"] = {{"mean_cycles", v2.mean + sh.mean}, {"max_cycles", v2.max + sh.max}};
}

}  // namespace

Section computeSection(const AvrPaths& paths) {
  Section s;
  s.key = "compute";
  Table t("2. Compute: simulated ATmega2560 cycles (simavr, 16 MHz) of read_run's calls for four "
          "motors, 100-450 g commands changing every frame, draining bus",
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
  const ProbeResult r = runProbe(probe, 400000000ull, kLabelV2Frame);
  struct RowSpec {
    int label;
    const char* key;
    const char* name;
    bool target;
  };
  const RowSpec rows[] = {
      {kLabelV2Frame, "v2_read_run",
       "v2 as read_run flies it: V2Frame::fly (bus filter + 4 motors + sag prediction)", true},
      {kLabelV2Steady, "v2_frame", "v2 one-call frame, the same commands every frame: V2Frame::fly", true},
      {kLabelV2Reading, "v2_battery_reading", "v2 battery reading: the middle two of four readings", false},
      {kLabelThesis, "thesis_controller",
       "thesis option 2.1 as read_run flies it: 4 x (compensated reading + forceToPwm)", false},
      {kLabelThesisMedian, "thesis_battery_median", "thesis battery reading: median of 101 (4 pushes)", false},
  };
  // The assembly must give the portable C++'s state on every frame checked, or no target is met.
  const uint16_t mismatches = r.values.count(0x89) ? r.values.at(0x89) : 0xFFFF;
  const uint16_t checked = r.values.count(0x8A) ? r.values.at(0x8A) : 0;
  for (const RowSpec& row : rows) {
    auto it = r.sections.find(row.label);
    if (it == r.sections.end()) throw std::runtime_error(std::string("the AVR probe did not measure ") + row.name);
    const CycleStat& c = it->second;
    const bool met = c.max <= kCycleTarget && mismatches == 0 && checked > 0;
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
  const CycleStat& th = r.sections.at(kLabelThesis);
  const CycleStat& med = r.sections.at(kLabelThesisMedian);
  t.addRow({"thesis total (reading + controller)", std::to_string(th.mean + med.mean), "", "", "-", "-"});
  addShapingRows(r, t, s.json);
  const uint16_t failures = r.values.count(0x83) ? r.values.at(0x83) : 0xFFFF;
  if (failures != 0) t.addNote(fmt::format("WARNING: {} model fits or loads failed inside the probe", failures));
  t.addNote(fmt::format("probe: {} (core/ and read_run's slot storage built with avr-g++ -Os as in the AVR "
                        "tree, the thesis steps read through hal/avr's Eeprom), net of {} cycles of marker "
                        "overhead, {} frames each; the calls' argument setup is included",
                        shown(probe), r.overhead_cycles, th.count));
  t.addNote(fmt::format("V2Frame::fly is assembly on the AVR; on {} frames with insane readings, jumps, rate "
                        "changes, stops and saturation, bus readings from 3.0 to 26.0 V and a 5 g and a 5 kg "
                        "motor, it gave the same state as its portable C++: {}",
                        checked, mismatches == 0 ? "every frame" : fmt::format("NOT on {} frames", mismatches)));
  t.addNote("one call: V2Frame::fly is read_run's one call per frame for all its v2 motors; it replaces issue "
            "5's forceToPwmV2Frame (no sag prediction, 1295 cycles max) and includes the prediction");
  s.json["available"] = true;
  s.json["target_max_cycles"] = kCycleTarget;
  s.json["probe_elf"] = shown(probe);
  s.json["assembly_vs_portable"] = {{"frames", checked}, {"mismatches", mismatches}};
  s.tables.push_back(std::move(t));
  s.tables.push_back(breakdownTable(r, probe, s.json));
  return s;
}

Section footprintSection(const AvrPaths& paths) {
  Section s;
  s.key = "footprint";
  Table t("3. Footprint: AVR images (avr-size; stacks measured in simavr), SRAM of read_run's models "
          "(sizeof on the AVR), EEPROM per motor",
          {"item", "bytes", "of", "target", "met?"});
  for (const char* image : {"gather_store", "read_run"}) {
    const std::string elf = paths.elf(image);
    if (!std::filesystem::exists(elf)) {
      t.addRow({std::string(image) + ".elf", "missing", "", "-", "-"});
      t.addNote(fmt::format("{} not found: build the AVR tree (cmake -DCMAKE_TOOLCHAIN_FILE="
                            "toolchain-avr.cmake; --target {}) or pass --avr-build DIR", elf, image));
      s.json["images"][image] = {{"available", false}, {"elf", shown(elf)}};
      continue;
    }
    const SizeInfo z = avrSize(elf);
    const bool sram_met = z.sram() <= kStaticSramTargetBytes;
    t.addRow({fmt::format("{} flash (.text + .data)", image), std::to_string(z.flash()), "262144", "-", "-"});
    t.addRow({fmt::format("{} static SRAM (.data + .bss)", image), std::to_string(z.sram()), "8192",
              fmt::format("<= {} (2 KB stack)", kStaticSramTargetBytes), verdict(sram_met)});
    s.json["images"][image] = {{"available", true}, {"elf", shown(elf)}, {"flash_bytes", z.flash()},
                               {"sram_static_bytes", z.sram()}, {"text", z.text}, {"data", z.data},
                               {"bss", z.bss}, {"sram_static_target_bytes", kStaticSramTargetBytes}};
    s.targets.push_back({fmt::format("3. static SRAM of {} (>= 2 KB left for the stack)", image),
                         fmt::format("{} bytes", z.sram()), fmt::format("<= {} bytes", kStaticSramTargetBytes),
                         sram_met});
    s.json["met"][fmt::format("{}_static_sram", image)] = sram_met;
    if (std::string(image) == "read_run") {
      const uint64_t app = symbolSize(elf, "(anonymous namespace)::app");
      if (app) {
        t.addRow({"read_run app object (ReadRunApp: slots, frame, median of 101)", std::to_string(app), "", "-", "-"});
        s.json["images"][image]["app_object_bytes"] = app;
      }
    }
  }
  const std::string probe = probePath(paths);
  if (!probe.empty() && std::filesystem::exists(probe)) {
    const ProbeResult r = runProbe(probe);
    const uint64_t v2 = r.values.at(0x80), v1 = r.values.at(0x81), slot = r.values.at(0x82);
    const uint64_t v2run = r.values.at(0x85), v1run = r.values.at(0x86), frame = r.values.at(0x88);
    const bool slots_met = 4 * slot <= kModelsSramTarget;
    t.addRow({fmt::format("read_run's four slots, v1 or v2 (4 x sizeof(tc::SlotModel) = 4 x {})", slot),
              std::to_string(4 * slot), "", "<= 1024", verdict(slots_met)});
    t.addRow({fmt::format("  four v2 models as flown (4 x sizeof(tc::ModelV2Run) = 4 x {})", v2run),
              std::to_string(4 * v2run), "", "-", "-"});
    t.addRow({fmt::format("  four thesis models as flown (4 x sizeof(tc::ThesisRun) = 4 x {})", v1run),
              std::to_string(4 * v1run), "", "-", "-"});
    t.addRow({"read_run's frame of its v2 motors (tc::V2Frame)", std::to_string(frame), "", "-", "-"});
    t.addRow({fmt::format("decoded records at start-up, on the stack (tc::MotorCalibration {} + tc::ModelV2 {})", v1, v2),
              std::to_string(v1 + v2), "", "-", "-"});
    t.addNote("read_run keeps the thesis curves' steps in the EEPROM (read on demand, PWM checkpoints every "
              "16 g in SRAM) and model v2 in the form its frame reads: a slot is a union of the two");
    s.json["models_sram"] = {{"sizeof_model_v2", v2}, {"sizeof_motor_calibration", v1},
                             {"sizeof_slot_model", slot}, {"sizeof_model_v2_run", v2run},
                             {"sizeof_thesis_run", v1run}, {"sizeof_v2_frame", frame},
                             {"read_run_four_slots_bytes", 4 * slot}, {"four_v2_bytes", 4 * v2run},
                             {"four_v1_bytes", 4 * v1run}, {"target_bytes", kModelsSramTarget}};
    s.targets.push_back({"3. SRAM of read_run's four slots (v1 or v2 each)", fmt::format("{} bytes", 4 * slot),
                         "<= 1024 bytes", slots_met});
    s.json["met"]["read_run_slots"] = slots_met;
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
