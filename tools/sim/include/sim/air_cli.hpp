// The virtual airframe on the command line: the options `sim console` and `sim run` share
// (--imu, --imu-seed, --layout, --fault, --log, ...), the wiring they ask for, and the
// `sim run` and `sim imu` subcommands. docs/sim.md, "The virtual airframe".
#pragma once
#include <CLI/CLI.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sim/airframe.hpp"
#include "sim/rc_input.hpp"

namespace sim {

struct AirCliOptions {
  std::string imu = "none";        // none | mpu6050
  uint64_t imu_seed = 1;
  bool imu_ideal = false;          // no unit errors, no noise
  std::string layout = "x";        // gimbal: plus | x
  std::vector<std::string> faults; // KIND[:ARG...]@T
  std::string log;                 // CSV of the rig's truth
  double log_period_s = 0.01;
  std::vector<std::string> motor_parts;  // "M:PRESET": motor M is another part
  double vibration_g = 0.0;        // rotor imbalance at 10,000 rpm
  std::string esc_pins;            // "D3,D5,D6,D2": ESC outputs 0..3 ("": the board table)
  std::string spin;                // gimbal: "cw,ccw,cw,ccw" per motor ("" = the layout's)
  std::string imu_mount = "yaw0";  // the IMU's rotation against the airframe (sim/imu_on_board.hpp)
  std::string rc;                  // ppm:PIN | pwm:PIN,PIN,... ("" = no receiver)
  std::string rc_script;           // CSV of channel values over simulated time
  bool rc_pty = false;             // the live RC pty (sim console opens it whenever --rc is given)
};

// Adds the options above to a command.
void addAirOptions(CLI::App* cmd, AirCliOptions& o);
// "cw,ccw,cw,ccw": +1 (ccw) / -1 (cw) per motor, as many as `motors`. Throws
// std::invalid_argument saying what to write.
std::vector<int> parseSpin(const std::string& text, int motors);
bool isAirRig(const std::string& rig);  // "seesaw" or "gimbal"
// --esc-pins on a board of any rig (the bench, the tethered quad, none): its ESC outputs move.
void applyEscPins(Board& board, const AirCliOptions& o);

// The seesaw or gimbal rig on a board running `elf` (with `eeprom` loaded if not empty), the
// motors from `preset` varied by `seeds` (3 %), the log file opened and streamed to. Throws
// std::invalid_argument / BoardError saying what was wrong and what to do.
std::unique_ptr<AirframeRig> makeAirframeRig(const std::string& elf, const std::string& rig,
                                             const std::string& preset,
                                             const std::vector<uint64_t>& seeds,
                                             const AirCliOptions& o);
// The RC receiver --rc asks for on `board` (null without --rc), playing --rc-script, with the live
// pty open if `pty` (its path in RcOnBoard::ptyPath()). Throws std::invalid_argument saying
// what was wrong (a bad spec, a script's file:line:column, --rc-script without --rc).
std::unique_ptr<RcOnBoard> makeRcInput(Board& board, const AirCliOptions& o, bool pty);
// "rc: 12 changes applied", then the first lines of RcOnBoard::applied(), for the end of a run.
std::string rcSummary(const RcOnBoard& rc);

// A board without an attitude rig (bench, quad, none): the IMU lying still if --imu asked for
// it, and the IMU and bus faults applied at their cycle. Throws std::invalid_argument if an
// option needs the seesaw or the gimbal (--log, motor faults).
class StillAirframe {
 public:
  StillAirframe(Board& board, const std::string& rig, const AirCliOptions& o);
  ~StillAirframe();
  ImuOnBoard* imu() { return imu_.get(); }
  const std::vector<std::string>& faultsApplied() const { return applied_; }
  // Hears each fault as it is applied (in the simulation's thread).
  void onFaultApplied(std::function<void(const std::string&)> listener) { fault_listener_ = std::move(listener); }

 private:
  static uint64_t onFaultTime(avr_t* avr, uint64_t when, void* param);
  void arm();

  Board& board_;
  std::unique_ptr<ImuOnBoard> imu_;
  std::vector<AirFault> pending_;  // by time
  std::vector<std::string> applied_;
  std::function<void(const std::string&)> fault_listener_;
  std::shared_ptr<int> alive_ = std::make_shared<int>(0);
};

void addRunCommand(CLI::App& sim);   // thrustcal sim run
void addImuCommand(CLI::App& sim);   // thrustcal sim imu

}  // namespace sim
