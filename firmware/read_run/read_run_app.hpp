// Read and Run (thesis sec. 6.5, appendix H): the flight-side program.
//
// Flow (main.cpp): hardware init -> banner -> loadCalibration() (H.2: the four EEPROM
// records, read once into per-motor structs) -> arm() (1000 us for 2 s) -> runOnce() forever,
// sleeping until the next interrupt between passes. Every ESC frame each motor's force command
// (grams) becomes a PWM through the Force-PWM controller (H.3, thesis option 2.1) at the
// battery voltage read now, sag-compensated with that motor's offsets and last PWM (sec. 6.2).
//
// Safety rules, all enforced here:
//  - a motor without a valid record (erased, bad version, bad CRC, bad content) is never
//    armed: it is held at 1000 us and every command to it is refused;
//  - failsafe: while any motor is commanded above 0 g, 500 ms without a complete command line
//    (any line, even an empty or rejected one, is a keep-alive) stops all motors;
//  - the lift-off sequence is its own command source (no failsafe while it runs), and any
//    received byte aborts it and stops the motors.
//
// The per-frame path (battery sample, compensation, controller, ESC write) is integer only.
// Host tests drive the same class against the fake HAL.
//
// Measured on the ATmega2560 image in simavr 1.6 (cycles the CPU was awake, four calibrated
// motors): armed and stopped 3.8 % CPU; four motors running at 50 Hz 5.6 %, at 400 Hz 26.6 %;
// peak stack about 170 bytes; static SRAM 5199 bytes (this object 4999: 4 x 1122 motors, 414
// battery median).
#pragma once
#include <stdint.h>

#include "console.hpp"
#include "hal/hal.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/median_filter.hpp"
#include "thrustcal/motor_calibration.hpp"

namespace rr {

constexpr uint8_t kMotors = tc::kMotorSlots;
static_assert(kMotors == hal::kEscChannels, "one ESC output per calibration slot");

constexpr uint16_t kArmMs = 2000;           // ESCs see 1000 us this long before any command
constexpr uint16_t kFailsafeMs = 500;       // no command line this long while running -> stop
constexpr uint16_t kStopPwmUs = 1000;       // ESC "motor off" pulse
constexpr uint16_t kForceMaxG = tc::kCurveGrams;
constexpr uint16_t kBatteryWindow = 101;    // thesis: median of 101 readings
constexpr uint8_t kBatterySamplesPerFrame = 4;
constexpr uint16_t kLiftoffDefaultRampMs = 2000;
constexpr uint16_t kLiftoffDefaultHoldMs = 5000;
constexpr uint16_t kLiftoffMaxMs = 60000;
constexpr uint16_t kLiftoffProgressMs = 500;  // one "# " progress line this often
constexpr uint8_t kStreamLinesPerSecond = 10;

// One motor as the thesis's motor_struct: the constants from EEPROM plus the controller's
// run-time state.
struct Motor {
  tc::MotorCalibration cal;
  tc::DecodeStatus record = tc::DecodeStatus::kErased;
  uint16_t force_g = 0;             // commanded force
  uint16_t pwm_us = kStopPwmUs;     // last pulse written to the ESC
  uint16_t vbat_mv = 0;             // sag-compensated battery used for that pulse
  uint8_t flags = 0;                // tc::ForcePwmFlag bits of that pulse

  bool isArmable() const { return record == tc::DecodeStatus::kOk; }
};

enum class Mode : uint8_t {
  kBoot,     // before arm()
  kArming,   // 1000 us on every ESC, input ignored
  kReady,    // accepting commands (motors stopped or running)
  kLiftoff,  // the lift-off sequence drives the motors
};

class ReadRunApp {
 public:
  // Prints the program name and how to get help.
  void printBanner();
  // H.2: reads the four EEPROM records once into the motor structs and reports each slot.
  // Returns how many motors are calibrated.
  uint8_t loadCalibration();
  // Holds every ESC at 1000 us for kArmMs while the battery median fills; input received
  // meanwhile is discarded (a command typed before "armed" never spins a motor). Blocks.
  void arm();
  // One pass of the main loop: commands (or lift-off abort), failsafe, and the ESC frame when
  // it is due. Does not sleep: the caller sleeps until the next interrupt afterwards.
  void runOnce();

  // Observers (status command, tests).
  const Motor& motor(uint8_t index) const { return motors_[index]; }
  Mode mode() const { return mode_; }
  bool isRunning() const;               // any motor commanded above 0 g
  uint16_t batteryMv() const { return battery_mv_; }  // median reading, uncompensated
  bool isStreaming() const { return stream_; }
  uint32_t failsafeTrips() const { return failsafe_trips_; }

 private:
  void handleLine(char* line);
  void commandHelp();
  void commandForce(char** tokens, uint8_t count);
  void commandStop();
  void commandStatus();
  void commandLiftoff(char** tokens, uint8_t count);
  void commandStream(char** tokens, uint8_t count);
  void commandRate(char** tokens, uint8_t count);

  bool requireArmable(uint8_t index);  // prints the refusal when not
  void stopAll();                      // forces to 0, every ESC to 1000 us at once
  void checkFailsafe(uint32_t now_ms);
  void abortLiftoff();
  void updateLiftoff(uint32_t now_ms);
  void printLiftoffProgress(uint32_t elapsed_ms, uint16_t force_g);

  void scheduleFrames(uint32_t now_ms);
  bool frameDue(uint32_t now_ms) const;
  void frame(uint32_t now_ms);
  void sampleBattery();
  void streamLine(uint32_t now_ms);
  void prompt();

  Motor motors_[kMotors];
  tc::MedianFilter<kBatteryWindow> battery_counts_;
  tc::BatteryMonitor monitor_;
  fw::LineReader line_;
  Mode mode_ = Mode::kBoot;
  uint16_t battery_mv_ = 0;
  uint32_t last_line_ms_ = 0;
  uint32_t failsafe_trips_ = 0;

  // ESC frame schedule: period 1000/hz ms as whole ms plus a remainder, so 400 Hz averages
  // exactly 2.5 ms on a 1 ms clock.
  uint32_t next_frame_ms_ = 0;
  uint16_t frame_rem_ = 0;
  uint16_t frame_hz_ = hal::kEscDefaultFrameHz;

  bool stream_ = false;
  uint8_t stream_every_frames_ = 5;
  uint8_t stream_countdown_ = 0;

  uint32_t liftoff_start_ms_ = 0;
  uint32_t liftoff_next_progress_ms_ = 0;
  uint16_t liftoff_force_g_ = 0;
  uint16_t liftoff_ramp_ms_ = 0;
  uint16_t liftoff_hold_ms_ = 0;
  bool liftoff_holding_ = false;
};

}  // namespace rr
