// Commands typed into the terminal that runs `sim console` (sim/console_stdin.hpp).
#include "sim/console_stdin.hpp"

#include <fmt/format.h>
#include <poll.h>
#include <unistd.h>

#include <cstdio>
#include <string>

namespace sim {

const char* const ConsoleStdin::kHelp =
    "simulator commands (type here, Enter): level = the rig level and still now; help";

ConsoleStdin::ConsoleStdin(PtyBridge& pty, AirframeRig* rig) : pty_(pty), rig_(rig) {
  thread_ = std::thread([this] { read(); });
}

ConsoleStdin::~ConsoleStdin() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

// Polls stdin every 100 ms so the destructor never waits on a blocked read.
void ConsoleStdin::read() {
  std::string line;
  while (!stop_) {
    pollfd p{STDIN_FILENO, POLLIN, 0};
    const int ready = ::poll(&p, 1, 100);
    if (ready < 0) return;
    if (ready == 0) continue;
    if (!(p.revents & POLLIN)) return;  // closed or hung up: nothing more will come
    char buf[256];
    const ssize_t n = ::read(STDIN_FILENO, buf, sizeof buf);
    if (n <= 0) return;
    for (ssize_t i = 0; i < n; ++i) {
      if (buf[i] != '\n' && buf[i] != '\r') {
        line += buf[i];
        continue;
      }
      if (!line.empty()) handle(line);
      line.clear();
    }
  }
}

void ConsoleStdin::handle(const std::string& line) {
  if (line == "level") {
    if (rig_ == nullptr) {
      fmt::print("level: there is no attitude rig (use --rig seesaw or gimbal)\n");
    } else {
      const double t_s = pty_.paused([&] {
        rig_->levelNow();
        return rig_->board().timeS();
      });
      fmt::print("level: t={:.3f} s the rig is level and still\n", t_s);
    }
  } else if (line == "help") {
    fmt::print("{}\n", kHelp);
  } else {
    fmt::print("unknown simulator command '{}': {} (the firmware's console is on the pty)\n", line, kHelp);
  }
  std::fflush(stdout);
}

}  // namespace sim
