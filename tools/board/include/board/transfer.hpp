// Flash and EEPROM of a Mega2560 with its stock STK500v2 bootloader, done so they work:
//
//   flash:       avrdude -p m2560 -c wiring -b 115200 -D -U flash:w:IMAGE:i (its own verify
//                works), then the port is opened again and the image must answer with its prompt.
//   eeprom put:  the image is made whole (4096 bytes; a partial file is completed with what the
//                board holds now, read through the firmware), written by avrdude WITHOUT its
//                verify (-V: the bootloader's EEPROM read is broken, arduino/ArduinoCore-avr
//                issue 129, so avrdude's verify fails on every stock board, and a partial image
//                would be merged with wrongly read bytes), then verified through the running
//                firmware's `eeprom crc` (per slot and whole).
//   eeprom get:  the firmware's `eeprom dump` (Intel HEX records on the console), checked
//                against its `eeprom crc`; never through the bootloader.
// The board must run gather_store, read_run or fly for the EEPROM operations (it checks, and says
// so).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "board/avrdude.hpp"
#include "board/console_client.hpp"
#include "hal/board.hpp"

namespace board {

using hal::kEepromBytes;  // the board table (hal/board.hpp)
constexpr std::size_t kSlotBytes = 1024;
constexpr uint32_t kBootSectionStart = 0x3E000;  // the Mega2560's 8 KiB boot section
constexpr double kBootTimeoutS = 10.0;  // bootloader wait (~1 s) + banner; read_run arms 2 s

using Progress = std::function<void(const std::string&)>;

// CRC-16/CCITT-FALSE of each 1024-byte slot and of all 4096 bytes (as `eeprom crc` prints).
struct EepromCrcs {
  std::array<uint16_t, 4> slot{};
  uint16_t all = 0;
  static EepromCrcs of(const std::vector<uint8_t>& image);
  // Parses "eeprom crc slot0 XXXX slot1 XXXX slot2 XXXX slot3 XXXX all XXXX"; false otherwise.
  static bool parse(const std::string& line, EepromCrcs& out);
  std::string text() const;  // the same line
  bool operator==(const EepromCrcs& o) const { return slot == o.slot && all == o.all; }
  bool operator!=(const EepromCrcs& o) const { return !(*this == o); }
};

// An EEPROM Intel HEX file: its bytes (0xFF where it says nothing) and which bytes it gives.
struct EepromFile {
  std::vector<uint8_t> bytes;
  std::vector<bool> given;
  std::size_t givenCount() const;
};
// Throws std::runtime_error (hex::HexError) naming the file and line for a bad file.
EepromFile readEepromFile(const std::string& path);

// --- through the running firmware (a ConsoleClient after waitForBoot) ---
EepromCrcs boardEepromCrc(ConsoleClient& con);
// `eeprom dump`, parsed, checked whole and against `eeprom crc`. Throws std::runtime_error.
std::vector<uint8_t> boardEepromDump(ConsoleClient& con);

// --- the operations ---
struct TransferOptions {
  double avrdude_timeout_s = 180.0;   // a 40 KB image takes ~15 s on a real board
  double boot_timeout_s = kBootTimeoutS;
  bool check_prompt = true;           // flash: wait for the image's prompt afterwards
  Progress progress;                  // one line per step
};

// --- writing through the bootloader (-V), verifying through the firmware ---
// Runs avrdude on `hex_text`; throws AvrdudeError naming `source` and the `what` to run again.
AvrdudeRun writeEepromHex(const std::string& port, const std::string& hex_text, const std::string& source,
                          const std::string& what, const TransferOptions& o);
struct Verified {
  EepromCrcs crcs;
  Image image = Image::kUnknown;
  std::vector<std::string> boot;
  double wall_s = 0;
};
// Opens the port (a reset), waits for the firmware and compares its CRCs with `want`'s;
// throws std::runtime_error naming the slots that differ.
Verified verifyEeprom(const std::string& port, const std::vector<uint8_t>& want, const std::string& what,
                      const TransferOptions& o);

struct FlashResult {
  AvrdudeRun avrdude;
  std::size_t image_bytes = 0;
  Image image = Image::kUnknown;  // what answered after the flash (kUnknown: not checked)
  double check_wall_s = 0;
};
// Throws AvrdudeError (missing, failed, verify error, time-out), PortError, BoardTimeout.
FlashResult flashImage(const std::string& port, const std::string& hex_path,
                       const TransferOptions& o = {});

struct EepromPutResult {
  std::size_t given_bytes = 0;  // bytes the file gave (the rest came from the board)
  bool written = false;         // false: the board already held the image
  AvrdudeRun avrdude;
  EepromCrcs crcs;              // verified on the board
  Image image = Image::kUnknown;
  double wall_s = 0, prepare_wall_s = 0, verify_wall_s = 0;
};
// Throws AvrdudeError, PortError, BoardTimeout (no firmware answers: nothing is written),
// std::runtime_error (a bad file; the verify failed, naming the slots).
EepromPutResult putEeprom(const std::string& port, const std::string& hex_path,
                          const TransferOptions& o = {});

struct EepromRangeResult {
  AvrdudeRun avrdude;
  EepromCrcs crcs;                // verified on the board
  Image image = Image::kUnknown;  // what answered after the write
  std::vector<std::string> boot;  // what it printed booting (fly: its "params: ..." line)
  double wall_s = 0;
};
// Writes only bytes [first, first + count) of `image` (whole 16-byte records: whole EEPROM
// pages, so avrdude merges nothing read through the broken bootloader read) and verifies the
// whole EEPROM through the firmware against `image` (the 4096 bytes the board should now hold).
// `what` names the command in messages. Throws as putEeprom.
EepromRangeResult putEepromRange(const std::string& port, const std::vector<uint8_t>& image, std::size_t first,
                                 std::size_t count, const std::string& what, const TransferOptions& o = {});

struct EepromGetResult {
  std::vector<uint8_t> bytes;
  EepromCrcs crcs;
  Image image = Image::kUnknown;
  double wall_s = 0, dump_wall_s = 0;
};
EepromGetResult getEeprom(const std::string& port, const TransferOptions& o = {});

}  // namespace board
