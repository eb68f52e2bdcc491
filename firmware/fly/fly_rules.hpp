// fly's decisions as pure functions of numbers: when it may arm, when it must disarm, how its
// 400 Hz frame is laid out. No HAL, no console, no state of their own: fly_app.cpp calls them,
// tests/firmware/fly/test_fly_rules.cpp checks them without booting the image. The reasons and
// the figures behind the constants: docs/fly.md.
#pragma once
#include <math.h>
#include <stdint.h>

#include "flight_types.hpp"
#include "link_watch.hpp"
#include "thrustcal/record_limits.hpp"

namespace fly {

// ---- the frame ----
// What runs after the pulses are written: each job once in a cycle of frames (kSlowJobHz times
// a second), on its own frame, so no frame carries two: the battery (four ADC conversions and
// the median), the mode's use of it (ardupilot: its voltage filter and lift_max), a stream row,
// the accelerometer's roll correction, its pitch correction.
enum class SlowJob : uint8_t {
  kNone,
  kBattery,
  kBatteryModel,
  kStreamRow,
  kRollCorrection,
  kPitchCorrection
};
constexpr uint16_t kSlowJobHz = 50;
constexpr uint8_t kSlowCycleFrames = static_cast<uint8_t>(kLoopHz / kSlowJobHz);
static_assert(kLoopHz % kSlowJobHz == 0 && kSlowCycleFrames >= 8, "five jobs on frames of their own");
inline SlowJob slowJob(uint32_t frame) {
  switch (frame % kSlowCycleFrames) {
    case 0:
      return SlowJob::kBattery;
    case 1:
      return SlowJob::kBatteryModel;
    case 3:
      return SlowJob::kStreamRow;
    case 5:
      return SlowJob::kRollCorrection;
    case 7:
      return SlowJob::kPitchCorrection;
    default:
      return SlowJob::kNone;
  }
}
constexpr float kSlowCycleS = kSlowCycleFrames * kFramePeriodS;

// When in the frame the IMU read starts (Esc's phase hook): as late as lets the read and the
// computation end before the frame ends, so the next rising edge carries the result and the
// time from the end of the read to that edge is the computation's budget, not a whole frame.
constexpr uint16_t kImuReadUs = 720;   // a 15-byte burst at 400 kHz, its interrupts, the wake-up
constexpr uint16_t kMinPhaseUs = 100;  // after the rising edge at the earliest
inline uint16_t readPhaseUs(uint16_t budget_us) {
  const uint16_t needed = static_cast<uint16_t>(kImuReadUs + budget_us);
  return needed + kMinPhaseUs >= kFrameUs ? kMinPhaseUs : static_cast<uint16_t>(kFrameUs - needed);
}

// The computation from a finished read to the written pulses: estimator, controller and mixer,
// then the output stage's own cost (a budget, not a measurement: status shows the measured
// time, docs/fly.md the figures).
// The budgets (issue 19 item 4: read end to the rising edge at most 1 ms): the time from the
// read's end to the edge is the budget plus what the read leaves of kImuReadUs (~220 us: the
// read takes ~500 us), so a budget may not exceed ~780 us. Each covers its mode's worst
// computation as `thrustcal bench fly` measures it (read end to the written pulses, hover and
// a 10 deg roll step sent on the console, the mixer's saturation path integer, console lines
// kept out of the read: consoleMayStart) with at least 60 us to spare, and the read's ~220 us
// behind that before a frame's pulses would go out one frame late: force v2 and generic 760 us
// (measured 560 / 543 us), ardupilot 500 + 4 x 65 = 760 us (699 us), pwm 750 us (431 us). For
// ardupilot the margin is what the 1 ms target leaves (760 + 220 is 980 us), not a choice; it
// is ~8 % of its computation, the others have more. Thesis records: v2's 760 us (no time of
// their own, kThesisMotorBudgetUs 0), what the 1 ms target leaves, not a cover: their worst
// computation measured is 840 us (the frames that take the `arm` and the `sp` lines; 810 us
// outside them), above the budget, so their worst frames take up to ~80 us of the read's ~220 us
// spare (written at least 132 us before their edge, none late; four motors' option 2.1 take
// ~4,500 cycles a frame where v2's frame takes ~1,700: thesis_runtime.hpp, docs/fly.md
// "Budgets"). status counts a frame that goes late. Budgets of 764-772 us met read to edge too,
// but moved the read's end onto other interrupts in the `arm` and `sp` frames, so that status
// (the TWI interrupt's clock) read 13 us less than the bench's simulated cycles there.
constexpr uint16_t kControlBudgetUs = 500;         // taking the sample, estimator, controller, mixer
constexpr uint16_t kForceApiBudgetUs = 260;        // forces to grams, the v2 frame, the pulses
constexpr uint16_t kThesisMotorBudgetUs = 0;       // option 2.1 on one motor beyond the v2 frame's share (none)
constexpr uint16_t kArduPilotMotorBudgetUs = 65;   // one square root and a few products
constexpr uint16_t kPwmBudgetUs = 250;
// thesis_motors: the motors that fly a v1 record (force, generic modes); motors: the layout's.
inline uint16_t computeBudgetUs(OutputMode mode, uint8_t thesis_motors, uint8_t motors) {
  switch (mode) {
    case OutputMode::kPwm:
      return kControlBudgetUs + kPwmBudgetUs;
    case OutputMode::kArduPilot:
      return static_cast<uint16_t>(kControlBudgetUs + motors * kArduPilotMotorBudgetUs);
    default:
      return static_cast<uint16_t>(kControlBudgetUs + kForceApiBudgetUs +
                                   thesis_motors * kThesisMotorBudgetUs);
  }
}

// A console line is handled in one go (parsing, the setting, the reply: ~800 us for `sp`), and
// the frame's computation waits for it if the read ends meanwhile: armed, or able to arm (the
// estimate runs), a line is taken only early in the frame, at least kConsoleSliceUs before the
// read starts (the read then runs ~500 us, so ~900 us of console work ends before the read
// does), else in a later frame. 300 us was too little: once the reply printed faster and the
// main loop's wake checks were inlined, a `sp` line taken late in that window ran ~100 us past
// the read's end in force+dyn (`thrustcal bench fly`: computation 839 us, 732 us with 400).
// Where the read starts too early to leave such a window (thesis records) the line is taken
// whenever it comes, as before.
constexpr uint16_t kConsoleSliceUs = 400;
inline bool consoleMayStart(uint16_t frame_time_us, uint16_t phase_us) {
  if (phase_us < kMinPhaseUs + kConsoleSliceUs) return true;
  return frame_time_us + kConsoleSliceUs < phase_us;
}

// ---- arming ----
constexpr float kArmLevelDeg = 5.0f;  // roll and pitch within this of level
constexpr float kArmStillDps = 5.0f;  // every body rate below this
constexpr uint16_t kSpoolMs = 1000;   // the collective ramps up from 0 this long after arming

enum class ArmRefusal : uint8_t {
  kNone,
  kArmed,        // already
  kEscsArming,   // the ESCs' 2 s at the stop pulse after power-on are not over
  kImuFault,     // the IMU failed (or never answered): status says why
  kImuStarting,  // the IMU is being set up or its gyro calibrated
  kNotLevel,
  kMoving,
  kMotorNotCalibrated,  // a motor the layout flies has no valid record to fly (force, generic)
  kModeNeedsSettings,   // pwm: no hover pulse; ardupilot: no parameters
};

struct ArmInputs {
  bool armed = false;
  bool escs_ready = false;
  bool imu_fault = false;
  bool imu_ready = false;  // running, gyro calibrated, every recent read good and fresh
  float roll_deg = 0, pitch_deg = 0;
  float rate_dps[3] = {0, 0, 0};
  bool motors_ok = false;  // every motor the layout flies can fly in this mode
  bool mode_ready = false;
};

// Why `arm` is refused, in the order a user fixes things; kNone: it may arm.
inline ArmRefusal armRefusal(const ArmInputs& in) {
  if (in.armed) return ArmRefusal::kArmed;
  if (in.imu_fault) return ArmRefusal::kImuFault;
  if (!in.imu_ready) return ArmRefusal::kImuStarting;
  if (!in.escs_ready) return ArmRefusal::kEscsArming;
  if (fabsf(in.roll_deg) > kArmLevelDeg || fabsf(in.pitch_deg) > kArmLevelDeg) return ArmRefusal::kNotLevel;
  for (uint8_t i = 0; i < 3; ++i) {
    if (fabsf(in.rate_dps[i]) > kArmStillDps) return ArmRefusal::kMoving;
  }
  if (!in.motors_ok) return ArmRefusal::kMotorNotCalibrated;
  if (!in.mode_ready) return ArmRefusal::kModeNeedsSettings;
  return ArmRefusal::kNone;
}

// The collective at `since_arm_ms` after arming: a linear spool-up from 0 over kSpoolMs (the
// integrators stay at 0 until it is complete). Integer, in the frame path: the share in 1/1024
// by a product (kSpoolMs is 1000: 1049 / 1024 per ms, exact at both ends), no division.
static_assert(kSpoolMs == 1000, "the share's product is for 1000 ms");
inline ForceDg spooledForce(ForceDg full, uint32_t since_arm_ms) {
  if (since_arm_ms >= kSpoolMs) return full;
  const int32_t share_q10 = static_cast<int32_t>((since_arm_ms * 1049u) >> 10);  // 0..1023
  return (full * share_q10 + 512) >> 10;
}

// ---- disarming ----

// The receiver's failsafe. What it promises: armed from the sticks, every ESC is at the stop
// pulse within kRcStopMs of the last valid receiver frame (the edge that completed it). Between
// that edge and the pins lie: the loop takes the frame at its next pass (at most a frame), the
// failsafe is checked once a frame (at most another) on the millisecond clock (1 ms), and the
// pulse under way when it disarms runs to its end (at most the longest, tc::kThrottleMaxUs); the
// next edge carries the stop pulse. So it disarms after kRcLossMs without a valid frame, early by
// that latency (measured in simavr: tests/hil_safety/fly_receiver_hil_test.cpp).
constexpr uint16_t kRcStopMs = 100;
constexpr uint16_t kRcStopLatencyMs =
    static_cast<uint16_t>((2u * kFrameUs + 1000u + tc::kThrottleMaxUs + 999u) / 1000u);
constexpr uint16_t kRcLossMs = kRcStopMs - kRcStopLatencyMs;  // no valid frame this long: disarm
static_assert(kRcLossMs * 10u > 4u * 225u, "two PPM frames lost in a row leave 4 x 22.5 ms between valid ones");
inline bool receiverLost(uint32_t now_ms, uint32_t last_frame_ms) {
  return now_ms - last_frame_ms >= kRcLossMs;  // unsigned: right across the clock's wrap
}

enum class DisarmCause : uint8_t { kNone, kCommand, kCrash, kImu, kLink, kRcLost, kSticks };

// Who armed: the console's `arm` (its link failsafe applies: tc::kFailsafeMs without a line) or
// the receiver's sticks (its failsafe applies: kRcLossMs without a valid frame, below).
enum class ArmSource : uint8_t { kConsole, kSticks };

constexpr uint8_t kDefaultCrashDeg = 45;
constexpr uint8_t kMinCrashDeg = 10;
constexpr uint8_t kMaxCrashDeg = 90;
// Roll or pitch beyond the limit: the aircraft is not flying any more (or about to hit).
inline bool crashed(float roll_rad, float pitch_rad, float limit_rad) {
  return fabsf(roll_rad) > limit_rad || fabsf(pitch_rad) > limit_rad;
}
// The same rule on the estimator's integer angles (every frame: no float), limit > 0.
inline bool crashedUnits(int32_t roll, int32_t pitch, int32_t limit) {
  return roll > limit || roll < -limit || pitch > limit || pitch < -limit;
}

// While armed, kFailsafeMs without a complete valid line (fw::LinkWatch) disarms.
using fw::LinkWatch;

}  // namespace fly
