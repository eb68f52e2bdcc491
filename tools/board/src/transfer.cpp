#include "board/transfer.hpp"
#include "elapsed.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <fmt/format.h>

#include "hex/intel_hex.hpp"
#include "thrustcal/crc16.hpp"

namespace board {
namespace {

using Clock = std::chrono::steady_clock;
void say(const Progress& p, const std::string& line) {
  if (p) p(line);
}

std::string readText(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot read the {}; check the path", path, what));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Parses Intel HEX twice with different fills: a byte the text gives reads the same both times.
std::vector<bool> givenBytes(const std::string& text, std::size_t size, const std::string& origin,
                             std::vector<uint8_t>& bytes) {
  bytes = hex::parseIntelHex(text, size, origin, 0xFF);
  const std::vector<uint8_t> zero = hex::parseIntelHex(text, size, origin, 0x00);
  std::vector<bool> given(size);
  for (std::size_t i = 0; i < size; ++i) given[i] = bytes[i] == zero[i];
  return given;
}

// Opens the port (a reset) and waits for gather_store, read_run or fly; `why` says what the board
// must answer for.
std::unique_ptr<SerialPort> openBooted(const std::string& port, const char* why,
                                       std::unique_ptr<ConsoleClient>& con, double timeout_s) {
  auto sp = std::make_unique<SerialPort>(port);
  con = std::make_unique<ConsoleClient>(*sp);
  try {
    con->waitForBoot(timeout_s);
  } catch (const BoardTimeout& e) {
    throw BoardTimeout(fmt::format("{}\n{} needs gather_store, read_run or fly running on the "
                                   "board (they answer `eeprom crc` and `eeprom dump`)",
                                   e.what(), why));
  }
  return sp;
}

std::string slotsDiffering(const EepromCrcs& want, const EepromCrcs& got) {
  std::string out;
  for (int s = 0; s < 4; ++s)
    if (want.slot[s] != got.slot[s])
      out += fmt::format("{}slot {} (bytes {}..{})", out.empty() ? "" : ", ", s, s * 1024,
                         s * 1024 + 1023);
  return out;
}

std::string avrdudeDiagnosis(const AvrdudeRun& run, const std::string& port, double timeout_s) {
  if (run.timed_out)
    return fmt::format("avrdude did not finish within {:.0f} s and was stopped", timeout_s);
  const std::string& o = run.output;
  auto has = [&](const char* s) { return o.find(s) != std::string::npos; };
  if (has("verification") || has("mismatch") || has("differ"))
    return "avrdude's verify failed: the flash does not hold what was written";
  if (has("not in sync") || has("not responding") || has("timeout") || has("getsync"))
    return fmt::format("the bootloader on {} did not answer (is it a Mega2560 with its stock "
                       "STK500v2 bootloader? press its reset button if its firmware disabled "
                       "the auto-reset)",
                       port);
  if (has("can't open device") || has("cannot open"))
    return fmt::format("avrdude could not open {}", port);
  return fmt::format("avrdude failed (exit code {})", run.exit_code);
}

}  // namespace

// ---- writing through the bootloader, verifying through the firmware -------------------------

AvrdudeRun writeEepromHex(const std::string& port, const std::string& hex_text, const std::string& source,
                          const std::string& what, const TransferOptions& o) {
  char tmpl[] = "/tmp/thrustcal_eeprom_XXXXXX";
  const int fd = ::mkstemp(tmpl);
  if (fd < 0) throw std::runtime_error("cannot make a temporary file in /tmp");
  ::close(fd);
  const std::string tmp = tmpl;
  struct Remove {
    std::string path;
    ~Remove() { std::remove(path.c_str()); }
  } remove{tmp};
  std::ofstream(tmp) << hex_text;
  auto args = avrdudeArgs(port);
  args.push_back("-V");  // avrdude's verify reads through the broken bootloader read
  args.push_back("-U");
  args.push_back("eeprom:w:" + tmp + ":i");
  const AvrdudeRun run = runAvrdude(args, o.avrdude_timeout_s);
  if (run.exit_code != 0 || run.timed_out)
    throw AvrdudeError(fmt::format("{}: {}; the EEPROM may be partly written: run `thrustcal board {}` again. "
                                   "avrdude said:\n{}",
                                   source, avrdudeDiagnosis(run, port, o.avrdude_timeout_s), what,
                                   lastLines(run.output)));
  return run;
}

Verified verifyEeprom(const std::string& port, const std::vector<uint8_t>& want, const std::string& what,
                      const TransferOptions& o) {
  const auto t0 = Clock::now();
  std::unique_ptr<ConsoleClient> con;
  std::vector<std::string> boot;
  auto sp = std::make_unique<SerialPort>(port);
  con = std::make_unique<ConsoleClient>(*sp);
  try {
    boot = con->waitForBoot(o.boot_timeout_s);
  } catch (const BoardTimeout& e) {
    throw BoardTimeout(fmt::format("{}\n{} (to verify what it wrote) needs gather_store, read_run or fly "
                                   "running on the board",
                                   e.what(), what));
  }
  Verified v;
  v.crcs = boardEepromCrc(*con);
  v.image = con->image();
  v.boot = boot;
  v.wall_s = secondsSince(t0);
  const EepromCrcs expect = EepromCrcs::of(want);
  if (v.crcs != expect)
    throw std::runtime_error(fmt::format(
        "{}: verify FAILED: the board's EEPROM differs in {} (board: {}; image: {}); write it "
        "again, and if it fails again the EEPROM or the bootloader is at fault",
        port, slotsDiffering(expect, v.crcs), v.crcs.text(), expect.text()));
  say(o.progress, fmt::format("verified through {}: {}", imageName(v.image), v.crcs.text()));
  return v;
}

// ---- CRCs and files ------------------------------------------------------------------------

EepromCrcs EepromCrcs::of(const std::vector<uint8_t>& image) {
  if (image.size() != kEepromBytes)
    throw std::invalid_argument(fmt::format("EEPROM image of {} bytes, need {}", image.size(),
                                            kEepromBytes));
  EepromCrcs c;
  for (int s = 0; s < 4; ++s)
    c.slot[s] = tc::crc16CcittFalse(image.data() + s * kSlotBytes, kSlotBytes);
  c.all = 0xFFFF;
  for (uint8_t b : image) c.all = tc::crc16Update(c.all, b);
  return c;
}

bool EepromCrcs::parse(const std::string& line, EepromCrcs& out) {
  unsigned v[5];
  char tail = 0;
  const int n = std::sscanf(line.c_str(),
                            "eeprom crc slot0 %4X slot1 %4X slot2 %4X slot3 %4X all %4X%c", &v[0],
                            &v[1], &v[2], &v[3], &v[4], &tail);
  if (n != 5) return false;
  for (int s = 0; s < 4; ++s) out.slot[s] = static_cast<uint16_t>(v[s]);
  out.all = static_cast<uint16_t>(v[4]);
  return true;
}

std::string EepromCrcs::text() const {
  return fmt::format("eeprom crc slot0 {:04X} slot1 {:04X} slot2 {:04X} slot3 {:04X} all {:04X}",
                     slot[0], slot[1], slot[2], slot[3], all);
}

std::size_t EepromFile::givenCount() const {
  std::size_t n = 0;
  for (bool g : given) n += g;
  return n;
}

EepromFile readEepromFile(const std::string& path) {
  EepromFile f;
  f.given = givenBytes(readText(path, "EEPROM image (Intel HEX)"), kEepromBytes, path, f.bytes);
  return f;
}

EepromCrcs boardEepromCrc(ConsoleClient& con) {
  const auto lines = con.mustCommand("eeprom crc", CommandLimits{5.0});
  EepromCrcs c;
  for (const auto& l : lines)
    if (EepromCrcs::parse(l, c)) return c;
  throw std::runtime_error(fmt::format(
      "{}: {} did not answer `eeprom crc` with its CRC line (an image from before the EEPROM "
      "commands? rebuild and flash it); it said:\n{}",
      con.port().path(), imageName(con.image()), con.tail()));
}

std::vector<uint8_t> boardEepromDump(ConsoleClient& con) {
  // 256 records of 44 characters: ~1 s at 115200 baud.
  const auto lines = con.mustCommand("eeprom dump", CommandLimits{20.0, 3.0});
  std::string text;
  std::size_t records = 0;
  for (const auto& l : lines)
    if (!l.empty() && l[0] == ':') {
      text += l + "\n";
      ++records;
    }
  const std::string origin = con.port().path() + " (eeprom dump)";
  std::vector<uint8_t> bytes;
  const std::vector<bool> given = givenBytes(text, kEepromBytes, origin, bytes);
  std::size_t missing = 0;
  for (bool g : given) missing += !g;
  if (missing > 0)
    throw std::runtime_error(fmt::format("{}: the dump left {} of {} bytes out ({} records came); "
                                         "the line may be noisy, try again",
                                         origin, missing, kEepromBytes, records));
  const EepromCrcs want = boardEepromCrc(con);
  const EepromCrcs got = EepromCrcs::of(bytes);
  if (want != got)
    throw std::runtime_error(fmt::format("{}: the dump does not match the board's own CRCs in {} "
                                         "(board: {}; dump: {}); try again",
                                         origin, slotsDiffering(want, got), want.text(), got.text()));
  return bytes;
}

// ---- flash ---------------------------------------------------------------------------------

FlashResult flashImage(const std::string& port, const std::string& hex_path,
                       const TransferOptions& o) {
  const double timeout_s = o.avrdude_timeout_s;
  const Progress& progress = o.progress;
  requirePort(port);
  findAvrdude();
  FlashResult r;
  std::vector<uint8_t> flash;
  const std::vector<bool> given =
      givenBytes(readText(hex_path, "flash image"), hal::kFlashBytes, hex_path, flash);
  uint32_t hi = 0;
  for (uint32_t a = 0; a < given.size(); ++a)
    if (given[a]) {
      ++r.image_bytes;
      hi = a + 1;
    }
  if (r.image_bytes == 0)
    throw std::runtime_error(fmt::format("{}: holds no data; pass the image's .hex (e.g. "
                                         "build/avr/firmware/read_run/read_run.hex)",
                                         hex_path));
  if (hi > kBootSectionStart)
    throw std::runtime_error(fmt::format(
        "{}: reaches byte 0x{:05X}, into the bootloader's section at 0x{:05X}; it would not fit "
        "beside the bootloader (and the bootloader refuses to overwrite itself)",
        hex_path, hi - 1, kBootSectionStart));
  auto args = avrdudeArgs(port);
  args.push_back("-U");
  args.push_back("flash:w:" + hex_path + ":i");
  say(progress, fmt::format("flashing {} ({} bytes) through the bootloader on {}", hex_path,
                            r.image_bytes, port));
  r.avrdude = runAvrdude(args, timeout_s);
  if (r.avrdude.exit_code != 0 || r.avrdude.timed_out)
    throw AvrdudeError(fmt::format("{}: {}; nothing is known to be on the board. avrdude said:\n{}",
                                   hex_path, avrdudeDiagnosis(r.avrdude, port, timeout_s),
                                   lastLines(r.avrdude.output)));
  say(progress, fmt::format("written and verified by avrdude in {:.1f} s", r.avrdude.wall_s));
  if (o.check_prompt) {
    const auto t0 = Clock::now();
    SerialPort sp(port);
    ConsoleClient con(sp);
    con.waitForBoot(o.boot_timeout_s);
    r.image = con.image();
    r.check_wall_s = secondsSince(t0);
    say(progress, fmt::format("{} answers ({}) {:.1f} s after the reset", imageName(r.image),
                              con.prompt(), r.check_wall_s));
  }
  return r;
}

// ---- EEPROM ----------------------------------------------------------------------------------

EepromPutResult putEeprom(const std::string& port, const std::string& hex_path,
                          const TransferOptions& o) {
  const Progress& progress = o.progress;
  const auto t0 = Clock::now();
  requirePort(port);
  findAvrdude();
  EepromPutResult r;
  EepromFile file = readEepromFile(hex_path);
  r.given_bytes = file.givenCount();
  std::vector<uint8_t> image = file.bytes;
  {
    std::unique_ptr<ConsoleClient> con;
    auto sp = openBooted(port, "eeprom put (to verify what it wrote)", con, o.boot_timeout_s);
    r.image = con->image();
    const EepromCrcs before = boardEepromCrc(*con);
    if (r.given_bytes < kEepromBytes) {
      say(progress, fmt::format("{} gives {} of {} bytes: the other {} come from the board "
                                "(read through {})",
                                hex_path, r.given_bytes, kEepromBytes, kEepromBytes - r.given_bytes,
                                imageName(r.image)));
      const std::vector<uint8_t> now = boardEepromDump(*con);
      for (std::size_t i = 0; i < kEepromBytes; ++i)
        if (!file.given[i]) image[i] = now[i];
    }
    if (EepromCrcs::of(image) == before) {
      r.crcs = before;
      r.wall_s = r.prepare_wall_s = secondsSince(t0);
      say(progress, fmt::format("the board already holds this image ({}); nothing written",
                                before.text()));
      return r;
    }
  }
  r.prepare_wall_s = secondsSince(t0);
  // The whole image, so avrdude has nothing to merge with what the broken read returns.
  say(progress, fmt::format("writing {} EEPROM bytes through the bootloader on {} (a real "
                            "board takes ~3.3 ms per byte: ~14 s)",
                            hal::kEepromBytes, port));
  r.avrdude = writeEepromHex(port, hex::formatIntelHex(image), hex_path, "eeprom put", o);
  r.written = true;
  const Verified v = verifyEeprom(port, image, "eeprom put", o);
  r.crcs = v.crcs;
  r.verify_wall_s = v.wall_s;
  r.wall_s = secondsSince(t0);
  return r;
}

EepromRangeResult putEepromRange(const std::string& port, const std::vector<uint8_t>& image, std::size_t first,
                                 std::size_t count, const std::string& what, const TransferOptions& o) {
  if (image.size() != kEepromBytes || first % 16 != 0 || count % 16 != 0 || first + count > kEepromBytes)
    throw std::invalid_argument(fmt::format("EEPROM range {}..{} is not whole 16-byte records", first,
                                            first + count));
  const auto t0 = Clock::now();
  requirePort(port);
  findAvrdude();
  EepromRangeResult r;
  std::string part;
  std::istringstream all(hex::formatIntelHex(image));
  for (std::string line; std::getline(all, line);) {
    const std::size_t addr = std::stoul(line.substr(3, 4), nullptr, 16);
    if (line.substr(7, 2) == "01" || (line.substr(7, 2) == "00" && addr >= first && addr < first + count))
      part += line + "\n";
  }
  say(o.progress, fmt::format("writing EEPROM bytes {}..{} through the bootloader on {} (nothing else)", first,
                              first + count - 1, port));
  r.avrdude = writeEepromHex(port, part, what, what, o);
  const Verified v = verifyEeprom(port, image, what, o);
  r.crcs = v.crcs;
  r.image = v.image;
  r.boot = v.boot;
  r.wall_s = secondsSince(t0);
  return r;
}

EepromGetResult getEeprom(const std::string& port, const TransferOptions& o) {
  const Progress& progress = o.progress;
  const auto t0 = Clock::now();
  EepromGetResult r;
  std::unique_ptr<ConsoleClient> con;
  auto sp = openBooted(port, "eeprom get", con, o.boot_timeout_s);
  r.image = con->image();
  const auto td = Clock::now();
  r.bytes = boardEepromDump(*con);
  r.dump_wall_s = secondsSince(td);
  r.crcs = EepromCrcs::of(r.bytes);
  r.wall_s = secondsSince(t0);
  say(progress, fmt::format("read {} bytes through {} in {:.1f} s (dump {:.1f} s): {}",
                            hal::kEepromBytes, imageName(r.image), r.wall_s, r.dump_wall_s,
                            r.crcs.text()));
  return r;
}

}  // namespace board
