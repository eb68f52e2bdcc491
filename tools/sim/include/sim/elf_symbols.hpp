// Symbols of an AVR ELF image (libelf), for fault injection and probes in the HIL tests and
// benchmarks: where a function starts in flash, how large it is.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace sim {

struct ElfSymbol {
  uint32_t address = 0;  // flash byte address (functions) or data address
  uint32_t size = 0;
};

// The symbol whose demangled name is `name` (e.g. "rr::ReadRunApp::runOnce()"), or whose raw
// name is. Throws std::runtime_error naming the file and symbol when there is none.
ElfSymbol elfSymbol(const std::string& elf_path, const std::string& name);

// Every named symbol in flash (functions, and the labels of assembly without a type, such as
// avr-libc's float routines), demangled, in address order: what a program address belongs to.
struct FlashSymbol {
  std::string name;
  uint32_t address = 0;  // bytes
  uint32_t size = 0;     // 0: unknown (a label)
  bool function = false;
};
std::vector<FlashSymbol> flashSymbols(const std::string& elf_path);
// The symbol an address belongs to: the function whose extent holds it, else the label or
// function starting last at or before it; "?" before the first.
std::string symbolAt(const std::vector<FlashSymbol>& symbols, uint32_t byte_address);

}  // namespace sim
