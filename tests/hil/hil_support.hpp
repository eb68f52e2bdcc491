// Shared pieces of the HIL tests: where the real images are, and one calibrated EEPROM image
// (four varied motors gathered with the real gather_store) cached per gather_store build.
#pragma once
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "sim/board.hpp"
#include "hex/intel_hex.hpp"
#include "sim/scenarios.hpp"

namespace hil {

namespace fs = std::filesystem;

// <avr build>/firmware/<name>/<name>.elf (CMake's layout), or <avr build>/firmware/<name>.elf.
// The environment variable THRUSTCAL_AVR_BUILD_DIR, when set, overrides the configured tree
// (e.g. to run the tests against another commit's images).
inline std::string imagePath(const std::string& name) {
  const char* env = std::getenv("THRUSTCAL_AVR_BUILD_DIR");
  const fs::path dir = fs::path(env && *env ? env : THRUSTCAL_AVR_BUILD_DIR) / "firmware";
  const fs::path flat = dir / (name + ".elf");
  const fs::path nested = dir / name / (name + ".elf");
  return (fs::exists(nested) || !fs::exists(flat) ? nested : flat).string();
}

// GTEST_SKIP()s the calling test when an image is missing (the lead's test script builds them).
#define HIL_REQUIRE_IMAGE(name)                                                                   \
  do {                                                                                            \
    if (!std::filesystem::exists(hil::imagePath(name)))                                           \
      GTEST_SKIP() << "no AVR image " << hil::imagePath(name)                                     \
                   << ": build the AVR tree first (tools/test.sh does; or cmake --preset avr && " \
                      "cmake --build build/avr), or set THRUSTCAL_AVR_BUILD_DIR";                 \
  } while (0)

// The four motors of the HIL fleet (seeds) and the calibration settings used for them.
constexpr std::array<uint64_t, 4> kFleetSeeds = {11, 12, 13, 14};

inline sim::GatherOptions fleetGatherOptions() {
  sim::GatherOptions o;
  o.elf_path = imagePath("gather_store");
  o.seeds.assign(kFleetSeeds.begin(), kFleetSeeds.end());
  o.slots = {0, 1, 2, 3};
  // sweep 1040..1800 us in 10 us steps, 500 ms settling: the scenario defaults (see
  // sim::GatherOptions for why they differ from gather_store's own 1000..1800 / 200 ms)
  o.progress = [](const std::string&) {};
  return o;
}

inline uint64_t fileHash(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return std::hash<std::string>{}(s.str());
}

// This test binary's identity: its size and modification time (every link writes a new file).
// Not its content: reading and hashing tens of MB took 0.3-0.4 s in every test process.
inline uint64_t selfStamp() {
  const fs::path self = fs::read_symlink("/proc/self/exe");
  const auto when = fs::last_write_time(self).time_since_epoch().count();
  return static_cast<uint64_t>(when) * 1000003u + static_cast<uint64_t>(fs::file_size(self));
}

// EEPROM with all four fleet motors calibrated by the real gather_store. Gathered once and
// cached next to the test binary (ctest runs each test in its own process), keyed by the
// gather_store image and this test binary (which holds the plant and the scenario settings; a
// relink counts as a change): a change to either, or a damaged cache file, means a fresh gather.
inline std::vector<uint8_t> fleetEeprom() {
  const std::string elf = imagePath("gather_store");
  const uint64_t key = fileHash(elf) * 31 + selfStamp();
  const fs::path cache = fs::path(HIL_CACHE_DIR) /
                         ("thrustcal_hil_fleet_" + std::to_string(key) + ".hex");
  if (fs::exists(cache)) {
    try {
      return hex::readIntelHexFile(cache.string(), sim::kEepromBytes);
    } catch (const hex::HexError&) {
    }
  }
  const sim::GatherResult r = sim::runGather(fleetGatherOptions());
  const fs::path tmp = cache.string() + "." + std::to_string(::getpid());
  hex::writeIntelHexFile(tmp.string(), r.eeprom);
  fs::rename(tmp, cache);
  return r.eeprom;
}

}  // namespace hil
