#include "hex/intel_hex.hpp"

#include <fmt/format.h>

#include <fstream>
#include <sstream>

namespace hex {
namespace {

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

}  // namespace

std::vector<uint8_t> parseIntelHex(const std::string& text, std::size_t size_bytes,
                                   const std::string& origin, uint8_t fill) {
  std::vector<uint8_t> image(size_bytes, fill);
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  uint32_t base = 0;  // from type 02 (segment) or 04 (linear) records
  bool saw_eof = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    auto fail = [&](const std::string& what) {
      return HexError(fmt::format("{}:{}: {}; expected Intel HEX records like "
                                  "':10000000FFFF...FF00' (avrdude writes them with "
                                  "-U eeprom:r:FILE:i or -U flash:r:FILE:i, thrustcal sim an "
                                  "EEPROM's)",
                                  origin, line_no, what));
    };
    if (saw_eof) throw fail("data after the end-of-file record");
    if (line[0] != ':') throw fail("record does not start with ':'");
    if ((line.size() - 1) % 2 != 0 || line.size() < 11)
      throw fail(fmt::format("record has {} hex digits, need an even count of at least 10",
                             line.size() - 1));
    std::vector<uint8_t> bytes;
    for (std::size_t i = 1; i < line.size(); i += 2) {
      int hi = hexDigit(line[i]), lo = hexDigit(line[i + 1]);
      if (hi < 0 || lo < 0)
        throw fail(fmt::format("column {}: '{}{}' is not a hex byte", i + 1, line[i], line[i + 1]));
      bytes.push_back(static_cast<uint8_t>(hi * 16 + lo));
    }
    const uint8_t count = bytes[0];
    if (bytes.size() != static_cast<std::size_t>(count) + 5)
      throw fail(fmt::format("length byte says {} data bytes, the record holds {}", count,
                             bytes.size() - 5));
    uint8_t sum = 0;
    for (uint8_t b : bytes) sum = static_cast<uint8_t>(sum + b);
    if (sum != 0) {
      uint8_t partial = static_cast<uint8_t>(sum - bytes.back());
      throw fail(fmt::format("checksum {:02X} is wrong, the record needs {:02X}", bytes.back(),
                             static_cast<uint8_t>(-partial)));
    }
    const uint16_t offset = static_cast<uint16_t>(bytes[1] << 8 | bytes[2]);
    const uint8_t type = bytes[3];
    const uint8_t* data = bytes.data() + 4;
    switch (type) {
      case 0x00: {
        // 64-bit: an extended address FFFF plus an offset near FFFF would wrap 32 bits.
        const uint64_t addr = static_cast<uint64_t>(base) + offset;
        if (addr + count > size_bytes)
          throw fail(fmt::format("data at 0x{:04X}..0x{:04X} lies beyond the {}-byte image", addr,
                                 addr + count - (count ? 1 : 0), size_bytes));
        for (uint8_t i = 0; i < count; ++i) image[addr + i] = data[i];
        break;
      }
      case 0x01:
        saw_eof = true;
        break;
      case 0x02:
        if (count != 2) throw fail("extended segment address record needs 2 data bytes");
        base = static_cast<uint32_t>(data[0] << 8 | data[1]) << 4;
        break;
      case 0x04:
        if (count != 2) throw fail("extended linear address record needs 2 data bytes");
        base = static_cast<uint32_t>(data[0] << 8 | data[1]) << 16;
        break;
      case 0x03:
      case 0x05:
        break;  // start addresses: meaningless for an EEPROM image
      default:
        throw fail(fmt::format("unknown record type {:02X}", type));
    }
  }
  if (!saw_eof)
    throw HexError(fmt::format("{}: no end-of-file record (:00000001FF); the file is truncated",
                               origin));
  return image;
}

std::string formatIntelHex(const std::vector<uint8_t>& image) {
  std::string out;
  uint32_t upper = 0;
  for (std::size_t addr = 0; addr < image.size(); addr += 16) {
    if ((addr >> 16) != upper) {
      upper = static_cast<uint32_t>(addr >> 16);
      uint8_t sum = static_cast<uint8_t>(2 + 0 + 0 + 4 + (upper >> 8) + (upper & 0xFF));
      out += fmt::format(":02000004{:04X}{:02X}\n", upper, static_cast<uint8_t>(-sum));
    }
    const std::size_t n = std::min<std::size_t>(16, image.size() - addr);
    uint8_t sum = static_cast<uint8_t>(n + ((addr >> 8) & 0xFF) + (addr & 0xFF));
    std::string rec = fmt::format(":{:02X}{:04X}00", n, addr & 0xFFFF);
    for (std::size_t i = 0; i < n; ++i) {
      rec += fmt::format("{:02X}", image[addr + i]);
      sum = static_cast<uint8_t>(sum + image[addr + i]);
    }
    out += rec + fmt::format("{:02X}\n", static_cast<uint8_t>(-sum));
  }
  out += ":00000001FF\n";
  return out;
}

std::vector<uint8_t> readIntelHexFile(const std::string& path, std::size_t size_bytes,
                                      uint8_t fill) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw HexError(fmt::format("{}: cannot open the EEPROM image; check the path (an erased "
                               "board needs no file: leave --eeprom out or point it at a new "
                               "file to be written)",
                               path));
  std::ostringstream text;
  text << in.rdbuf();
  return parseIntelHex(text.str(), size_bytes, path, fill);
}

void writeIntelHexFile(const std::string& path, const std::vector<uint8_t>& image) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw HexError(fmt::format("{}: cannot write the EEPROM image; check the directory", path));
  out << formatIntelHex(image);
  if (!out.flush()) throw HexError(fmt::format("{}: write failed (disk full?)", path));
}

}  // namespace hex
