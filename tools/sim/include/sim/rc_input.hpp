// RC input for any image on the simulated board (`sim console|run --rc ...`): a receiver
// (sim/rc_receiver.hpp) on the pins `--rc` names, its channel values from a script
// (`--rc-script FILE`, played in simulated time) and/or typed live on a second pseudo-terminal.
// docs/sim.md, "RC receiver input".
//
//   sim::RcOnBoard rc(board, sim::parseRcSpec("pwm:A8,A9,A10,A11", &board.escPins()));
//   rc.play(sim::readRcScript("sticks.csv"));     // rows at their simulated times
//   rc.command("ch 1500 1500 1000 1500");           // what a line on the live pty does
//   std::string path = rc.openPty();                // "/dev/pts/7": type `ch ...` lines there
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/board.hpp"
#include "sim/rc_receiver.hpp"

namespace sim {

// `--rc ppm:PIN` or `--rc pwm:PIN,PIN,...` (1..8 pins, channel k on the k-th).
struct RcSpec {
  RcSignal signal = RcSignal::kPpm;
  std::vector<hal::MegaPin> pins;
  std::string text;  // as written
};
// Pins as sim/pin_names.hpp reads them (D49, A8, PK0). Throws std::invalid_argument saying what
// is wrong and what to write. Pins the Mega's headers do not carry, and pins that carry
// something else on this board (UART0 D0/D1, the TWI D20/D21, an ESC output in `*esc_pins`
// if given) are refused.
RcSpec parseRcSpec(const std::string& spec, const std::array<hal::MegaPin, hal::kEscChannels>* esc_pins);
extern const char* const kRcSpecSyntax;

// One row of an RC script: at t_s, channels 1..count get us[0..count-1] (the rest keep theirs),
// or (loss) the signal stops.
struct RcScriptRow {
  double t_s = 0.0;
  bool loss = false;
  int count = 0;
  std::array<double, kRcChannels> us{};
  int line = 0;  // in the file
};
// The script's CSV: '#' comment lines and blank lines anywhere; a header `t_s,ch1,...,chN`
// (N 1..8, in that order); then one row per change: `T,V1,...,VN` (T simulated seconds, not
// decreasing; V microseconds 500..2500) or `T,loss`. Throws std::invalid_argument
// "NAME:LINE:COLUMN: what is wrong; what to write" for the first bad line.
std::vector<RcScriptRow> parseRcScript(const std::string& text, const std::string& name);
std::vector<RcScriptRow> readRcScript(const std::string& path);

class RcOnBoard {
 public:
  // The receiver wired to the pins of `spec`, no signal until a value is set. The board must
  // outlive this object; a board reset does not reset the receiver.
  RcOnBoard(Board& board, const RcSpec& spec);
  ~RcOnBoard();
  RcOnBoard(const RcOnBoard&) = delete;
  RcOnBoard& operator=(const RcOnBoard&) = delete;

  // Plays `rows`, each when simulated time reaches its t_s (at once if that has passed).
  void play(std::vector<RcScriptRow> rows);
  // One live command, as typed on the pty; returns the reply (one line, no newline):
  //   ch V1 [V2 ... V8]   channels 1..N (spaces or commas), from the next frame
  //   loss                no signal from the next frame
  //   status              the signal, the values, frames sent
  //   help
  std::string command(const std::string& line);
  // Opens the live pseudo-terminal (raw; lines end with CR or LF; each gets its reply) and
  // polls it every 5 ms of simulated time. Returns its path. Throws std::runtime_error if the
  // system has no ptys.
  std::string openPty();
  const std::string& ptyPath() const { return pty_path_; }

  const RcPart& part() const { return part_; }
  // "PPM on D49 (PL0)", "PWM on D62 (PK0), D63 (PK1)"
  std::string describe() const;
  // The rows applied so far and lines taken from the pty, "t=1.0000 s ch 1500 ..." each.
  const std::vector<std::string>& applied() const { return applied_; }

 private:
  static uint64_t onRowTime(avr_t* avr, uint64_t when, void* param);
  static uint64_t onPtyPoll(avr_t* avr, uint64_t when, void* param);
  void apply(const RcScriptRow& row, const char* from);
  void armRows();
  void readPty();
  std::string status() const;

  Board& board_;
  RcSpec spec_;
  RcPart part_;
  std::vector<RcScriptRow> rows_;
  std::size_t next_row_ = 0;
  std::vector<std::string> applied_;
  int pty_master_ = -1, pty_slave_ = -1;
  std::string pty_path_, pty_line_;
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);
};

}  // namespace sim
