// The swap experiment's calibrations (sim/swap.hpp): the stock motors and each swapped part with
// the real gather_store, cached in the output folder; the settings of the modes without records
// (pwm's hover point, ArduPilot's fitted parameters); the motors' time constants.
#include <fcntl.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "hex/intel_hex.hpp"
#include "lab/autopilot_export.hpp"
#include "lab/dataset.hpp"
#include "plant/actuator.hpp"
#include "plant/fidelity.hpp"
#include "plant/power_source.hpp"
#include "sim/dynamics_session.hpp"
#include "sim/swap.hpp"

namespace sim::swap {

namespace fs = std::filesystem;

const std::vector<Part>& swapParts() {
  static const std::vector<Part> kParts = {
      {"kv1100_9x4.7", "kv1100_9x4.7", 15, 1.0, "another KV1100 + APC 9x4.7 unit (seed 15)"},
      {"kv900_11x4.7", "kv900_11x4.7", 16, 1.0, "a KV900 motor with an APC 11x4.7 propeller (seed 16)"},
      {"prop-8pct", "kv1100_9x4.7", 12, 0.92,
       "the stock motor 1 with a propeller giving 8 % less thrust (C_T x 0.92, same C_P)"},
  };
  return kParts;
}

const Part& findPart(const std::string& name) {
  std::string known;
  for (const Part& p : swapParts()) {
    if (p.name == name) return p;
    known += (known.empty() ? "" : ", ") + p.name;
  }
  throw std::invalid_argument(
      fmt::format("unknown part '{}'; the parts that can replace motor {} are: {}", name, kSwapSlot, known));
}

namespace {
// The part's propeller on its varied motor: the bench and the rig get the same.
void fitPropeller(const Part& part, plant::ActuatorParams& a) {
  a.prop.ct_low *= part.thrust_scale;
  a.prop.ct_high *= part.thrust_scale;
  if (part.thrust_scale != 1.0) a.name += fmt::format("_ct{:g}", part.thrust_scale);
}

// The part on the thesis bench: its propeller, and the amplifier's offset trimmed so the mounted
// part reads at rest what the stock motor read (the thesis set it for its motor; a heavier one
// leaves the INA125P at its lower rail and gather_store refuses `cal`: "ADC rail").
void mountOnBench(const Part& part, const std::string& stock_preset, plant::BenchParams& b) {
  fitPropeller(part, b.actuator);
  const double heavier_g = b.actuator.mountWeight_g() - plant::presetParams(stock_preset).mountWeight_g();
  b.load_cell.offset_mv += b.load_cell.millivoltsPerGram() * heavier_g;
}
}  // namespace

plant::ActuatorParams actuatorOf(const Part& part, double variation) {
  plant::ActuatorParams a = motorForSeed(part.preset, part.seed, variation);
  fitPropeller(part, a);
  return a;
}

const PartCalibration& Calibration::of(const std::string& part) const {
  for (const PartCalibration& p : parts)
    if (p.part == part) return p;
  throw std::out_of_range("no calibration for part '" + part + "'");
}

namespace {

// FNV-1a of bytes: the cache key changes when gather_store (or the image dyn starts from) does.
std::string bytesDigest(const std::vector<uint8_t>& bytes) {
  uint64_t h = 1469598103934665603ULL;
  for (uint8_t c : bytes) h = (h ^ c) * 1099511628211ULL;
  return fmt::format("{:016x}", h);
}

std::string fileDigest(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error(
        fmt::format("{}: cannot read the image; build it (cmake --build --preset avr)", path));
  return bytesDigest(std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()));
}

void writeAtomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp" + std::to_string(std::hash<std::string>{}(text)&0xFFFF);
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw std::runtime_error(fmt::format("{}: cannot write; check --out-dir", tmp.string()));
    out << text;
  }
  fs::rename(tmp, path);
}

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// What made a calibration: the image, the settings, the motors (and for a part, the stock key).
nlohmann::json cacheKey(const SwapOptions& o, const std::string& elf_digest, const Part* part) {
  nlohmann::json k = {{"gather_store", elf_digest},   {"model", gatherModelName(o.model)},
                      {"variation", o.variation},     {"stock_preset", o.stock_preset},
                      {"stock_seeds", o.stock_seeds}, {"sweep", "scenario defaults"}};
  if (part)
    k["part"] = {{"name", part->name},
                 {"preset", part->preset},
                 {"seed", part->seed},
                 {"thrust_scale", part->thrust_scale},
                 {"slot", kSwapSlot}};
  return k;
}

GatherOptions gatherBase(const SwapOptions& o) {
  GatherOptions g;
  g.elf_path = o.gather_elf;
  g.link = GatherLink::kInProcess;  // simulated time only: the same image gives the same bytes
  g.model = o.model;
  g.variation = o.variation;
  g.progress = [](const std::string&) {};
  return g;
}

// The cached image when its key matches, else a fresh gather saved with its key.
PartCalibration gatherCached(const std::string& name, const nlohmann::json& key, const GatherOptions& g,
                             const fs::path& dir, const ProgressFn& progress) {
  PartCalibration pc;
  pc.part = name;
  pc.eeprom_path = (dir / (name + ".hex")).string();
  const fs::path key_path = dir / (name + ".key.json");
  if (fs::exists(pc.eeprom_path) && fs::exists(key_path) && readText(key_path) == key.dump(2) + "\n") {
    try {
      pc.eeprom = hex::readIntelHexFile(pc.eeprom_path, kEepromBytes);
      pc.cached = true;
      progress(fmt::format("calibration of {}: cached ({})", name, pc.eeprom_path));
      return pc;
    } catch (const std::exception&) {
      // a damaged image is gathered again
    }
  }
  progress(fmt::format("calibration of {}: gather_store on the virtual bench, slot(s) {}", name,
                       fmt::join(g.slots, " ")));
  const GatherResult r = runGather(g);
  pc.eeprom = r.eeprom;
  pc.curve_error_max_g = r.curve_error_max_g;
  hex::writeIntelHexFile(pc.eeprom_path + ".new", r.eeprom);
  fs::rename(pc.eeprom_path + ".new", pc.eeprom_path);
  writeAtomically(key_path, key.dump(2) + "\n");
  return pc;
}

// Every byte outside slot 1 as the stock image has it: the other slots' records were not touched.
void checkOtherSlots(const std::vector<uint8_t>& stock, const std::vector<uint8_t>& swapped,
                     const std::string& part) {
  const std::size_t lo = static_cast<std::size_t>(kSwapSlot) * 1024, hi = lo + 1024;
  for (std::size_t a = 0; a < stock.size(); ++a) {
    if (a >= lo && a < hi) continue;
    if (stock[a] != swapped.at(a))
      throw std::runtime_error(
          fmt::format("calibrating {} into slot {} changed EEPROM byte {} (slot {}): 0x{:02X} -> 0x{:02X}; "
                      "only slot {} may "
                      "change. Delete the cached images in the output folder and run again; if it stays, "
                      "gather_store wrote "
                      "outside the slot it calibrated",
                      part, kSwapSlot, a, a / 1024, stock[a], swapped.at(a), kSwapSlot));
  }
  if (std::equal(stock.begin() + lo, stock.begin() + hi, swapped.begin() + lo))
    throw std::runtime_error(
        fmt::format("calibrating {} left slot {} as it was: the store did not happen", part, kSwapSlot));
}

// The calibration folder held by one `sim swap` at a time: a second one on the same --out-dir
// (two terminals, two tests, a script run twice) waits for the first and then finds its results
// in the cache, instead of gathering into the files the first is writing or reading. An
// advisory flock(2), released by the kernel however the holder ends.
class FolderLock {
 public:
  FolderLock(const fs::path& dir, const ProgressFn& progress) {
    const fs::path path = dir / ".lock";
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0)
      throw std::runtime_error(fmt::format("{}: cannot create the lock file; check --out-dir", path.string()));
    if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return;
    progress(fmt::format("calibrations: waiting for another sim swap using {}", dir.string()));
    if (::flock(fd_, LOCK_EX) != 0) {
      ::close(fd_);
      throw std::runtime_error(fmt::format("{}: cannot lock the calibration folder", path.string()));
    }
  }
  ~FolderLock() { ::close(fd_); }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace

// The stock image and sweeps, then each part into slot 1 of a copy of it.
Calibration calibrate(const SwapOptions& o) {
  const fs::path dir = fs::path(o.out_dir) / "calibration";
  const fs::path sweeps = dir / "stock_sweeps";
  fs::create_directories(sweeps);
  const ProgressFn progress = o.progress ? o.progress : ProgressFn(stderrProgress);
  const FolderLock lock(dir, progress);
  const std::string digest = fileDigest(o.gather_elf);
  Calibration c;
  GatherOptions g = gatherBase(o);
  g.preset = o.stock_preset;
  g.seeds.assign(o.stock_seeds.begin(), o.stock_seeds.end());
  g.slots = {0, 1, 2, 3};
  g.log_dir = sweeps.string();
  for (int s = 0; s < 4; ++s)
    for (int k = 1; k <= 2; ++k)
      c.stock_sweeps.push_back((sweeps / fmt::format("gather_slot{}_curve{}.csv", s, k)).string());
  nlohmann::json stock_key = cacheKey(o, digest, nullptr);
  const bool sweeps_there = std::all_of(c.stock_sweeps.begin(), c.stock_sweeps.end(),
                                        [](const std::string& p) { return fs::exists(p); });
  if (!sweeps_there) fs::remove(dir / "stock.key.json");
  c.parts.push_back(gatherCached(kStock, stock_key, g, dir, progress));
  for (const std::string& name : o.parts) {
    const Part& part = findPart(name);
    GatherOptions gp = gatherBase(o);
    gp.preset = part.preset;
    gp.seeds = {part.seed};
    gp.slots = {kSwapSlot};
    gp.eeprom = c.parts.front().eeprom;
    gp.adjust_bench = [&part, &o](plant::BenchParams& b) { mountOnBench(part, o.stock_preset, b); };
    nlohmann::json key = cacheKey(o, digest, &part);
    key["stock"] = stock_key;
    PartCalibration pc = gatherCached(name, key, gp, dir, progress);
    checkOtherSlots(c.parts.front().eeprom, pc.eeprom, name);
    c.parts.push_back(std::move(pc));
  }
  c.modes = modeSettings(o, c.stock_sweeps);
  if (std::find(o.modes.begin(), o.modes.end(), Mode::kForceDyn) != o.modes.end()) addDynamics(o, c, progress);
  return c;
}

// ---------------------------------------------------------------------------------------------
// force+dyn: the records with each motor's dynamics

namespace {

plant::ActuatorParams motorInSlot(const SwapOptions& o, const std::string& part, int slot) {
  if (part != kStock && slot == kSwapSlot) return actuatorOf(findPart(part), o.variation);
  return actuatorOf({kStock, o.stock_preset, o.stock_seeds[static_cast<std::size_t>(slot)], 1.0, ""}, o.variation);
}

// gather_store's `dyn` on each of `slots` of `image` in turn (the first session also identifies
// the bench's load cell, `dyn cell`, unless the board settings hold it), cached by what made it.
std::vector<uint8_t> gatherDynamics(const SwapOptions& o, const std::string& part, std::vector<uint8_t> image,
                                    const std::vector<int>& slots, const ProgressFn& progress) {
  const fs::path dir = fs::path(o.out_dir) / "calibration";
  const fs::path hex_path = dir / (part + ".dyn.hex"), key_path = dir / (part + ".dyn.key.json");
  const nlohmann::json key = {{"gather_store", fileDigest(o.gather_elf)}, {"from_image", bytesDigest(image)},
                              {"slots", slots}, {"part", part}};
  if (fs::exists(hex_path) && fs::exists(key_path) && readText(key_path) == key.dump(2) + "\n") {
    try {
      std::vector<uint8_t> cached = hex::readIntelHexFile(hex_path.string(), kEepromBytes);
      progress(fmt::format("dynamics of {}: cached ({})", part, hex_path.string()));
      return cached;
    } catch (const std::exception&) {
      // a damaged image is measured again
    }
  }
  for (int slot : slots) {
    DynSessionOptions d;
    d.elf_path = o.gather_elf;
    d.motor = motorInSlot(o, part, slot);
    d.slot = slot;
    d.eeprom = image;
    d.calibrate = false;  // the slot holds the swap's model
    d.noise_seed = static_cast<uint64_t>(slot) + 1;
    d.progress = [](const std::string&) {};
    d.log_path = (dir / fmt::format("{}_slot{}.dyn.log", part, slot)).string();  // dyn's step log
    progress(fmt::format("dynamics of {}: gather_store's dyn on slot {} (about 35 s simulated)", part, slot));
    const DynSessionResult r = runDynSession(d);
    if (!r.dynamics.isPresent())
      throw std::runtime_error(fmt::format("dynamics of {}: gather_store's dyn stored none in slot {}:\n{}", part,
                                           slot, fmt::join(r.summary, "\n")));
    image = r.eeprom;
  }
  hex::writeIntelHexFile(hex_path.string() + ".new", image);
  fs::rename(hex_path.string() + ".new", hex_path);
  writeAtomically(key_path, key.dump(2) + "\n");
  return image;
}

}  // namespace

// Stock: every slot measured; a part: the stock image with dynamics, its slot 1 replaced by the
// part's calibration and measured again (what a user does after the swap).
void addDynamics(const SwapOptions& o, Calibration& c, const ProgressFn& progress) {
  if (o.dyn_from != "gather" && o.dyn_from != "plant")
    throw std::invalid_argument(fmt::format("--dyn-from {}: use gather (gather_store's dyn) or plant", o.dyn_from));
  const std::size_t lo = static_cast<std::size_t>(kSwapSlot) * 1024, hi = lo + 1024;
  for (PartCalibration& p : c.parts) {
    const bool stock = p.part == kStock;
    std::vector<uint8_t> image = stock ? p.eeprom : c.parts.front().eeprom_dyn;
    if (!stock) std::copy(p.eeprom.begin() + lo, p.eeprom.begin() + hi, image.begin() + lo);
    const std::vector<int> slots = stock ? std::vector<int>{0, 1, 2, 3} : std::vector<int>{kSwapSlot};
    if (o.dyn_from == "plant") {
      for (int slot : slots)
        if (!storePlantDynamics(image, slot, motorInSlot(o, p.part, slot)))
          throw std::runtime_error(fmt::format("force+dyn: slot {} of {} holds no model v2 to add dynamics to; "
                                               "force+dyn needs --model v2",
                                               slot, p.part));
    } else {
      image = gatherDynamics(o, p.part, image, slots, progress);
    }
    p.eeprom_dyn = image;
    for (int slot = 0; slot < 4; ++slot) p.dynamics[static_cast<std::size_t>(slot)] = storedDynamics(image, slot);
  }
}

}  // namespace sim::swap
