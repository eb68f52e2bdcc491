#include "sim/elf_symbols.hpp"

#include <cxxabi.h>
#include <fcntl.h>
#include <gelf.h>
#include <unistd.h>

#include <cstdlib>
#include <memory>
#include <stdexcept>

#include <fmt/format.h>

namespace sim {

namespace {
std::string demangle(const char* raw) {
  int status = 0;
  std::unique_ptr<char, void (*)(void*)> d(abi::__cxa_demangle(raw, nullptr, nullptr, &status),
                                           std::free);
  return status == 0 && d ? std::string(d.get()) : std::string(raw);
}
}  // namespace

ElfSymbol elfSymbol(const std::string& elf_path, const std::string& name) {
  if (elf_version(EV_CURRENT) == EV_NONE) throw std::runtime_error("libelf is too old");
  const int fd = ::open(elf_path.c_str(), O_RDONLY);
  if (fd < 0) throw std::runtime_error(fmt::format("{}: cannot open (build the AVR tree first)", elf_path));
  Elf* elf = elf_begin(fd, ELF_C_READ, nullptr);
  ElfSymbol found;
  bool ok = false;
  for (Elf_Scn* scn = nullptr; elf && !ok && (scn = elf_nextscn(elf, scn)) != nullptr;) {
    GElf_Shdr sh;
    if (!gelf_getshdr(scn, &sh) || sh.sh_type != SHT_SYMTAB) continue;
    Elf_Data* data = elf_getdata(scn, nullptr);
    const std::size_t n = sh.sh_entsize ? sh.sh_size / sh.sh_entsize : 0;
    for (std::size_t i = 0; data && i < n; ++i) {
      GElf_Sym sym;
      if (!gelf_getsym(data, static_cast<int>(i), &sym)) continue;
      const char* raw = elf_strptr(elf, sh.sh_link, sym.st_name);
      if (!raw || !*raw) continue;
      if (name == raw || name == demangle(raw)) {
        found.address = static_cast<uint32_t>(sym.st_value);
        found.size = static_cast<uint32_t>(sym.st_size);
        ok = true;
        break;
      }
    }
  }
  if (elf) elf_end(elf);
  ::close(fd);
  if (!ok) throw std::runtime_error(fmt::format("{}: no symbol {}", elf_path, name));
  return found;
}

}  // namespace sim
