// The virtual bench scenarios behind `thrustcal sim gather|liftoff` (and the HIL tests):
// the real firmware images on a simulated board wired to the plant model.
//
// gather:  gather_store on the thesis bench (plant::Bench: one motor on the load-cell plate),
//          reached the way a user's cable reaches it: the board boots from the Mega2560's
//          bootloader behind a pty and `thrustcal board calibrate`'s client code (tools/board)
//          drives the workflow (GatherLink::kPty); kInProcess types into the simulated UART
//          directly, in simulated time only, which is reproducible byte for byte.
//          Per motor: motor K, plate 60, cal W (W = motor + propeller weight), sweep on a full
//          3S LiPo -> store 1, swap the power for a bench supply at another voltage (or drain
//          the pack) -> tare, sweep -> store 2, show. The EEPROM image is kept across motors.
//          The stored curves are decoded with the core codec and compared with the plant's true
//          steady-state thrust at each stored PWM (power source as at the start of that sweep).
//          With model v2 each sweep is followed by `store v2` instead (the second one refines
//          the model); the stored model is checked at each sweep's conditions the same way.
// liftoff: read_run on the tethered quad (plant::QuadFrame, four varied motors, one LiPo):
//          "liftoff G RAMP HOLD"; thrust, moments and tilt are logged; the hold phase is
//          summarized. Over the pty (kPty, default) the board boots from the bootloader and
//          `thrustcal board liftoff`'s client code flies it (stream on, liftoff, stream off). Uncalibrated = every slot holds the reference slot's record, so all four
//          ESCs get the same PWM (what one generic curve gives).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>  // toJson() only: the users include json.hpp

#include "plant/bench.hpp"
#include "plant/params.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace sim {

// Progress messages (one line each, no newline); default: stderr.
using ProgressFn = std::function<void(const std::string&)>;

// ---- gather ---------------------------------------------------------------------------------

enum class SecondCurveSource { kBenchSupply, kDrainedPack };
// What gather_store stores after each sweep: the thesis's two curves (store 1, store 2) or
// model v2 (store v2 after both sweeps: fitted from the first, refined by the second).
enum class GatherModel { kThesisV1, kModelV2 };
const char* gatherModelName(GatherModel model);  // "v1" / "v2"
// How the scenario reaches gather_store (see the top of this file).
enum class GatherLink { kPty, kInProcess };
const char* gatherLinkName(GatherLink link);  // "pty" / "in-process"

struct GatherOptions {
  std::string elf_path;                 // gather_store.elf
  GatherLink link = GatherLink::kPty;
  std::string bootloader_hex =          // kPty: the bootloader in the boot section
      "/usr/share/arduino/hardware/arduino/avr/bootloaders/stk500v2/stk500boot_v2_mega2560.hex";
  std::string preset = "kv1100_9x4.7";
  std::vector<uint64_t> seeds = {1};    // one varied motor per seed ...
  std::vector<int> slots = {0};         // ... calibrated into this slot (same length)
  double variation = 0.03;              // plant::makeVaried spread
  std::vector<uint8_t> eeprom;          // starting image (empty: erased)
  // Sweep. It starts at 1040 us (below the ESC's ~1100 us start: bin 0 reads the resting pack)
  // so that gather_store's 13 sag bins of 40 us span 1040..1560 us, the band the motors fly
  // in; everything above 1520 us lands in the last bin. Started at 1000 us the last bin
  // (1480 us and up) averages the sag of the whole top of the sweep, and a motor flying near
  // 1480 us limit-cycles between two offsets far apart (the lift-off's spread several times
  // larger). Settle 500 ms: the bench's 3rd-order low-pass has then settled at each step; the
  // thesis's 200 ms reads each step before it has (docs/results.md, benchmark 4).
  int pwm_min_us = 1040, pwm_max_us = 1800, step_us = 10, settle_ms = 500;
  bool settle_auto = false;             // `settle auto` after `settle settle_ms` (then the cap)
  SecondCurveSource second = SecondCurveSource::kBenchSupply;
  GatherModel model = GatherModel::kThesisV1;
  double supply_v = 10.0;               // bench supply for curve 2 (6.32 A limit)
  double drained_soc = 0.25;            // pack state of charge for curve 2 when drained
  double band_min_g = 10.0;             // calibrated band for the error: band_min_g ..
  double band_top_frac = 0.95;          //   band_top_frac * the curve's heaviest gram
  std::string log_dir;                  // sweep CSVs and curve tables go here ("" = none)
  ProgressFn progress;
  // Changes the bench before each motor is calibrated, its varied motor already on it (e.g.
  // another propeller, the amplifier's offset trimmed for a heavier motor); null: as it is.
  std::function<void(plant::BenchParams&)> adjust_bench;
};

// A stored model at one sweep's conditions against the plant. v1: the stored curve of that
// sweep. v2: the stored model, the PWM read_run sends holding each gram in steady state
// (tc::forceToPwmV2 at the bus voltage the plant settles at for that PWM).
struct CurveCheck {
  double start_v = 0;          // as stored (v1: the curve's start voltage; v2: the sweep's rest)
  int max_g = 0;               // heaviest gram the stored curve reaches, at most sweep_max_g
  double sweep_max_g = 0;      // the sweep's largest force, as gather_store reported it
  double band_lo_g = 0, band_hi_g = 0;
  double error_max_g = 0;      // |true thrust at stored PWM - gram| over the band
  double error_rms_g = 0;
  double error_max_pct = 0;    // relative to the gram, grams >= 50 only
  int samples = 0;             // CSV rows of the sweep
  double sweep_simulated_s = 0, sweep_wall_s = 0;
  std::string csv_path;        // the streamed sweep (with plant columns)
};

struct GatherMotorResult {
  int slot = 0;
  uint64_t seed = 0;
  double mount_weight_g = 0;   // what `cal` was told
  CurveCheck curve1, curve2;
  std::string second_source;   // "bench supply 10.0 V" / "drained pack 25 %"
  std::vector<std::string> store;  // the answers to the two store commands
  std::vector<std::string> show;  // `show` output lines
  std::string curves_csv_path;
  double v2_start_us = 0;         // model v2: the stored ESC start threshold
  int v2_knots = 0;               // model v2: knots of the stored curve
};

struct GatherResult {
  GatherModel model = GatherModel::kThesisV1;
  GatherLink link = GatherLink::kPty;
  double session_wall_s = 0;     // wall clock of the whole run (pty: bootloader waits included)
  std::vector<GatherMotorResult> motors;
  std::vector<uint8_t> eeprom;
  double curve_error_max_g = 0;  // worst over all motors and both curves
  double simulated_s = 0, wall_s = 0, realtime_factor = 0;  // wall_s: inside the simulator
  double sweep_realtime_factor = 0;  // simulated / wall during sweeps only
  // v1: calibration.{curve_error_max_g, motors}; v2: calibration.v2.{...} (same keys);
  // sim.{link, session_wall_s, ...}
  nlohmann::json toJson() const;
};

GatherResult runGather(const GatherOptions& options);

// ---- liftoff --------------------------------------------------------------------------------

struct LiftoffOptions {
  std::string elf_path;                       // read_run.elf
  GatherLink link = GatherLink::kPty;         // how the scenario reaches read_run
  std::string bootloader_hex =                // kPty: the bootloader in the boot section
      "/usr/share/arduino/hardware/arduino/avr/bootloaders/stk500v2/stk500boot_v2_mega2560.hex";
  std::vector<uint8_t> eeprom;                // calibrated image (from gather)
  std::string preset = "kv1100_9x4.7";
  std::array<uint64_t, 4> seeds = {1, 2, 3, 4};  // the same seeds as at gather, per slot
  double variation = 0.03;
  double force_g = 300.0;                     // per motor
  int ramp_ms = 2000, hold_ms = 5000;
  double lipo_soc = 1.0;                      // pack at take-off
  bool uncalibrated = false;
  std::string label;                          // names the run ("" = calibrated/uncalibrated)
  int reference_slot = 0;                     // uncalibrated: whose record all four use
  bool dyn = false;                           // equal dynamics: each v2 record gets its motor's
                                              // dynamics (the plant's), `dyn on` before the
                                              // lift-off; in-process only
  double settle_s = 1.0;                      // hold time skipped before averaging
  double sample_period_s = 0.01;              // CSV time step
  std::string csv_path;                       // "" = no CSV
  ProgressFn progress;
};

struct LiftoffSample {
  double t_s;
  std::array<double, 4> thrust_g, pwm_us;
  double roll_deg, pitch_deg, tilt_deg, height_m, roll_moment_nm, pitch_moment_nm, bus_v;
};

struct LiftoffResult {
  std::string mode;                       // "calibrated" / "uncalibrated" (or the label)
  std::array<std::string, 4> models;      // per slot, as read_run reported it: v1, v2 or ""
  double force_g = 0;
  std::array<double, 4> hold_thrust_g{};  // mean over the hold (after settle_s)
  std::array<double, 4> hold_pwm_us{};
  double thrust_spread_pct = 0;           // (max - min) / mean of hold_thrust_g
  double ramp_spread_pct = 0;             // the ramp's largest (max - min) / mean of the four
                                          // thrusts, where their mean is above 20 % of the force
  double force_error_rms_pct = 0;         // rms over motors of (thrust - command) / command
  double max_tilt_deg = 0, hold_tilt_deg = 0;
  double hold_roll_moment_nm = 0, hold_pitch_moment_nm = 0;
  double hold_bus_v = 0;
  std::vector<std::string> calibration_report;  // read_run's boot lines about the slots
  std::vector<LiftoffSample> samples;
  double simulated_s = 0, wall_s = 0, realtime_factor = 0;
  double session_wall_s = 0;              // wall clock of the whole run (pty: boot included)
  GatherLink link = GatherLink::kPty;
  std::string csv_path;
  nlohmann::json toJson() const;
};

LiftoffResult runLiftoff(const LiftoffOptions& options);

// ---- shared helpers -------------------------------------------------------------------------

// Decodes one slot of an EEPROM image with the firmware's codec. Returns the status text
// ("ok", "erased", ...) and fills `out` when ok.
std::string decodeSlot(const std::vector<uint8_t>& eeprom, int slot, tc::MotorCalibration& out);
// Same for a model v2 record (the newest valid of the slot's two copies).
std::string decodeSlotV2(const std::vector<uint8_t>& eeprom, int slot, tc::ModelV2& out);
// Copies slot `from`'s 1024-byte record over slot `to` (CRC included: the copy is valid).
void copySlot(std::vector<uint8_t>& eeprom, int from, int to);
// The varied motor for a seed (plant::makeVaried on the preset).
plant::ActuatorParams motorForSeed(const std::string& preset, uint64_t seed, double variation);
// Writes `lines` to stderr with a "sim: " prefix (default progress).
void stderrProgress(const std::string& line);

}  // namespace sim
