// Shared by the `thrustcal sim` commands' sources (internal): writing a JSON result and turning
// an exception into a message and exit code 1.
#pragma once
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "hex/intel_hex.hpp"
#include "sim/board.hpp"

namespace sim {

inline void writeJson(const std::string& path, const nlohmann::json& j) {
  if (path.empty()) return;
  if (std::filesystem::path(path).has_parent_path()) std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw std::runtime_error(fmt::format("{}: cannot write the JSON result", path));
  out << j.dump(2) << "\n";
}

// An EEPROM image from an Intel HEX file; erased (all 0xFF) when `path` is empty, or when it does
// not exist and need not.
inline std::vector<uint8_t> loadEepromOrErased(const std::string& path, bool must_exist) {
  if (path.empty() || (!must_exist && !std::filesystem::exists(path)))
    return std::vector<uint8_t>(kEepromBytes, 0xFF);
  return hex::readIntelHexFile(path, kEepromBytes);
}

// Runs `body`, turning any exception into a message on stderr ("thrustcal sim COMMAND: error:
// ...", or "thrustcal sim: error: ..." without a command) and exit code 1.
template <class F>
void guarded(const char* command, F&& body) {
  try {
    body();
  } catch (const std::exception& e) {
    fmt::print(stderr, "thrustcal sim{}{}: error: {}\n", *command ? " " : "", command, e.what());
    std::exit(1);
  }
}
template <class F>
void guarded(F&& body) {
  guarded("", std::forward<F>(body));
}

}  // namespace sim
