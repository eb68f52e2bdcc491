// fly's flight types: the quantities its loop's stages pass to each other, and the one place
// their units are written. The stages sit side by side and each depends on this header (and on
// fixed_point.hpp's arithmetic), never on another stage:
//
//   Mpu6050 (imu)  --ImuSample-->  AttitudeEstimator  --AttitudeQ-->  AttitudeController
//   --TorqueDg-->  Mixer  --Forces-->  OutputStage (the force API or a mode's curve)  --> pulses
//
// with the setpoint (SetpointQ) from the console or the receiver into the controller, the
// mixer's limits (ForceLimits) from the output stage, and what the mixer gave up (MixLimit bits)
// back to the controller's integrators. fly_app.cpp wires them; each has its own unit tests that
// link that stage alone (tests/firmware/fly/CMakeLists.txt).
//
// Units (fixed point on the frame path: on the AVR a float sum or product costs ~100-170
// cycles, an integer one a few):
//   loop     kLoopHz frames a second; every count of frames derives from it (framesIn)
//   IMU      raw counts as the MPU-6050 gives them at fly's settings: kGyroLsbPerDps, kAccelLsbPerG
//   rate     1/16 of a gyro count (kRadPerRateUnit rad/s), body p, q, r about x, y, z
//   angle    2^-22 rad (kRadPerAngleUnit), roll and pitch; independent of the loop rate
//   force    decigrams (0.1 g, ForceDg) per motor: the mixer, every output mode and the force
//            API (fw::ForceActuators::setForceDg) alike; nothing rounds to whole grams
//   torque   as the mixer takes it (TorqueDg): the force it adds to each motor, decigrams per
//            lever (roll, pitch) or per propeller torque arm (yaw)
// Axes are the body's: x forward, y left, z up; roll positive = right side down, pitch positive
// = nose down, yaw positive = nose left (docs/fly.md). The float types (Attitude, Setpoint,
// Torque) are the same quantities in SI units: settings, status and the reference the tests
// hold the fixed-point path to.
#pragma once
#include <stdint.h>

#include "fixed_point.hpp"

namespace fly {

// ---- the loop ----
constexpr uint16_t kLoopHz = 400;  // the loop and the ESC frames (hal::Esc at this rate)
constexpr uint16_t kFrameUs = static_cast<uint16_t>(1000000UL / kLoopHz);
constexpr float kFramePeriodS = 1.0f / kLoopHz;
static_assert(1000000UL % kLoopHz == 0, "a whole number of microseconds per frame");
// The frames in `ms` milliseconds, rounded up (a wait is never shorter than asked).
constexpr uint16_t framesIn(uint32_t ms) {
  return static_cast<uint16_t>((ms * kLoopHz + 999u) / 1000u);
}
// The milliseconds `frames` frames last, rounded down.
constexpr uint32_t msOfFrames(uint32_t frames) { return frames * 1000u / kLoopHz; }

constexpr uint8_t kMotors = 4;  // ESC outputs 0..3, one per calibration slot

// ---- the IMU's sample (the driver -> the estimator) ----
constexpr float kGyroLsbPerDps = 16.4f;   // +-2000 deg/s (GYRO_CONFIG FS_SEL 3)
constexpr int16_t kAccelLsbPerG = 4096;   // +-8 g (ACCEL_CONFIG AFS_SEL 2)
constexpr uint16_t kImuSampleHz = 1000;   // SMPLRT_DIV 0 with the low-pass on
static_assert(kImuSampleHz > kLoopHz, "a new sample for every frame");

// One sample in the IMU's axes (mounted as the body's), raw counts.
struct ImuSample {
  int16_t accel[3] = {0, 0, 0};
  int16_t temp = 0;
  int16_t gyro[3] = {0, 0, 0};
  bool fresh = false;  // DATA_RDY: a new sample since the last read
};

// ---- attitude and rates (the estimator -> the controller and the rules) ----
constexpr float kPi = 3.14159265f;
constexpr float kRadPerDeg = kPi / 180.0f;
constexpr float kDegPerRad = 180.0f / kPi;
constexpr float kRadPerRateUnit = kRadPerDeg / kGyroLsbPerDps / 16.0f;  // rad/s
constexpr float kRadPerAngleUnit = 1.0f / 4194304.0f;                   // 2^-22 rad
// Angles are held within +-100 rad (a board turned over and over while disarmed), far beyond
// any attitude flown, so an integral never wraps.
constexpr int32_t kMaxAngleUnits = static_cast<int32_t>(100.0f / kRadPerAngleUnit);

struct AttitudeQ {
  int32_t roll = 0;             // angle units
  int32_t pitch = 0;
  int32_t rate[3] = {0, 0, 0};  // rate units: p, q, r
};

struct Attitude {
  float roll_rad = 0;
  float pitch_rad = 0;
  float rate_rad_s[3] = {0, 0, 0};  // p, q, r about body x, y, z
};

// Radians to angle units and radians per second to rate units, rounded and saturated
// (settings, slow jobs).
inline int32_t angleUnits(float rad) { return roundToInt32(rad * (1.0f / kRadPerAngleUnit)); }
inline int32_t rateUnits(float rad_s) { return roundToInt32(rad_s * (1.0f / kRadPerRateUnit)); }
// Whole degrees to angle units, rounded: constant limits such as the crash limit.
constexpr int32_t angleUnitsOfDegrees(uint8_t deg) {
  return static_cast<int32_t>(deg * kRadPerDeg / kRadPerAngleUnit + 0.5f);
}

// ---- the setpoint (the console or the receiver -> the controller) ----
// Angle mode holds roll and pitch angles (the thesis's controller); rate mode holds roll and
// pitch rates (acro). Yaw is a rate in both.
enum class FlightMode : uint8_t { kAngle, kRate };

struct Setpoint {
  FlightMode mode = FlightMode::kAngle;
  float roll_rad = 0;  // angle mode
  float pitch_rad = 0;
  float roll_rate_rad_s = 0;  // rate mode
  float pitch_rate_rad_s = 0;
  float yaw_rate_rad_s = 0;
};

struct SetpointQ {
  FlightMode mode = FlightMode::kAngle;
  int32_t roll = 0;             // angle units (angle mode)
  int32_t pitch = 0;
  int32_t rate[3] = {0, 0, 0};  // rate units: roll and pitch (rate mode), yaw (both)
};

// ---- torques (the controller -> the mixer) ----
struct Torque {
  float x_nm = 0;
  float y_nm = 0;
  float z_nm = 0;
};

struct TorqueDg {
  int32_t x = 0;  // decigrams per lever (Mixer::dgPerNmXy per N m)
  int32_t y = 0;
  int32_t z = 0;  // decigrams per propeller torque arm (Mixer::dgPerNmZ per N m)
};

// ---- forces (the mixer -> the output stage) ----
using ForceDg = int32_t;  // decigrams
constexpr int32_t kDgPerGram = 10;
inline ForceDg forceDgOf(float grams) {  // rounded; |grams| well within +-100,000
  const float dg = grams * kDgPerGram;
  return static_cast<ForceDg>(dg < 0 ? dg - 0.5f : dg + 0.5f);
}
inline float gramsOf(ForceDg force) { return static_cast<float>(force) * (1.0f / kDgPerGram); }
// Whole grams, rounded (what the console prints; the flight never rounds to them).
inline int32_t roundedGrams(ForceDg force) {
  return force >= 0 ? (force + kDgPerGram / 2) / kDgPerGram : -((kDgPerGram / 2 - force) / kDgPerGram);
}

struct Forces {
  ForceDg dg[kMotors] = {0, 0, 0, 0};
};

// The range the mixer works in, per motor, from the output stage (the mode's model of the
// motors), and the collective it centres on.
struct ForceLimits {
  ForceDg collective = 0;  // per motor, at full spool
  ForceDg min = 0;
  ForceDg max = 0;
};

// How the output stage turns forces into pulses (output_stage.hpp; docs/fly.md "Modes").
enum class OutputMode : uint8_t { kForce, kGeneric, kPwm, kArduPilot };

// What the mixer had to give up (Mixer::mix's result): the integrators of those axes hold.
enum MixLimit : uint8_t {
  kMixRollPitchLimited = 1u << 0,
  kMixYawLimited = 1u << 1,
  kMixCollectiveLimited = 1u << 2,
};

}  // namespace fly
