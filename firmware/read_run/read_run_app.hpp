// Read and Run (thesis sec. 6.5, appendix H): the flight-side program.
//
// Flow (main.cpp): hardware init -> banner -> loadCalibration() (H.2: the four EEPROM
// records, read once into per-motor structs) -> arm() (1000 us for 2 s) -> runOnce() forever,
// sleeping until the next interrupt between passes. Every ESC frame each motor's force command
// (grams) becomes a PWM through the model its slot holds:
//  - layout v1 (the thesis record, the baseline): the Force-PWM controller (H.3, option 2.1)
//    at the median battery reading, sag-compensated with that motor's offsets and last PWM
//    (sec. 6.2);
//  - layout v2 (thrustcal/model_v2.hpp): force is a curve in effective motor voltage
//    (pwm - start) * V_bus; PWM = start + drive(F) / V at the bus voltage filter (this frame's
//    reading, first-order IIR with a time constant of about 150 ms at every frame rate), the
//    bench sag of the step from the force the reading reflects to the command predicted.
//    Force beyond what the present voltage reaches saturates at the ESC maximum (flag
//    "saturated"); status shows each v2 motor's headroom.
// The slot loader (thrustcal/record_v2.hpp, tc::loadSlot) tells the layouts apart; a v2 slot
// keeps two copies and flies the newest valid one.
//
// Safety rules, all enforced here:
//  - a motor without a valid record (erased, bad version, bad CRC, bad content; for v2: both
//    copies bad) is never armed: it is held at 1000 us and every command to it is refused;
//    a record that cannot be right (thrustcal/plausibility.hpp: flat, non-monotone, pulses
//    outside the ESC range, voltages outside the monitor's range...) is bad content, and the
//    start-up report and `status` say which rule it broke;
//  - the battery monitor's divider is a stored board setting (thrustcal/board_settings.hpp,
//    `divider` command, default 100k/47k): counts -> volts and the voltage range a record may
//    hold follow it;
//  - failsafe: while any motor is commanded above 0 g, 500 ms without a keep-alive stops all
//    motors. The keep-alive is a complete, intact line (fw::LineReader: nothing lost or
//    garbled, text only, within 48 characters, checksum right when present), even an empty one
//    or one whose command is refused; with strict on only a line with a valid checksum counts
//    (an empty line: "*00"). Stray bytes and damaged lines keep nothing alive;
//  - the lift-off sequence drives the motors itself: empty lines (a bare CR, LF or CRLF) keep
//    it going, 500 ms without one stops it (loss of link), and any other byte aborts it at
//    once; the rest of that byte's line is discarded, never executed ("xf 2 450");
//  - commands that spin a motor (f above 0 g, liftoff) need a checksum with strict on;
//  - the main loop's period is bounded: one pass handles at most one input event of at most
//    kRxBytesPerPass bytes, serves the ESC frame, the failsafe and the lift-off timeout
//    (service()), then prints what service() noted. A reply longer than the transmit ring blocks in
//    hal::Uart::write, which runs service() from its wait hook, so frames stay on time;
//  - service() kicks the watchdog; nothing else in the loop does (docs/safety.md).
//
// Files, by lifetime: read_run_app.cpp (start-up, the loop's pass, failsafe, lift-off),
// frame.cpp (the ESC frame), commands.cpp (the console's command table and handlers: parsing,
// ranges, strict mode and help come from the table, firmware/common/shell.hpp),
// console_view.cpp (every line printed), run_rules.hpp (the pure decisions).
//
// The per-frame path (battery samples, voltage filter, both models, ESC write) is integer
// only; the image links no floating-point routine at all.
// Host tests drive the same class against the fake HAL.
//
// Measured on the ATmega2560 image in simavr 1.6 (cycles the CPU was awake, four motors
// running, whole ESC frame including the 1 ms ticks, the four ADC conversions and the median):
//   50 Hz: four v1 motors 18816 cycles per frame, four v2 motors 16608;
//   400 Hz: v1 28.0 % CPU, v2 23.8 %.
// Static SRAM 1895 bytes (avr-size), this object 1388 (`thrustcal bench footprint`): four
// slots of 169 bytes (tc::SlotModel: tc::ThesisRun 168 or tc::ModelV2Run 159), four Motor
// structs of 198 with their slot, the V2Frame (58) and the 414-byte battery median. At start-up
// tc::loadSlot decodes each record on the stack (tc::MotorCalibration 1114 + tc::ModelV2 124).
#pragma once
#include <stdint.h>

#include "console.hpp"
#include "hal/hal.hpp"
#include "record_report.hpp"
#include "thrustcal/battery_monitor.hpp"
#include "thrustcal/board_settings.hpp"
#include "thrustcal/eeprom_codec.hpp"
#include "thrustcal/force_pwm.hpp"
#include "thrustcal/limits.hpp"
#include "thrustcal/median_filter.hpp"
#include "thrustcal/model_v2.hpp"
#include "thrustcal/model_v2_runtime.hpp"
#include "thrustcal/motor_calibration.hpp"
#include "thrustcal/record_v2.hpp"
#include "thrustcal/slot_model.hpp"
#include "thrustcal/thesis_runtime.hpp"
#include "run_rules.hpp"

namespace rr {

using tc::SlotModel;  // thrustcal/slot_model.hpp
constexpr uint8_t kMotors = tc::kMotorSlots;
static_assert(kMotors == hal::kEscChannels, "one ESC output per calibration slot");

using tc::kArmMs;  // thrustcal/limits.hpp
using tc::kFailsafeMs;
using tc::kStopPwmUs;
constexpr uint16_t kForceMaxG = tc::kRecordMaxForceG;  // 5 kg: v1 curves saturate at 500 g
using tc::kBatteryWindow;
constexpr uint8_t kBatterySamplesPerFrame = 4;  // v2 filter input: mean of the middle two
constexpr uint16_t kLiftoffDefaultRampMs = 2000;  // `help` spells both (static_assert there)
constexpr uint16_t kLiftoffDefaultHoldMs = 5000;
constexpr uint16_t kLiftoffMaxMs = 60000;
constexpr uint16_t kLiftoffProgressMs = 500;  // one "# " progress line this often
constexpr uint8_t kStreamLinesPerSecond = 10;
constexpr uint8_t kNoLane = 0xFF;             // a motor that does not fly v2
// Received bytes one loop pass handles at most: one longest line and its CR LF.
constexpr uint8_t kRxBytesPerPass = fw::kLineMax + 2;

// One motor as the thesis's motor_struct: the model loaded from EEPROM plus the controller's
// run-time state.
struct Motor {
  SlotModel model;                               // v1 ThesisRun or v2 ModelV2Run (a union)
  tc::SlotLayout layout = tc::SlotLayout::kNone; // what the slot holds
  tc::DecodeStatus record = tc::DecodeStatus::kErased;  // kOk: `model` is loaded and flown
  uint8_t v2_copy = tc::kNoCopy;                 // v2: copy flown (0 = A, 1 = B)
  tc::DecodeStatus v2_copy_status[2] = {tc::DecodeStatus::kErased, tc::DecodeStatus::kErased};
  uint8_t lane = kNoLane;           // v2: its lane in the frame (command in, pulse out)
  tc::Plausibility why;             // record kBadContent: the plausibility rule it broke
  uint16_t force_g = 0;             // commanded force
  uint16_t pwm_us = kStopPwmUs;     // last pulse written to the ESC
  uint16_t vbat_mv = 0;             // voltage used for that pulse: v1 sag-compensated median,
                                    // v2 the bus filter's value
  uint8_t flags = 0;                // tc::ForcePwmFlag bits of that pulse

  bool isArmable() const { return record == tc::DecodeStatus::kOk; }
  bool fliesV2() const { return isArmable() && model.holdsV2(); }
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
  // One pass of the main loop: at most one input event (a line, or the lift-off's keep-alives
  // and abort key), service(), then the notes service() left. Does not sleep: the caller
  // sleeps until the next interrupt afterwards.
  void runOnce();

  // Observers (status command, tests).
  const Motor& motor(uint8_t index) const { return motors_[index]; }
  Mode mode() const { return mode_; }
  bool isRunning() const;               // any motor commanded above 0 g
  uint16_t batteryMv() const { return battery_mv_; }  // median reading, uncompensated
  const tc::BoardSettings& settings() const { return settings_; }
  // v2 motors' voltage: this frame's reading through the IIR filter, and its reciprocal.
  const tc::BusVoltageFilter& busFilter() const { return v2_.bus; }
  bool busSampleSane() const { return bus_sample_sane_; }  // this frame's reading was usable
  // v2: the bench sag of the commands the filtered voltage reflects (1/16 of 10 mV).
  const tc::BusSagFilter& sagFilter() const { return v2_.sag; }
  bool isStreaming() const { return stream_; }
  uint16_t frameHz() const { return frame_hz_; }
  uint8_t v2Motors() const { return v2_.count; }  // motors flying model v2
  // Lift-off progress: since its command, its force, whether it holds.
  uint32_t liftoffStartMs() const { return liftoff_start_ms_; }
  bool liftoffHolding() const { return liftoff_holding_; }
  uint16_t liftoffForceG() const { return liftoff_force_g_; }
  uint16_t liftoffHoldMs() const { return liftoff_hold_ms_; }
  uint32_t failsafeTrips() const { return failsafe_trips_; }
  const fw::LineReader& console() const { return line_; }

  // `help`: every row of the command table (usage, help text, ranges), then the console rules
  // with their constants. docs/read_run.md holds a copy a test compares with it.
  static void printHelp();

 private:
  friend struct Commands;  // commands.cpp: the console's command table and its handlers

  void handleLine(char* line);
  bool requireArmable(uint8_t index) const;  // prints the refusal when not
  void stopAll();                      // forces to 0, every ESC to 1000 us at once

  // The time-critical part of a pass, also run from inside a blocked write (the UART wait
  // hook): kicks the watchdog, the ESC frame when due (battery filter, models, pulses), the
  // failsafe and the lift-off link timeout. Prints nothing: it leaves notes_ for printNotes().
  void service();
  static void serviceHook();
  void handleInput();
  void printNotes();
  void checkFailsafe(uint32_t now_ms);
  void abortLiftoff(int16_t key);
  void updateLiftoff(uint32_t now_ms);

  void scheduleFrames(uint32_t now_ms);
  void setFrameRate(uint16_t frame_hz);  // filter constant and stream pace follow it
  void frame(uint32_t now_ms);
  void sampleBattery();
  void setFilterShift(uint16_t frame_hz);
  void setForce(uint8_t index, uint16_t force_g);  // a v2 motor's lane too
  void flyMotor(Motor& m);
  void prompt();

  Motor motors_[kMotors];
  tc::MedianFilter<kBatteryWindow> battery_counts_;
  tc::BoardSettings settings_;      // the divider (EEPROM), loaded with the calibration
  tc::BatteryMonitor monitor_;      // configured from settings_
  tc::V2Frame v2_;                  // the motors flying v2: bus filter, sag, their lanes
  bool bus_sample_sane_ = false;
  fw::LineReader line_;
  Mode mode_ = Mode::kBoot;
  uint16_t battery_mv_ = 0;
  uint32_t last_line_ms_ = 0;      // last keep-alive (lift-off: last line end)
  uint32_t failsafe_trips_ = 0;

  // service() -> printNotes()
  static constexpr uint8_t kNoteHold = 0x01;
  static constexpr uint8_t kNoteProgress = 0x02;
  static constexpr uint8_t kNoteDone = 0x04;
  static constexpr uint8_t kNoteLinkLost = 0x08;
  static constexpr uint8_t kNoteFailsafe = 0x10;
  static constexpr uint8_t kNoteStream = 0x20;
  uint8_t notes_ = 0;
  bool in_service_ = false;
  uint16_t note_force_g_ = 0;   // lift-off progress: force at that frame
  uint32_t note_ms_ = 0;        // time of the frame the notes are about
  static ReadRunApp* active_;   // the instance the UART wait hook serves

  FrameClock frames_;  // ESC frame schedule (run_rules.hpp)
  uint16_t frame_hz_ = hal::kEscDefaultFrameHz;

  bool stream_ = false;
  bool hold_prompt_ = false;  // the command's reply goes on (lift-off progress, stream rows)
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
