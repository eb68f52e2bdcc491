// Symbols of an AVR ELF image (libelf), for fault injection and probes in the HIL tests and
// benchmarks: where a function starts in flash, how large it is.
#pragma once
#include <cstdint>
#include <string>

namespace sim {

struct ElfSymbol {
  uint32_t address = 0;  // flash byte address (functions) or data address
  uint32_t size = 0;
};

// The symbol whose demangled name is `name` (e.g. "rr::ReadRunApp::runOnce()"), or whose raw
// name is. Throws std::runtime_error naming the file and symbol when there is none.
ElfSymbol elfSymbol(const std::string& elf_path, const std::string& name);

}  // namespace sim
