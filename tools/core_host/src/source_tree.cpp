#include "thrustcal/source_tree.hpp"

#include <cstdlib>

namespace thrustcal {

std::string sourceTree() { return THRUSTCAL_SOURCE_DIR; }

std::vector<std::filesystem::path> avrBuildDirs() {
  std::vector<std::filesystem::path> dirs;
  if (const char* env = std::getenv("THRUSTCAL_AVR_BUILD_DIR")) dirs.emplace_back(env);
  dirs.emplace_back((std::filesystem::path(sourceTree()) / "build" / "avr").lexically_normal());
  return dirs;
}

}  // namespace thrustcal
