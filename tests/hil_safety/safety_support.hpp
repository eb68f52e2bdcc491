// Shared by the safety HIL tests (issue 8) and the console fuzz: the real images in simavr
// with the fault-injection helpers of sim/faults.hpp (calibrated EEPROM made on the host, hang
// injection by patching flash, the ESC pulse log, the console checksum).
#pragma once
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "hil_support.hpp"
#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/faults.hpp"
#include "sim/watchdog_gaps.hpp"

namespace safety {

using sim::batteryPinMv;
using sim::Hang;
using sim::PulseLog;

inline std::vector<uint8_t> calibratedEeprom() { return sim::calibratedTestEeprom(); }
inline std::string withSum(const std::string& line) { return sim::withChecksum(line); }
using HangPatch = sim::FlashPatch;
inline HangPatch hangFunction(sim::Board& board, const std::string& elf, const std::string& symbol,
                              Hang how) {
  return sim::hangFunction(board, elf, symbol, how);
}
inline void unpatch(sim::Board& board, const HangPatch& p) { sim::restoreFlash(board, p); }

inline bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

inline void drain(sim::Console& con, double quiet_s = 0.3) { sim::drainConsole(con, quiet_s); }

// The watchdog headroom tests' figure and check: the longest gap `meter` saw in `image`,
// printed and recorded (`IMAGE_longest_gap_ms`), at most half the time-out.
inline void expectKickHeadroom(const sim::KickGapMeter& meter, const std::string& image) {
  std::printf("%s: longest %.2f ms without a kick (%s -> %s), %llu kicks\n", image.c_str(), meter.longestMs(),
              meter.longestFrom().c_str(), meter.longestTo().c_str(),
              static_cast<unsigned long long>(meter.kicks()));
  ::testing::Test::RecordProperty(image + "_longest_gap_ms", fmt::format("{:.2f}", meter.longestMs()));
  EXPECT_LE(meter.longestMs(), sim::KickGapMeter::kHeadroomTargetMs)
      << image << ": " << meter.longestFrom() << " -> " << meter.longestTo();
}

// read_run on a bare board: battery on A1, nothing on A0.
struct ReadRunBoard {
  sim::Board board;
  sim::Console con;
  PulseLog log;
  std::vector<std::string> boot_lines;
  explicit ReadRunBoard(const std::vector<uint8_t>& eeprom)
      : board(hil::imagePath("read_run")), con(board, "rr> "), log(board) {
    board.setAdcSource([](int ch) { return ch == 1 ? batteryPinMv() : 0.0; });
    board.setEeprom(eeprom);
    boot_lines = con.waitPrompt(10.0);
  }
  // Sends an empty line (the keep-alive) every `every_s` for `seconds`.
  void keepAliveFor(double seconds, double every_s = 0.2) {
    const uint64_t end = board.cycle() + sim::secondsToCycles(seconds);
    const uint64_t every = std::max<uint64_t>(1, sim::secondsToCycles(every_s));
    while (board.cycle() < end) {
      con.send("");
      board.run(std::min(every, end - board.cycle()));
    }
  }
};

}  // namespace safety
