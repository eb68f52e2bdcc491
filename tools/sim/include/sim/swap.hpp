// The swap experiment (`thrustcal sim swap`; docs/fly.md, "The swap experiment"): the thesis's
// claim that a calibrated actuator can be exchanged "without affecting the quadrocopter
// performance" (sec. 1), measured in closed loop with the real images.
//
//   1. four stock motors are calibrated with gather_store on the virtual bench (runGather);
//   2. fly flies 10-degree steps from level on the seesaw (its one axis) and on the gimbal
//      (plus layout: roll and pitch), one flight per IMU unit, in each output mode;
//   3. motor 1 is replaced by another part, only slot 1 is calibrated again (the other slots'
//      bytes must not change: checked), and the same steps are flown with the same gains.
// Each run's figures (sim/step_metrics.hpp) come from the rig's true attitude in simulated time.
// The modes get what their users would have: force each slot's own record; generic slot 0's
// record for every motor; pwm the stock motors' hover pulse and force per microsecond; ardupilot
// the lab's ArduPilot fit (`lab export --to ardupilot`) of the stock sweeps. None of those three
// is calibrated again after the swap. What static calibration cannot equalise, the motors' time
// constants, is measured on the plant beside the flights.
//
// Calibrations are cached in the output folder (an EEPROM image per part and a key of what made
// it): a second run does not gather again unless gather_store or the settings changed.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>  // toJson() only: the users include json.hpp
#include <string>
#include <vector>

#include "plant/params.hpp"
#include "thrustcal/dynamics.hpp"
#include "sim/airframe.hpp"
#include "sim/peer_profile.hpp"
#include "sim/scenarios.hpp"
#include "sim/step_metrics.hpp"

namespace sim::swap {

// kForceDyn: force mode with each motor's dynamics in its record and `dyn on` (equal dynamics,
// SwapOptions::dyn_reference_ms). kPeer: another firmware flying with its own gains
// (SwapOptions::peer; its runs' mode in runs[] is "peer:NAME", runModeName()).
enum class Mode { kForce, kGeneric, kPwm, kArduPilot, kPeer, kForceDyn };
const char* modeName(Mode mode);  // "force", "generic", "pwm", "ardupilot", "peer", "force+dyn"
// Throws std::invalid_argument naming the modes.
Mode parseMode(const std::string& name);

// The controller's gains: the thesis's PD (Kp 2.2, Kd 0.4 as fly's default 800 0 146 mN m), and
// the same with an integral term, whose final value says what mismatch it had to absorb.
enum class Gains { kPd, kPid };
const char* gainsName(Gains gains);  // "pd", "pid"
Gains parseGains(const std::string& name);

// A motor + propeller in a slot: the preset's part varied by `seed` (plant::makeVaried), its
// propeller's thrust coefficient times `thrust_scale`.
struct Part {
  std::string name;  // "stock" for the stock motor in a slot; a swapped part's own name
  std::string preset;
  uint64_t seed = 0;
  double thrust_scale = 1.0;
  std::string description;
};
constexpr int kSwapSlot = 1;  // the slot (and ESC output) whose motor is replaced
constexpr const char* kStock = "stock";
// The swapped parts: another KV1100 unit, a KV900 with an 11x4.7 propeller, the stock motor 1
// with a propeller giving 8 % less thrust (C_T x 0.92 at every rpm; C_P, hence the rpm at a
// pulse, unchanged).
const std::vector<Part>& swapParts();
// Throws std::invalid_argument listing the names.
const Part& findPart(const std::string& name);
// The plant's motor for a part (the same on the bench and on the rig).
plant::ActuatorParams actuatorOf(const Part& part, double variation);

struct SwapOptions {
  std::string gather_elf, fly_elf;
  std::string out_dir = "build/swap";  // cache, series CSVs, plots
  GatherModel model = GatherModel::kModelV2;
  std::string stock_preset = "kv1100_9x4.7";
  std::array<uint64_t, 4> stock_seeds = {11, 12, 13, 14};
  double variation = 0.03;
  std::vector<AirRig> rigs = {AirRig::kSeesaw, AirRig::kGimbal};
  std::vector<Mode> modes = {Mode::kForce, Mode::kForceDyn, Mode::kGeneric, Mode::kPwm, Mode::kArduPilot};
  // force+dyn: where the records' dynamics come from: "gather" (gather_store's `dyn` on the
  // virtual bench for each calibrated slot: about 35 simulated s a motor, cached like the
  // calibrations) or "plant" (the plant's own time constants written into the records:
  // plant::recordDynamics, for cheap tests). The reference fly's `dyn on` follows: a fixed
  // first-order lag of this many ms both ways (no faster than any motor's at the forces flown),
  // or 0: the slowest motor's (`dyn on` without arguments), which a swap changes.
  std::string dyn_from = "gather";
  int dyn_reference_ms = 95;
  std::vector<std::string> parts = {"kv1100_9x4.7", "kv900_11x4.7", "prop-8pct"};
  std::vector<Gains> gains = {Gains::kPd, Gains::kPid};
  std::vector<uint64_t> imu_seeds = {1, 2, 3};
  std::array<int, 3> pd_gains = {800, 0, 146};  // fly's `gains KP KI KD`, mN m per rad, rad s, rad/s
  int pid_ki = 800;                             // the integral gain of the PID runs
  double hover_g = 300;                         // per motor (thrust: 4x on the gimbal, 2x on the seesaw)
  int step_deg = 10;
  double settle_s = 0.5;      // level flight after the spool-up, before the step
  bool level = true;          // fly's `level` (the accelerometer's trim) before each flight
  double pid_settle_s = 4.0;  // ... with PID gains: the integrator's time to take up the mismatch
  double window_s = 2.5;      // after the step
  // Up-steps per flight: the step, `window_s` of it, back to level for `window_s`, the next
  // step... Each run's figures are the means over its steps (fly's figures; a peer flies one).
  // One step's rise time scatters by about 1 % (SD) with the same motors (the IMU's noise, the
  // rig's motion at the step), as much as force+dyn's 1 % target: docs/fly.md, "Equal dynamics".
  int steps = 1;
  // force+dyn's up-steps per flight (0: `steps`). Its targets (1 % rise time) are ten times
  // finer than force mode's: the mean of 8 steps measures a run's rise time to about 0.4 %.
  int dyn_steps = 0;
  // Diagnostic: each part's runs fly the stock motor 1 carrying the part's motor and propeller
  // masses (and, on the seesaw, the counterweight), on the stock records: what the part changes
  // in the rig alone, without its thrust or dynamics.
  bool part_mass_only = false;
  // Diagnostic: the rigs' rotors push with their thrust alone, without their drag and spin-up
  // torques about the body's z (plant::RigCommon::reaction_torque): what a part's different
  // torque-to-thrust ratio does through the yaw balance.
  bool no_reaction_torque = false;
  double log_period_s = 0.0025;
  int jobs = 1;  // flights at once (each its own simulated board)
  // A peer (`--peer FILE`): flown on the gimbal with stock and every part, each IMU unit, roll
  // and pitch, beside fly's modes. With no fly mode (`modes` empty) nothing is calibrated.
  std::shared_ptr<const PeerProfile> peer;
  ProgressFn progress;
};

// What the flights fly on: the EEPROM images and the settings of the modes without records.
struct ModeSettings {
  int hover_us = 0;                          // pwm mode: the stock motors' pulse for hover_g (LiPo sweeps)
  double slope_g_per_us = 0;                 // ... and their force per microsecond there
  std::vector<std::string> ardupilot_lines;  // ap, apvolt, appwm: the lab's fit on the stock sweeps
  std::vector<std::pair<std::string, std::string>> ardupilot_params;  // as `lab export` writes them
  double ardupilot_full_g = 0;
  std::size_t ardupilot_rows =
      0;                       // the sweeps' rows it was fitted on (each up to where its force stops rising)
  double ardupilot_rms_g = 0;  // its error on them
};

struct PartCalibration {
  std::string part;
  std::vector<uint8_t> eeprom;   // stock: four slots; a part: slot 1 calibrated again
  std::vector<uint8_t> eeprom_dyn;  // force+dyn: the same with each slot's dynamics (the part's
                                    // slot 1 measured again); empty without force+dyn
  std::array<tc::MotorDynamics, 4> dynamics{};  // ... each slot's dynamics as stored
  bool cached = false;           // taken from the output folder
  double curve_error_max_g = 0;  // the stored model against the plant (runGather)
  std::string eeprom_path;
};

struct Calibration {
  std::vector<PartCalibration> parts;  // stock first
  ModeSettings modes;
  std::vector<std::string> stock_sweeps;  // the stock sweep CSVs (the ArduPilot fit's data)
  const PartCalibration& of(const std::string& part) const;
};

// The motor time constants the calibration cannot change: each part's and the stock motor 1's,
// the rpm's first-order time constant for a step from hover_g - 10 % to + 10 % at 12.0 V.
struct Dynamics {
  std::string part;
  double tau_s = 0, stock_tau_s = 0;
  double rise_change_pct = 0;  // the flights' mean rise time against stock (force, PD, roll)
};
struct DynamicsReport {
  std::array<double, 4> stock_tau_s{};  // the four stock motors, slot 0..3: their own spread
  std::vector<Dynamics> parts;
};

struct RunSpec {
  AirRig rig = AirRig::kGimbal;
  Mode mode = Mode::kForce;
  std::string part = kStock;
  Gains gains = Gains::kPd;
  std::string axis = "roll";  // roll | pitch
  uint64_t imu_seed = 1;
  std::string peer;  // Mode::kPeer: the peer's name (its gains are its own; `gains` unused)
};
// The up-steps a flight in `mode` flies: `dyn_steps` in force+dyn (when set), `steps` otherwise.
int stepsOf(const SwapOptions& o, Mode mode);
std::string runId(const RunSpec& spec);  // "gimbal_force_pd_stock_roll_s1", "gimbal_peer-NAME_stock_roll_s1"
std::string runModeName(const RunSpec& spec);  // modeName(), or "peer:NAME"

struct RunResult {
  RunSpec spec;
  StepMetrics metrics;             // of the true angle of the step's axis, in degrees (the
                                   // mean over the flight's steps)
  std::vector<double> step_rise_s;  // each step's rise time, in order
  double y0_deg = 0;               // mean over the 0.1 s before the step
  double integrator_mnm = 0;       // the step axis's integrator at the end (fly's status)
  double hover_pwm_spread_us = 0;  // max - min of the flying motors' mean pulses, last 0.25 s before the step
  std::string csv_path;            // the time series
  double simulated_s = 0, wall_s = 0;
};

struct Target {
  std::string target, figure, wanted;
  bool met = false;
  std::string what, part, rig;  // "overshoot vs stock", the swapped part, "seesaw" | "gimbal"
  std::string mode = "force";   // "force" | "force+dyn"
};

struct SwapResult {
  SwapOptions options;
  Calibration calibration;
  DynamicsReport dynamics;
  std::vector<RunResult> runs;
  std::vector<Target> targets;
  double simulated_s = 0, flight_wall_s = 0, wall_s = 0;
  // runs[] and targets[] as scripts read them (docs/architecture.md, "Interfaces"), plus setup, dynamics, sim.
  nlohmann::json toJson() const;
};

// Calibrates (or takes the cached images), flies every run, computes the targets. Throws
// std::runtime_error with what went wrong (a refused command, a slot that changed, a flight
// that never armed) and what to do.
SwapResult runSwap(const SwapOptions& options);

// ---- pieces (sim/src/swap_*.cpp), public for the tests ----
Calibration calibrate(const SwapOptions& options);
// force+dyn: each calibration's image with the dynamics of every slot (options.dyn_from), into
// PartCalibration::eeprom_dyn and ::dynamics (swap_dyn.cpp).
void addDynamics(const SwapOptions& options, Calibration& calibration, const ProgressFn& progress);
ModeSettings modeSettings(const SwapOptions& options, const std::vector<std::string>& stock_sweeps);
DynamicsReport measureDynamics(const SwapOptions& options);
// One flight: fly booted on the rig with the part in slot 1, the mode set, armed, settled, the
// step, the window; its time series written to `csv_path` ("" = none).
RunResult flyRun(const SwapOptions& options, const Calibration& calibration, const RunSpec& spec,
                 const std::string& csv_path);
// One flight of the peer (options.peer): booted on the gimbal with the profile's pins, spin,
// IMU mount and EEPROM, the part in slot 1; its sticks from the RC receiver: neutral, the arming
// sticks, hover, then the step (1500 + step x deg-us on the axis's channel). Throws
// std::runtime_error if it never armed (its armed-text, or no motor above idle before the step).
RunResult flyPeerRun(const SwapOptions& options, const RunSpec& spec, const std::string& csv_path);
// The targets of force mode (and force+dyn, tighter: 1 pp, 1 %, 1.05x) with PD gains, each
// swapped part against stock in the same mode, run by run (same rig, axis and IMU unit).
std::vector<Target> swapTargets(const std::vector<RunResult>& runs, const std::vector<std::string>& parts);

}  // namespace sim::swap
