// The host side of the firmware console line protocol (TEAM.md, "Console line protocol"), over a
// SerialPort: one command line out, the answer lines back until the prompt ("gs> ", "rr> ").
//
// - Every reply line is classified by its prefix: "error: ", "warning: ", "# " (info), anything
//   else is data (CSV rows, the answer itself).
// - Checksums: with checksums() on, each line goes out as `LINE*HH` (HH = XOR of the bytes of
//   LINE, NMEA style). enableStrict() turns them on when the firmware offers them: it sends
//   `strict on` with a checksum; an image that does not know the command answers with an error
//   and the client goes on in plain mode (the images of today), one that does answers without.
// - Abort: abort() sends the abort key (a CR: any key aborts a sweep or a lift-off, and a line
//   end also ends whatever a firmware discards after an abort), waits for the prompt, and sends
//   one empty line to resynchronise.
// - Time limits are wall-clock, sized for a real board; a command that spins a motor is aborted
//   on a time-out, on Ctrl-C (interruptRequested()) and when the port is lost.
#pragma once
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "board/serial_port.hpp"

namespace board {

// The board did not answer as expected in time; what() says what was awaited and shows the
// last lines that came.
class BoardTimeout : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// The firmware refused a command ("error: ..."); what() holds the command and the error line.
class CommandRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// Ctrl-C during a command: the abort key was sent.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// SIGINT/SIGTERM handling for clients: install once; interruptRequested() becomes true.
void installInterruptHandler();
bool interruptRequested();
void clearInterrupt();

enum class Image { kUnknown, kGatherStore, kReadRun, kFly };
const char* imageName(Image image);  // "gather_store", "read_run", "fly", "an unknown image"

// "XOR of the bytes" as two upper-case hex digits.
std::string checksumHex(const std::string& line);
// LINE*HH
std::string withChecksum(const std::string& line);

struct CommandLimits {
  CommandLimits() = default;
  explicit CommandLimits(double total, double silence = 0.0, bool abort = false)
      : total_s(total), silence_s(silence), abort_on_failure(abort) {}
  double total_s = 10.0;    // the whole answer
  double silence_s = 0.0;   // longest gap between two lines (0: only the total counts)
  bool abort_on_failure = false;  // send the abort key on a time-out, Ctrl-C or error: motors spin
  // While waiting, send an empty line (a bare CR, never checksummed) every keep_alive_s (0: never),
  // until a line starting with keep_alive_until arrives: read_run's lift-off stops after 500 ms
  // without a line end (docs/console.md), and any other byte aborts it.
  double keep_alive_s = 0.0;
  std::string keep_alive_until;
};

class ConsoleClient {
 public:
  using LineFn = std::function<void(const std::string& line)>;

  explicit ConsoleClient(SerialPort& port);

  // After a reset: waits up to `timeout_s` for a prompt (the bootloader's wait, then the
  // image's banner; read_run arms its ESCs for 2 s first). Returns the lines before it and sets
  // image(). Throws BoardTimeout (with what did arrive) when no prompt comes.
  std::vector<std::string> waitForBoot(double timeout_s = 10.0);
  Image image() const { return image_; }
  const std::string& prompt() const { return prompt_; }

  // Turns on strict mode with checksums if the firmware offers it; returns checksums().
  bool enableStrict();
  bool checksums() const { return checksums_; }
  void setChecksums(bool on) { checksums_ = on; }

  // Sends `line` and returns the answer lines up to the next prompt (the echo removed).
  // `on_line` sees each line as it arrives. Throws BoardTimeout, Interrupted, PortError.
  std::vector<std::string> command(const std::string& line, const CommandLimits& limits = {},
                                   const LineFn& on_line = {});
  // The same, and throws CommandRefused when an answer line starts with "error: ".
  std::vector<std::string> mustCommand(const std::string& line, const CommandLimits& limits = {},
                                       const LineFn& on_line = {});
  // Sends `line` and returns once a line matching `until` (a prefix) arrived, without waiting
  // for a prompt (e.g. `stream on`, which answers with a CSV header and no prompt).
  std::string sendUntil(const std::string& line, const std::string& until, double timeout_s);
  // Reads lines for up to `timeout_s` (a prompt, if one comes, ends it early when
  // stop_at_prompt), passing each to `on_line`.
  void readLines(double timeout_s, const LineFn& on_line, bool stop_at_prompt);

  // The abort key, then the prompt, then one empty line (see above). Never throws.
  void abort();

  // The last lines received (for error messages).
  std::string tail(std::size_t n = 12) const;
  SerialPort& port() { return port_; }

 private:
  bool pumpOnce(double timeout_s);  // reads; splits into lines_; true if anything came
  bool promptPending() const;       // the unfinished line starts with the prompt
  bool startsWithPrompt(const std::string& text) const;
  std::string takeLine();           // the oldest complete line ("" if none)
  void remember(const std::string& line);

  SerialPort& port_;
  std::string prompt_;
  Image image_ = Image::kUnknown;
  bool checksums_ = false;
  std::string buffer_;                // received, not yet split into lines
  std::vector<std::string> history_;  // recent lines
};

}  // namespace board
