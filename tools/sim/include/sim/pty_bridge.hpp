// The simulated board's UART0 on a pseudo-terminal, so a person opens it exactly like the real
// board: `screen /dev/pts/N 115200` or `picocom -b 115200 /dev/pts/N` (the baud setting is
// ignored by a pty; bytes reach the firmware at its own line rate).
#pragma once
#include <atomic>
#include <string>

#include "sim/board.hpp"

namespace sim {

class PtyBridge {
 public:
  // Opens a pty (raw mode) and wires it to `board`'s UART0. Throws std::runtime_error if the
  // system has no ptys (/dev/ptmx).
  explicit PtyBridge(Board& board);
  ~PtyBridge();
  PtyBridge(const PtyBridge&) = delete;
  PtyBridge& operator=(const PtyBridge&) = delete;

  // The terminal to open, e.g. "/dev/pts/3".
  const std::string& path() const { return path_; }

  // Runs the board in slices of `slice_s` simulated seconds, passing pty input to the firmware
  // and its output to the pty, at `speed` times real time (0: as fast as the host allows),
  // until `stop` becomes true or `duration_s` simulated seconds pass (0: no limit).
  void run(double speed, double duration_s, const std::atomic<bool>& stop, double slice_s = 0.005);

 private:
  Board& board_;
  int master_fd_ = -1;
  int slave_fd_ = -1;  // kept open so the master never sees a hang-up between clients
  std::string path_;
  std::string pending_out_;
};

}  // namespace sim
