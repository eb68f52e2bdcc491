// Lines typed into the terminal that runs `thrustcal sim console` (not into the board's pty):
// commands to the simulator while the board runs, handled with the simulation paused
// (PtyBridge::paused). `level` sets the attitude rig level and still (after a disarm the gimbal
// drifts; a person would set the airframe back on its stand before arming again); `help` lists
// them. Reading stops at the end of the input (stdin closed or not a terminal: nothing happens).
#pragma once
#include <atomic>
#include <thread>

#include "sim/airframe.hpp"
#include "sim/pty_bridge.hpp"

namespace sim {

class ConsoleStdin {
 public:
  // Starts reading stdin in a thread of its own; `rig` may be null (no attitude rig: `level`
  // says so).
  ConsoleStdin(PtyBridge& pty, AirframeRig* rig);
  ~ConsoleStdin();  // stops the thread
  ConsoleStdin(const ConsoleStdin&) = delete;
  ConsoleStdin& operator=(const ConsoleStdin&) = delete;

  // What the help line says (printed at the start too).
  static const char* const kHelp;

 private:
  void read();
  void handle(const std::string& line);

  PtyBridge& pty_;
  AirframeRig* rig_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace sim
