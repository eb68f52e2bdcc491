// Where this build's source tree is, and where its AVR images are looked for. Defined in one
// small translation unit (source_tree.cpp) that alone carries the path, so every other object
// compiles the same in any clone (a compiler cache shares them) and the tools' libraries keep
// their unity batches.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace thrustcal {

std::string sourceTree();  // absolute, no trailing slash

// The AVR build trees to look in, in order: $THRUSTCAL_AVR_BUILD_DIR when set, then
// <source tree>/build/avr (the last is the one an error should name when nothing is found).
std::vector<std::filesystem::path> avrBuildDirs();

}  // namespace thrustcal
