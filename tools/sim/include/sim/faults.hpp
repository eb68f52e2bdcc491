// Fault injection and observation on the simulated board, for the safety HIL tests and
// `thrustcal bench safety` (docs/safety.md):
//  - a calibrated EEPROM made on the host with the firmware's own codecs (no gather needed);
//  - a hang: a function of the real image replaced by a jump to itself, interrupts on
//    ("rjmp .") or off ("cli; rjmp ."), by patching the simulated flash;
//  - every ESC pulse with its width and end time;
//  - the console checksum (docs/console.md).
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/board.hpp"

namespace sim {

// The battery the bare boards read on A1 (12.0 V through the 100k/47k divider), in mV at the pin.
double batteryPinMv(double volts = 12.0);

// Four calibrated slots: 0 and 1 thesis (v1) records with curves at 12.0 and 10.5 V, 2 and 3
// model v2 fitted with the firmware's fitter, of motors whose thrust is
// k ((pwm - 1080 us) / 1000 us * V)^2, k = 12.5 + slot g/V^2.
std::vector<uint8_t> calibratedTestEeprom();

enum class Hang { kInterruptsOn, kInterruptsOff };

struct FlashPatch {
  uint32_t address = 0;
  std::vector<uint8_t> original;
  // When the program first ran into the patched code (simulated seconds; -1: not yet): the
  // moment it hangs, which can be later than the patch (a sweep settling calls no ADC read).
  std::shared_ptr<double> hung_at_s = std::make_shared<double>(-1.0);
};

// Replaces the first instruction(s) of `symbol` (demangled, e.g. "rr::ReadRunApp::runOnce()")
// in the running image with a jump to itself. Throws if the ELF has no such symbol.
FlashPatch hangFunction(Board& board, const std::string& elf, const std::string& symbol, Hang how);
void restoreFlash(Board& board, const FlashPatch& patch);

// "f 1 37" -> "f 1 37*53": the XOR of the line's characters as two upper-case hex digits.
std::string withChecksum(const std::string& line);

// How a firmware answered a line: with a prompt; with its echo (a line end) and nothing else but
// `stream on` rows for a while (read_run answers an empty line, its keep-alive, so); or not yet.
enum class Answer { kPrompt, kEchoOnly, kNone };
// After a line sent when the board's output was `mark` characters long: runs until a prompt
// follows mark, or until the line has been received and `quiet_s` passed without any output
// but line ends and stream rows; at most `budget_s` (all simulated). The prompt is not consumed.
Answer waitAnswer(class Console& con, std::size_t mark, double quiet_s, double budget_s);

// After a flood: waits until the board has received everything sent, `quiet_s` more, ends any
// partial line (a damaged one gets its error), and consumes every reply up to the last prompt,
// so the next command starts clean. A sweep still running is aborted by that line end. A firmware
// that answers the empty line with its echo alone (read_run) is taken as drained once the echo
// has been followed by `quiet_s` of silence.
void drainConsole(class Console& con, double quiet_s = 0.3);

struct Pulse {
  int channel;
  double width_us;
  double end_s;
};

// Every complete ESC pulse the board produces from now on.
class PulseLog {
 public:
  explicit PulseLog(Board& board);
  const std::vector<Pulse>& pulses() const { return pulses_; }
  double lastWiderThan(double width_us) const;  // end of the last such pulse, -1 if none
  double widestBetween(double from_s, double to_s, int channel = -1) const;  // 0 if none
  int countBetween(double from_s, double to_s) const;

 private:
  std::vector<Pulse> pulses_;
};

}  // namespace sim
