#include "sim/elf_symbols.hpp"

#include <cxxabi.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <gelf.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <functional>
#include <memory>
#include <stdexcept>

namespace sim {

namespace {
std::string demangle(const char* raw) {
  int status = 0;
  std::unique_ptr<char, void (*)(void*)> d(abi::__cxa_demangle(raw, nullptr, nullptr, &status), std::free);
  return status == 0 && d ? std::string(d.get()) : std::string(raw);
}

// Calls `each(raw name, symbol)` for every named symbol of the image's symbol table until it
// returns false.
void forEachSymbol(const std::string& elf_path,
                   const std::function<bool(const char*, const GElf_Sym&)>& each) {
  if (elf_version(EV_CURRENT) == EV_NONE) throw std::runtime_error("libelf is too old");
  const int fd = ::open(elf_path.c_str(), O_RDONLY);
  if (fd < 0) throw std::runtime_error(fmt::format("{}: cannot open (build the AVR tree first)", elf_path));
  Elf* elf = elf_begin(fd, ELF_C_READ, nullptr);
  bool more = true;
  for (Elf_Scn* scn = nullptr; elf && more && (scn = elf_nextscn(elf, scn)) != nullptr;) {
    GElf_Shdr sh;
    if (!gelf_getshdr(scn, &sh) || sh.sh_type != SHT_SYMTAB) continue;
    Elf_Data* data = elf_getdata(scn, nullptr);
    const std::size_t n = sh.sh_entsize ? sh.sh_size / sh.sh_entsize : 0;
    for (std::size_t i = 0; data && more && i < n; ++i) {
      GElf_Sym sym;
      if (!gelf_getsym(data, static_cast<int>(i), &sym)) continue;
      const char* raw = elf_strptr(elf, sh.sh_link, sym.st_name);
      if (raw && *raw) more = each(raw, sym);
    }
  }
  if (elf) elf_end(elf);
  ::close(fd);
}

constexpr uint32_t kDataSpace = 0x800000;  // avr-gcc's SRAM addresses in the ELF
}  // namespace

ElfSymbol elfSymbol(const std::string& elf_path, const std::string& name) {
  ElfSymbol found;
  bool ok = false;
  forEachSymbol(elf_path, [&](const char* raw, const GElf_Sym& sym) {
    if (name != raw && name != demangle(raw)) return true;
    found.address = static_cast<uint32_t>(sym.st_value);
    found.size = static_cast<uint32_t>(sym.st_size);
    ok = true;
    return false;
  });
  if (!ok) throw std::runtime_error(fmt::format("{}: no symbol {}", elf_path, name));
  return found;
}

std::vector<FlashSymbol> flashSymbols(const std::string& elf_path) {
  std::vector<FlashSymbol> out;
  forEachSymbol(elf_path, [&](const char* raw, const GElf_Sym& sym) {
    const int type = GELF_ST_TYPE(sym.st_info);
    const bool in_flash =
        sym.st_shndx != SHN_UNDEF && sym.st_shndx < SHN_LORESERVE && sym.st_value < kDataSpace;
    if (in_flash && (type == STT_FUNC || type == STT_NOTYPE))
      out.push_back({demangle(raw), static_cast<uint32_t>(sym.st_value), static_cast<uint32_t>(sym.st_size),
                     type == STT_FUNC});
    return true;
  });
  std::sort(out.begin(), out.end(), [](const FlashSymbol& a, const FlashSymbol& b) {
    return a.address != b.address ? a.address < b.address : a.function > b.function;
  });
  return out;
}

std::string symbolAt(const std::vector<FlashSymbol>& symbols, uint32_t byte_address) {
  const auto after = std::upper_bound(symbols.begin(), symbols.end(), byte_address,
                                      [](uint32_t a, const FlashSymbol& s) { return a < s.address; });
  for (auto it = after; it != symbols.begin();) {  // the innermost function holding it
    --it;
    if (it->function && byte_address < it->address + it->size) return it->name;
    if (byte_address - it->address > 0x10000) break;  // no function reaches that far
  }
  return after == symbols.begin() ? std::string("?") : std::prev(after)->name;
}

}  // namespace sim
