// Intel HEX reading and writing for AVR images (EEPROM, and the flash images the simulator
// loads), in the dialect avrdude reads and writes (`avrdude -U eeprom:w:FILE:i` /
// `-U eeprom:r:FILE:i`): 16 data bytes per record (type 00), an extended linear address record
// (type 04) only when an image passes 64 KiB, and the end-of-file record (type 01). Every
// record carries its two's-complement checksum. Its own library (thrustcal_hex) so that the
// simulator, the board client and the lab share it without depending on each other.
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace hex {

// Thrown for unreadable or malformed HEX input; what() names the file and line and says what
// was wrong and what to do.
class HexError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses Intel HEX text into an image of `size_bytes` bytes; bytes the file does not mention
// hold `fill` (0xFF: an erased AVR EEPROM). Accepts record types 00, 01, 02, 03, 04, 05;
// LF or CRLF line ends; blank lines. Throws HexError on a bad character, a short record, a
// wrong checksum, data beyond `size_bytes`, or a missing end-of-file record. `origin` names
// the input in messages (a file name).
std::vector<uint8_t> parseIntelHex(const std::string& text, std::size_t size_bytes,
                                   const std::string& origin = "<hex>", uint8_t fill = 0xFF);

// Serializes the whole `image` as Intel HEX text (16 bytes per record, uppercase hex, "\n"
// line ends), erased bytes included, so writing it back restores every byte.
std::string formatIntelHex(const std::vector<uint8_t>& image);

// File helpers around the two above. readIntelHexFile throws HexError if the file cannot be
// opened; writeIntelHexFile throws HexError if it cannot be written.
std::vector<uint8_t> readIntelHexFile(const std::string& path, std::size_t size_bytes,
                                      uint8_t fill = 0xFF);
void writeIntelHexFile(const std::string& path, const std::vector<uint8_t>& image);

}  // namespace hex
