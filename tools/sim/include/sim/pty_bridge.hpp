// The simulated board's UART0 on a pseudo-terminal, so a person or a program opens it exactly
// like the real board: `screen /dev/pts/N 115200`, `picocom -b 115200 /dev/pts/N`, avrdude,
// `thrustcal board ...` (the baud setting is ignored by a pty; bytes reach the firmware at its
// own line rate).
//
// Two ways to run:
//   - console (sim console): the bridge holds the port open itself, so clients come and go
//     without anything happening to the board, and time is paced at one constant speed.
//   - board (sim board, reset_on_open): like a Mega2560 on USB. A client that opens the port and
//     flushes it resets the board, as the DTR pulse of a real USB-serial adapter does (a pty has
//     no DTR; the flush is seen through the master's packet mode, TIOCPKT_FLUSHREAD/WRITE; every
//     flush resets, as clients flush only when they open the port). Whether a client has the
//     port open is seen through POLLHUP; output nobody has open is dropped.
//     Time is paced at `idle_speed` while nothing is in flight, so a bootloader's timeout takes
//     as long as on the bench, and runs at `busy_speed` while bytes flow: input waiting for the
//     UART, or a console command line whose prompt has not come back yet (application only;
//     while the CPU is in the bootloader only pending input counts, its protocol is binary).
#pragma once
#include <atomic>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "sim/board.hpp"

namespace sim {

struct PtyOptions {
  // Reset the board when a client opens the port and flushes it (see above); false: the bridge
  // keeps the port open itself and never resets the board.
  bool reset_on_open = false;
  // A stable name for the port: a symlink to /dev/pts/N, made at start and removed at the end.
  // An existing symlink there is replaced; any other file is refused.
  std::string link_path;
  // One line per event (client connected, reset, client left); empty: silent.
  std::function<void(const std::string&)> log;
  // Runs right after a client reset the board, in the bridge's thread with the simulation
  // stopped (e.g. to wire the plant that fits the image now in flash).
  std::function<void()> on_reset;
  // While this returns true (asked with the simulation stopped), the board runs at most at real
  // time, busy or not: read_run counts the client's keep-alive lines in its own time (failsafe,
  // lift-off: 500 ms), and a client keeps time by the wall clock, as with a real board.
  std::function<bool()> real_time_while;
};

// A pseudo-terminal in raw mode: the master (non-blocking) for the simulator, the slave's path
// for a client, and the slave held open here too, so that clients come and go without a
// hang-up on the master. Throws std::runtime_error if the system has no ptys (/dev/ptmx).
struct RawPty {
  int master_fd = -1;
  int slave_fd = -1;
  std::string path;  // "/dev/pts/N"
};
RawPty openRawPty();

// True while any ESC output pulses wider than `us` (a motor spins).
bool anyEscAbove(const Board& board, double us = 1050.0);

// Simulated seconds per wall-clock second; 0 = as fast as the host allows.
struct Pacing {
  double idle_speed = 1.0;
  double busy_speed = 0.0;
};

class PtyBridge {
 public:
  // Opens a pty (raw mode) and wires it to `board`'s UART0. Throws std::runtime_error if the
  // system has no ptys (/dev/ptmx) or the link cannot be made.
  explicit PtyBridge(Board& board, PtyOptions options = {});
  ~PtyBridge();  // stops the thread (if started), closes the pty, removes the link
  PtyBridge(const PtyBridge&) = delete;
  PtyBridge& operator=(const PtyBridge&) = delete;

  // The terminal to open, e.g. "/dev/pts/3".
  const std::string& path() const { return path_; }
  // What a client should open: the link if there is one, else path().
  const std::string& port() const { return options_.link_path.empty() ? path_ : options_.link_path; }

  // Runs the board in slices of `slice_s` simulated seconds, passing pty input to the firmware
  // and its output to the pty, at `speed` times real time (0: as fast as the host allows),
  // until `stop` becomes true or `duration_s` simulated seconds pass (0: no limit).
  void run(double speed, double duration_s, const std::atomic<bool>& stop, double slice_s = 0.005);
  // The same with the idle/busy pacing described above.
  void run(const Pacing& pacing, double duration_s, const std::atomic<bool>& stop);

  // Runs the bridge in a background thread until stop() (or the destructor).
  void start(const Pacing& pacing);
  // Stops the thread and rethrows what stopped the simulation early, if anything (a crashed
  // firmware: BoardError).
  void stop();
  // Runs `f` while the simulation stands still: the only safe way for another thread to touch
  // the board or the plant wired to it while the bridge runs in its thread.
  template <class F>
  decltype(auto) paused(F&& f) {
    pause_requests_.fetch_add(1);
    std::lock_guard<std::mutex> lock(mutex_);
    pause_requests_.fetch_sub(1);
    return f();
  }

  // Whether a client has the port open, and the number of resets it caused.
  bool clientConnected() const { return connected_.load(); }
  uint64_t clientResets() const { return client_resets_.load(); }

 private:
  struct LoopState;
  void loop(const Pacing& pacing, double duration_s, const std::atomic<bool>& stop,
            const LoopState& st);
  void serviceInput();
  void deliverOutput();
  bool busy() const;
  void trackInput(const char* data, std::size_t n);
  void trackOutput(uint8_t byte);
  void say(const std::string& line) const;
  void waitWall(double seconds);

  Board& board_;
  PtyOptions options_;
  int master_fd_ = -1;
  int slave_fd_ = -1;  // console mode: kept open so the master never sees a hang-up
  std::string path_;
  std::string pending_out_;
  bool link_made_ = false;

  // Console activity (board mode pacing).
  bool in_line_ = false;          // the client has typed something since the last line end
  bool command_running_ = false;  // a line was sent and its prompt has not come back
  std::string out_line_;          // output since the last newline (capped)
  double last_output_s_ = -1, last_input_s_ = -1;  // simulated time bytes last moved

  bool hup_ = true;  // no client has the port open
  std::atomic<bool> connected_{false};
  std::atomic<uint64_t> client_resets_{0};

  std::mutex mutex_;
  std::atomic<int> pause_requests_{0};
  std::thread thread_;
  std::atomic<bool> thread_stop_{false};
  std::exception_ptr thread_error_;
};

}  // namespace sim
