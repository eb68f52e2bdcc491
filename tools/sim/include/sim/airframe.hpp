// The virtual airframe: any firmware image on the simulated board, an attitude rig on its ESC
// outputs (the seesaw, plant/seesaw.hpp, or the quad on a gimbal, plant/gimbal.hpp: ESC i
// drives motor i), the MPU-6050 on its TWI measuring the rig, the battery monitor on A1 (as on
// the quad), faults at given simulated times, and a log of the rig's true state.
//
//   sim::AirframeOptions o;                       // gimbal, X layout, four kv1100_9x4.7
//   o.motors[2] = plant::presetParams("kv900_11x4.7");   // one motor a different part
//   o.imu_params.seed = 7;
//   o.faults.push_back(sim::parseAirFault("prop-loss:1:0.3@3.0"));
//   sim::AirframeRig rig("build/avr/firmware/fly/fly.elf", o);
//   rig.run(5.0);                                 // simulated seconds
//   plant::RigTruth t = rig.truth();              // roll/pitch/yaw, body rates, ...
//
// The plant follows the board's clock: it is advanced to the present cycle at every board
// tick (1 ms), whenever the IMU samples, at every fault and log instant, in sub-steps of at
// most 0.25 ms. Deterministic: same image, options and inputs, same run.
#pragma once
#include <array>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "plant/gimbal.hpp"
#include "plant/seesaw.hpp"
#include "plant/sensors.hpp"
#include "sim/board.hpp"
#include "sim/imu_on_board.hpp"
#include "sim/pin_names.hpp"

namespace sim {

enum class AirRig { kSeesaw, kGimbal };
const char* airRigName(AirRig rig);

struct AirFault {
  enum class Kind { kImuNack, kImuFreeze, kSdaLow, kMotorDead, kPropLoss };
  Kind kind = Kind::kImuNack;
  double at_s = 0.0;        // simulated time it happens
  int motor = -1;           // motor-dead, prop-loss: the ESC output / motor
  double share = 0.0;       // prop-loss: the share of thrust lost, 0..1
  int release_clocks = 0;   // sda-low: SCL clocks that free it (0: it stays low)
  std::string spec;         // as written
};

// "KIND[:ARG[:ARG]]@T", T in simulated seconds:
//   imu-nack@T           the IMU stops answering (NACK to its address)
//   imu-freeze@T         the IMU's data registers stop updating
//   sda-low[:N]@T        a slave holds SDA low (N: until N SCL clocks made as GPIO)
//   motor-dead:M@T       motor / ESC M dies (no drive; the rotor coasts down)
//   prop-loss:M:S@T      propeller M loses the share S (0..1) of its thrust
// Throws std::invalid_argument saying what is wrong and what to write instead.
AirFault parseAirFault(const std::string& spec);
extern const char* const kAirFaultSyntax;  // the list above, for --help

struct AirframeOptions {
  AirRig rig = AirRig::kGimbal;
  plant::SeesawParams seesaw = plant::SeesawParams::benchRig();
  plant::GimbalParams gimbal;   // its layout, inertia, damping, battery; common.spin for both
                                // rigs: each motor's propeller direction (plant/attitude_rig.hpp)
  // ESC output i -> motor i (the seesaw uses 0 and 1). Default: four kv1100_9x4.7.
  std::array<plant::ActuatorParams, 4> motors;
  // The pins of ESC outputs 0..3: the board table (hal::kEscPins) unless a firmware drives its
  // motors elsewhere (sim/pin_names.hpp: parseEscPins("D3,D5,D6,D2")).
  std::array<hal::MegaPin, hal::kEscChannels> esc_pins = boardEscPins();
  bool imu = true;
  Mpu6050Params imu_params;
  ImuMount imu_mount;           // the chip's rotation against the airframe (default: aligned)
  double imu_temp_c = 25.0;
  std::vector<AirFault> faults;
  double log_period_s = 0.0;    // a row of truth every so many seconds (0: no log)
  bool log_in_memory = true;    // keep the rows (samples()); the CLI streams them instead
};

// One row of the log: the rig's truth and its motors.
struct AirSample {
  plant::RigTruth truth;
  int motors = 0;
  std::array<double, 4> thrust_g{}, pulse_us{}, rpm{};
  double bus_v = 0.0;
};

class AirframeRig {
 public:
  // A board of its own running `elf`, or behind a bootloader (FlashImages), or a board that
  // exists (its plant wiring is replaced; it must outlive the rig). Throws BoardError /
  // std::invalid_argument (a fault that names a motor the rig lacks, an IMU fault without the
  // IMU) with what to do.
  AirframeRig(const std::string& elf, const AirframeOptions& options);
  AirframeRig(const FlashImages& images, const AirframeOptions& options);
  AirframeRig(Board& existing, const AirframeOptions& options);
  ~AirframeRig();
  AirframeRig(const AirframeRig&) = delete;
  AirframeRig& operator=(const AirframeRig&) = delete;

  Board& board() { return board_; }
  plant::AttitudeRig& plant() { return *rig_; }
  plant::Seesaw* seesaw();  // null on the gimbal
  plant::Gimbal* gimbal();  // null on the seesaw
  ImuOnBoard* imu() { return imu_.get(); }  // null without the IMU
  const AirframeOptions& options() const { return o_; }

  void run(double seconds) { board_.runFor(seconds); }
  // The rig's true state now (the plant advanced to the board's time; t_s on the board's clock).
  plant::RigTruth truth();

  // Adds a fault (it happens when simulated time reaches its at_s; at once if that is past).
  void schedule(const AirFault& fault);
  // The faults applied so far, "t=2.000 s imu-nack@2" each; the listener hears each as it is
  // applied (in the simulation's thread).
  const std::vector<std::string>& faultsApplied() const { return applied_; }
  void onFaultApplied(std::function<void(const std::string&)> listener) { fault_listener_ = std::move(listener); }

  // Puts the rig level and still now (roll, pitch and the rates 0; the gimbal keeps its yaw): a
  // person setting the airframe back on its stand after a disarm, so it can arm again.
  void levelNow();

  // The log (AirframeOptions::log_period_s): rows kept, and/or streamed to a listener.
  const std::vector<AirSample>& samples() const { return samples_; }
  void onSample(std::function<void(const AirSample&)> listener) { sample_listener_ = std::move(listener); }
  static std::string csvHeader(int motors);
  static std::string csvRow(const AirSample& s);
  // "gimbal (X, arm 0.225 m, I ...); motors kv1100_9x4.7#1 CCW, ...; MPU-6050 at 0x68 seed 7[, mounted yaw90]"
  std::string describe() const;

 private:
  void build();
  void wire();
  void advanceTo(double board_t_s);
  void apply(const AirFault& f);
  void logRow();
  void checkFault(const AirFault& f) const;

  AirframeOptions o_;
  std::unique_ptr<Board> owned_;
  Board& board_;
  std::unique_ptr<plant::AttitudeRig> rig_;
  plant::BatterySensor vsense_;
  std::unique_ptr<ImuOnBoard> imu_;
  double t0_s_ = 0.0;           // board time when the plant's clock was 0
  std::vector<AirFault> pending_;  // by time
  std::vector<std::string> applied_;
  uint64_t log_rows_ = 0;       // rows so far: the next is due at log_rows_ * log_period_s
  std::vector<AirSample> samples_;
  std::function<void(const AirSample&)> sample_listener_;
  std::function<void(const std::string&)> fault_listener_;
};

}  // namespace sim
