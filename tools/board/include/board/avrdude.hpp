// avrdude as the Mega2560's stock STK500v2 bootloader needs it: `-p m2560 -c wiring -b 115200
// -D` (-D: the bootloader refuses chip erase; it erases each page as it writes it), run as a
// child process with a wall-clock time limit.
#pragma once
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace board {

// avrdude is missing, failed, or ran out of time; what() says which, with its last lines.
class AvrdudeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct AvrdudeRun {
  int exit_code = -1;
  bool timed_out = false;
  double wall_s = 0;
  std::string output;  // stdout and stderr, interleaved
};

// $THRUSTCAL_AVRDUDE, else `avrdude` on PATH. Throws AvrdudeError with the package to install.
std::string findAvrdude();

// The arguments every call shares: -p m2560 -c wiring -P PORT -b 115200 -D.
std::vector<std::string> avrdudeArgs(const std::string& port);

// Runs avrdude with `args`, killing it after `timeout_s`. `on_output` sees its output as it
// comes (e.g. to show its progress bars). Never throws for a failed run: look at the result.
AvrdudeRun runAvrdude(const std::vector<std::string>& args, double timeout_s,
                      const std::function<void(const std::string&)>& on_output = {});

// The last `n` lines of avrdude's output, indented, for error messages.
std::string lastLines(const std::string& output, std::size_t n = 8);

}  // namespace board
