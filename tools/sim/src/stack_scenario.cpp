#include "sim/stack_scenario.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <regex>
#include <stdexcept>
#include <string>

#include "sim/board.hpp"
#include "sim/console.hpp"
#include "sim/elf_symbols.hpp"
#include "sim/faults.hpp"
#include "sim/lsan_simavr.hpp"
#include "sim/rigs.hpp"
#include "sim/scenarios.hpp"

extern "C" {
#include <simavr/sim_avr.h>
}

namespace sim {

namespace {

constexpr uint8_t kStackPaint = 0xC5;  // what the boot code paints the free SRAM with

// "stack: N of M bytes never used" from status's lines.
void readStatus(const std::vector<std::string>& lines, StackHeadroom& h) {
  static const std::regex re(R"(stack: (\d+) of (\d+) bytes never used)");
  h.status = lines;
  for (const auto& l : lines) {
    std::smatch m;
    if (std::regex_search(l, m, re)) {
      h.untouched_bytes = std::stoi(m[1]);
      h.stack_bytes = std::stoi(m[2]);
    }
  }
}

// Paint bytes still intact from _end upwards, read from the simulated SRAM.
int scanUntouched(Board& board, const std::string& elf) {
  const uint32_t end = elfSymbol(elf, "_end").address & 0xFFFF;
  const avr_t* avr = board.avr();
  int n = 0;
  for (uint32_t a = end; a <= avr->ramend && avr->data[a] == kStackPaint; ++a) ++n;
  return n;
}

// Line editing without a line end: every byte is handled, nothing is executed.
std::string flood(std::size_t bytes) {
  std::string f;
  while (f.size() < bytes) f += "a\b";
  return f;
}

}  // namespace

StackHeadroom gatherStoreDeepestPaths(const std::string& elf) {
  plant::BenchParams params = plant::BenchParams::thesis("kv1100_9x4.7");
  params.actuator = motorForSeed("kv1100_9x4.7", 13, 0.03);
  BenchRig rig(elf, params, 0);
  Console con(rig.board, "gs> ");
  con.waitPrompt(10.0);
  con.command(fmt::format("cal {}", static_cast<int>(std::lround(params.actuator.mountWeight_g()))), 10);
  con.command("range 1040 1800");
  con.command("settle 60");
  con.command("sweep", 120);
  StackHeadroom h;
  h.deepest = con.command("store v2", 10);
  con.command("show", 10);
  con.command("store 1", 10);
  rig.board.sendText("help\r" + flood(3000));
  drainConsole(con);
  readStatus(con.command("status", 10), h);
  h.scanned_untouched_bytes = scanUntouched(rig.board, elf);
  h.console_tail = con.tail();
  return h;
}

StackHeadroom readRunDeepestPaths(const std::string& elf) {
  Board board(elf);
  board.setAdcSource([](int ch) { return ch == 1 ? batteryPinMv() : 0.0; });
  board.setEeprom(calibratedTestEeprom());
  Console con(board, "rr> ");
  con.waitPrompt(10.0);
  con.send("liftoff 250 300 500");
  const uint64_t end = board.cycle() + secondsToCycles(1.2);  // keep-alive lines every 0.2 s
  while (board.cycle() < end) {
    con.send("");
    board.run(std::min(secondsToCycles(0.2), end - board.cycle()));
  }
  StackHeadroom h;
  h.deepest = con.command("f 200");
  board.sendText("help\r" + flood(2000));
  drainConsole(con, 0.1);
  readStatus(con.command("status"), h);
  h.scanned_untouched_bytes = scanUntouched(board, elf);
  h.console_tail = con.tail(40);
  return h;
}

StackHeadroom flyDeepestPaths(const std::string& elf, Console& con) {
  Board& board = con.board();
  const auto fly = [&](double seconds) {  // with a keep-alive line every 0.1 s: fly stays armed
    for (double done = 0; done < seconds - 1e-9; done += 0.1) {
      board.sendText("\r");
      board.runFor(std::min(0.1, seconds - done));
    }
  };
  con.send("stream on");
  fly(0.3);
  con.command("stream off");
  board.sendText("help\r" + flood(100));  // line editing while the reply waits for room
  fly(0.6);  // the reply, the flood's echo and its rejection (an empty line gets no prompt)
  while (con.unconsumed().find(con.prompt()) != std::string::npos) con.waitPrompt(0.1);
  StackHeadroom h;
  readStatus(con.command("status"), h);
  h.deepest = h.status;
  h.scanned_untouched_bytes = scanUntouched(board, elf);
  h.console_tail = con.tail(40);
  return h;
}

void flyDisarmedPaths(Console& con) {
  for (const char* line : {"param list", "param save"}) {
    for (const std::string& l : con.command(line, 5.0))
      if (l.rfind("error: ", 0) == 0 && l.find("no room") == std::string::npos)  // thesis records: no room
        throw std::runtime_error(std::string("fly refused `") + line + "`: " + l);
  }
}

}  // namespace sim
